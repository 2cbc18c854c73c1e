"""Gains of the baseline per-axis PID (kept free of plant imports: the presets import it)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from contour_gym._validate import as_finite_array


@dataclass(frozen=True)
class PIDGains:
    """Gains of one axis' position PID, in control units per metre.

    Attributes:
        kp: Proportional gain (u per m).
        ki: Integral gain (u per m s).
        kd: Derivative gain (u s per m).
        kff: Velocity feed-forward gain (u s per m); 0 in the papers' loops.
    """

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    kff: float = 0.0

    def __post_init__(self) -> None:
        vals = as_finite_array([self.kp, self.ki, self.kd, self.kff], "PID gains")
        if vals[0] <= 0 or np.any(vals[1:3] < 0):
            raise ValueError(f"PID gains need kp > 0 and ki, kd >= 0, got {self!r}")


def as_pid_gains(value: Any, name: str) -> PIDGains:
    """``value`` as :class:`PIDGains`: itself, or a mapping of its fields (``{"kp": ...}``).

    Raises:
        ValueError: naming ``name`` and the accepted fields.
    """
    if isinstance(value, PIDGains):
        return value
    accepted = [f.name for f in fields(PIDGains)]
    if isinstance(value, Mapping):
        unknown = sorted(set(value) - set(accepted))
        if not unknown and "kp" in value:
            return PIDGains(**value)
        raise ValueError(f"{name} needs kp and takes {', '.join(accepted)}; got {dict(value)!r}")
    raise ValueError(f"{name} must be a PIDGains or a mapping of {', '.join(accepted)}, "
                     f"got {value!r}")
