"""Checks of scalar arguments shared by the parameter classes: one wording for every "must be" message.

A whole number is a Python or NumPy integer, never a bool (``True`` is not 1 plane); a real number is a Python or
NumPy int or float, never a bool.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["is_real", "whole_number", "finite_number"]


def is_real(value) -> bool:
    """Whether ``value`` is a real number (int or float, Python or NumPy, not a bool)."""
    return not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))


def whole_number(value, name: str, least: int, what: str) -> int:
    """``value`` as an ``int`` if it is a whole number ≥ ``least``; else
    ``ValueError("{name} must be {what}; got …")``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise ValueError(f"{name} must be {what}; got {value!r}")
    return int(value)


def finite_number(value, name: str, positive: bool = False) -> float:
    """``value`` as a ``float`` if it is a finite real number ≥ 0 (> 0 with ``positive``); else
    ``ValueError("{name} must be a finite number ≥ 0; got …")`` (``> 0``)."""
    if not is_real(value) or not math.isfinite(value) or value < 0 or (positive and value == 0):
        raise ValueError(f"{name} must be a finite number {'>' if positive else '≥'} 0; got {value!r}")
    return float(value)
