"""Evaluation: metrics and protocols for reasoning over stored scenes."""
