"""Checks of parameter values: the one family every dataclass and function validates with.

Each check raises :class:`~robust_ismpc.exceptions.ParameterError` with one line naming the
value (``owner.name``, or ``owner name`` when ``owner`` ends with ``:``, e.g. a file) and the
rule it breaks. Booleans are not numbers here.
"""

from __future__ import annotations

import math

import numpy as np

from .exceptions import ParameterError

_REAL_TYPES = (int, float, np.integer, np.floating)


def _label(owner: str, name: str) -> str:
    if not owner:
        return name
    return f"{owner} {name}" if owner.endswith(":") else f"{owner}.{name}"


def is_number(value, allow_inf: bool = False) -> bool:
    """True for a real number (not a bool) that is finite, or only not NaN with ``allow_inf``."""
    if isinstance(value, bool) or not isinstance(value, _REAL_TYPES):
        return False
    return not math.isnan(value) if allow_inf else math.isfinite(value)


def check_number(owner: str, allow_inf: bool = False, **values: float) -> None:
    """Every value is a finite number (with ``allow_inf``: any number but NaN)."""
    for name, value in values.items():
        if not is_number(value, allow_inf):
            kind = "a number" if allow_inf else "a finite number"
            raise ParameterError(f"{_label(owner, name)} must be {kind}, got {value!r}")


def check_positive(owner: str, allow_inf: bool = False, **values: float) -> None:
    """Every value is a finite number > 0 (with ``allow_inf``: +inf too)."""
    for name, value in values.items():
        if not is_number(value, allow_inf) or value <= 0:
            kind = "a number > 0 (inf allowed)" if allow_inf else "a finite number > 0"
            raise ParameterError(f"{_label(owner, name)} must be {kind}, got {value!r}")


def check_nonnegative(owner: str, **values: float) -> None:
    """Every value is a finite number >= 0."""
    for name, value in values.items():
        if not is_number(value) or value < 0:
            raise ParameterError(f"{_label(owner, name)} must be a finite number >= 0, got {value!r}")


def check_fraction(owner: str, **values: float) -> None:
    """Every value is a number in [0, 1]."""
    for name, value in values.items():
        if not is_number(value) or not 0.0 <= value <= 1.0:
            raise ParameterError(f"{_label(owner, name)} must be in [0, 1], got {value!r}")


def check_vector(owner: str, name: str, value, size: int, allow_inf: bool = False) -> np.ndarray:
    """``value`` as a float array of shape ``(size,)`` of finite numbers (with ``allow_inf``: not
    NaN).

    Returns
    -------
    ndarray, shape (size,)
        A new array.
    """
    kind = "numbers (not NaN)" if allow_inf else "finite numbers"
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{_label(owner, name)} must be {size} {kind}, got {value!r}") from None
    if arr.shape != (size,) or not bool(np.all(~np.isnan(arr) if allow_inf else np.isfinite(arr))):
        raise ParameterError(f"{_label(owner, name)} must be {size} {kind}, got {value!r}")
    return arr
