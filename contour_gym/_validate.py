"""Input checks shared by every public constructor: bad input is a ValueError naming the value."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray


def as_finite_array(
    value: ArrayLike,
    name: str,
    *,
    ndim: int | None = None,
    shape: tuple[int | None, ...] | None = None,
) -> NDArray[np.float64]:
    """Return ``value`` as a float64 array, raising ValueError if it is non-finite or misshaped.

    Args:
        value: Anything numpy can turn into a float array.
        name: The argument's name, quoted in the error.
        ndim: Required number of dimensions, if any.
        shape: Required shape; ``None`` entries match any length.

    Returns:
        A float64 array (a copy when the input was not already float64).

    Raises:
        ValueError: if the value cannot be converted, has the wrong shape, or holds NaN/inf.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {value!r}") from exc
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimension(s), got shape {arr.shape}")
    if shape is not None and not _shape_matches(arr.shape, shape):
        want_txt = "(" + ", ".join("N" if s is None else str(s) for s in shape) + ")"
        raise ValueError(f"{name} must have shape {want_txt}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {_short(arr)}")
    return arr


def _shape_matches(got: tuple[int, ...], want: tuple[int | None, ...]) -> bool:
    if len(got) != len(want):
        return False
    return all(w is None or g == w for g, w in zip(got, want, strict=True))


def finite(value: Any, name: str) -> float:
    """Return ``value`` as a finite float or raise ValueError naming it."""
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if not np.isfinite(out):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return out


def number(value: Any, name: str) -> float:
    """Return ``value`` as a float that is not NaN (``inf`` allowed) or raise ValueError."""
    try:
        out = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a number, got {value!r}") from exc
    if out != out:
        raise ValueError(f"{name} must not be NaN, got {value!r}")
    return out


def positive_or_inf(value: Any, name: str) -> float:
    """Return ``value`` as a float > 0 (``inf`` allowed) or raise ValueError naming it."""
    out = number(value, name)
    if out <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return out


def positive(value: Any, name: str) -> float:
    """Return ``value`` as a finite float > 0 or raise ValueError naming it."""
    out = finite(value, name)
    if out <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return out


def non_negative(value: Any, name: str) -> float:
    """Return ``value`` as a finite float >= 0 or raise ValueError naming it."""
    out = finite(value, name)
    if out < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return out


def seed_value(value: Any, name: str = "seed") -> int:
    """Return ``value`` as a seed (a non-negative int, not a bool) or raise ValueError."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
        raise ValueError(f"{name} must be a non-negative int, got {value!r}")
    return int(value)


def choice(value: str, name: str, accepted: Iterable[str]) -> str:
    """Return ``value`` if it is one of ``accepted``, else raise ValueError listing them."""
    options = sorted(accepted)
    if value not in options:
        raise ValueError(f"unknown {name} {value!r}; accepted: {', '.join(options)}")
    return value


def _short(arr: NDArray[np.float64]) -> str:
    text = np.array2string(arr, threshold=8, edgeitems=2)
    return text if len(text) < 200 else text[:197] + "..."
