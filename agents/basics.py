"""The pipeline's names and number reading, free of torch, SB3 and scipy imports: the ``vegym`` command builds its
parser from them, so that ``vegym --help`` and argument errors answer at once (the commands import the rest)."""

from __future__ import annotations

import math
from typing import Any

ALGO_NAMES = ("ppo", "sac", "td3")
"""The SB3 algorithms a config may name (its file name, ``configs/<algo>.yml``), lower-case class names."""

EVAL_SEED = 1000
"""First episode seed of evaluations; training uses small seeds, so the episodes differ."""


def as_number(value: Any) -> float | None:
    """``value`` as a float if it is a number or a string holding one (not a bool), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return float(value)
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return None
    return None


def whole_number(value: Any) -> int | None:
    """``value`` as an int if it is one, or a float or a string holding an integer, also one written as a float
    without a fraction (``1e5``); else None (bools too). Integers and integer strings are read exactly."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        try:
            return int(value)
        except ValueError:
            pass
    number = as_number(value)
    if number is None or not math.isfinite(number) or number != int(number):
        return None
    return int(number)
