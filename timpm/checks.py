"""Checks of user values shared by the model's builders: each error names the value."""
import math

import numpy as np

__all__ = ["positive", "positive_int", "vector"]


def positive(name: str, value) -> float:
    """``value`` as a positive finite float."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number, got {value!r}") from None
    if not math.isfinite(value) or value <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return value


def positive_int(name: str, value) -> int:
    """``value`` as a positive int (a bool, a float or a string is refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    return int(value)


def vector(name: str, value, dim=None) -> np.ndarray:
    """``value`` as a finite float vector, of ``dim`` components where given."""
    try:
        v = np.array(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a sequence of numbers, got {value!r}") from None
    if dim is not None and len(v) != dim:
        raise ValueError(f"{name} must have {dim} components, got {len(v)}: {value!r}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v
