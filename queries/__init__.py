"""queries: the structured graph-query language (DESIGN §6) and its executors.

Imports :mod:`graph_store` only; never imports torch.
"""
