"""One check for configuration values: the message names the value and its allowed range.

Every ``*Config`` of the perception side validates its fields through
:func:`check_fields`, so a value out of range reads the same everywhere::

    FieldConfig.w_min must be in [0, 1], got 1.5
    InstanceConfig.min_cluster_size must be an integer in [2, inf), got 1
    InstanceConfig.selection must be one of eom, leaf, got 'median'

>>> check_fields("Demo", {"p": 1.5}, {"p": Interval(0, 1)}, ValueError)
Traceback (most recent call last):
...
ValueError: Demo.p must be in [0, 1], got 1.5
>>> str(Interval(0, None, low_open=True)), str(Interval(2, integer=True))
('(0, inf)', 'integer in [2, inf)')
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Interval:
    """Allowed real (or, with ``integer``, whole) values between ``low`` and ``high``
    (``None``: unbounded), each end closed unless ``low_open`` / ``high_open``. NaN and
    booleans are never inside, infinities only with ``infinite`` (at an unbounded end)."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    infinite: bool = False

    def __contains__(self, value: object) -> bool:
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        if self.integer and not isinstance(value, int):
            return False
        if math.isnan(value) or (math.isinf(value) and not self.infinite):
            return False
        if math.isinf(value):
            return (self.high is None) if value > 0 else (self.low is None)
        above_low = (
            self.low is None or value > self.low or (value == self.low and not self.low_open)
        )
        below_high = (
            self.high is None or value < self.high or (value == self.high and not self.high_open)
        )
        return above_low and below_high

    def __str__(self) -> str:
        left = "(" if self.low is None or self.low_open else "["
        right = ")" if (self.high is None and not self.infinite) or self.high_open else "]"
        low = "-inf" if self.low is None else _number(self.low)
        high = "inf" if self.high is None else _number(self.high)
        return f"{'integer in ' if self.integer else ''}{left}{low}, {high}{right}"


#: A field's allowed values: an interval, or the strings it may take.
Allowed = Interval | tuple[str, ...]


def check_fields(
    owner: str,
    values: Mapping[str, Any],
    allowed: Mapping[str, Allowed],
    error: type[Exception],
) -> None:
    """Raise ``error`` for the first field of ``allowed`` whose value in ``values`` is not
    allowed, naming ``owner.field``, what it may be and what it is."""
    for name, rule in allowed.items():
        value = values[name]
        if isinstance(rule, Interval):
            if value not in rule:
                raise error(f"{owner}.{name} must be {_article(rule)}{rule}, got {value!r}")
        elif not isinstance(value, str) or value not in rule:
            raise error(f"{owner}.{name} must be one of {', '.join(rule)}, got {value!r}")


def _article(rule: Interval) -> str:
    return "an " if rule.integer else "in "


def _number(x: float) -> str:
    return str(int(x)) if float(x).is_integer() else repr(float(x))


__all__ = ["Allowed", "Interval", "check_fields"]
