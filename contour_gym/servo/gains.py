"""Gains of the baseline per-axis PID (kept free of plant imports: the presets import it)."""

from __future__ import annotations

from dataclasses import dataclass

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
