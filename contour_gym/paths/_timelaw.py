"""Time laws: a reference prescribed as arc length against time, ``s(t)``.

The papers command some contours as functions of time rather than at a feedrate: 003's three-leaf
``x = r cos(6 pi f t) cos(2 pi f t)`` runs its parameter ``theta = 2 pi f t`` at a constant rate,
so the path speed ``|dC/dtheta| 2 pi f`` varies threefold along the curve. A :class:`TimeLaw`
holds such an ``s(t)`` on a uniform grid (the interpolator evaluates it by cubic Hermite
interpolation of ``s`` and ``s'``); a :class:`~contour_gym.paths.Path` may carry one
(:meth:`~contour_gym.paths.Path.with_time_law`), and the servo loop then follows it instead of a
feedrate.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from contour_gym._validate import positive

Array = NDArray[np.float64]

# 5-point Gauss-Legendre nodes and weights on [0, 1] (exact for polynomials of degree 9)
_GL_X, _GL_W = np.polynomial.legendre.leggauss(5)
_GL_X, _GL_W = 0.5 * (_GL_X + 1.0), 0.5 * _GL_W


@dataclass(frozen=True)
class TimeLaw:
    """A prescribed reference ``s(t)`` on a uniform grid (cubic Hermite in between).

    Attributes:
        dt: Grid step, s.
        s: (m,) arc length at ``k dt``, m (non-decreasing, from 0 to the path length).
        v: (m,) its time derivative, m/s.
        label: What the law is (for reports).
    """

    dt: float
    s: Array = field(repr=False)
    v: Array = field(repr=False)
    label: str = ""

    def __post_init__(self) -> None:
        positive(self.dt, "dt")
        s, v = np.asarray(self.s, dtype=float), np.asarray(self.v, dtype=float)
        if s.ndim != 1 or s.shape != v.shape or s.size < 2:
            raise ValueError("time law s and v must be 1-D of the same length >= 2")
        for name, arr in (("s", s), ("v", v)):
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise ValueError(f"time law {name} must be finite, got {arr[bad[0]]} at {bad[0]}")
        drop = np.flatnonzero(np.diff(s) < 0)
        if s[0] != 0.0 or drop.size:
            at = f"s[0] = {s[0]}" if s[0] != 0.0 else f"s[{drop[0] + 1}] = {s[drop[0] + 1]}"
            raise ValueError(f"time law s must start at 0 and not decrease, got {at}")
        neg = np.flatnonzero(v < 0)
        if neg.size:
            raise ValueError(f"time law v must be >= 0, got v[{neg[0]}] = {v[neg[0]]}")
        for name, arr in (("s", s), ("v", v)):
            arr = np.ascontiguousarray(arr)
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    @property
    def duration(self) -> float:
        """Time to traverse the path at override 1, s."""
        return self.dt * (self.s.size - 1)

    @property
    def length(self) -> float:
        """Arc length at the end, m."""
        return float(self.s[-1])

    def mean_speed(self) -> float:
        """Path length / duration, m/s."""
        return self.length / self.duration

    @classmethod
    def from_functions(
        cls, s_of_t: Callable[[Array], Array], v_of_t: Callable[[Array], Array],
        duration: float, dt: float = 1e-3, label: str = "",
    ) -> TimeLaw:
        """Sample ``s(t)`` and ``s'(t)`` on ``[0, duration]`` (rounded up to whole steps)."""
        t = _grid(duration, dt)
        return cls(dt, np.asarray(s_of_t(t), float), np.asarray(v_of_t(t), float), label)

    @classmethod
    def from_speed(
        cls, speed: Callable[[Array], Array], duration: float, dt: float = 1e-3,
        label: str = "",
    ) -> TimeLaw:
        """Integrate a path speed ``|dC/dt|(t)`` on ``[0, duration]``.

        Each grid step is integrated by 5-point Gauss-Legendre quadrature (exact to about
        1e-15 for a speed smooth on the step), so ``s`` is accurate whatever ``dt``.

        Args:
            speed: Vectorised path speed, m/s, as a function of time.
            duration: End time, s (> 0; rounded up to a whole number of steps).
            dt: Grid step, s.
            label: What the law is.
        """
        t = _grid(duration, dt)
        nodes = t[:-1, None] + dt * _GL_X[None, :]
        steps = dt * (np.asarray(speed(nodes), float) @ _GL_W)
        s = np.concatenate(([0.0], np.cumsum(steps)))
        return cls(dt, s, np.asarray(speed(t), float), label)

    def scaled_to(self, length: float) -> TimeLaw:
        """The same timing with ``s`` (and ``v``) scaled to end exactly at ``length``."""
        k = positive(length, "length") / positive(self.length, "time law length")
        return TimeLaw(self.dt, self.s * k, self.v * k, self.label)

    def repeat(self, laps: int) -> TimeLaw:
        """The law run ``laps`` times back to back (a closed path traced ``laps`` times)."""
        if not isinstance(laps, (int, np.integer)) or laps < 1:
            raise ValueError(f"laps must be a positive int, got {laps!r}")
        n = self.s.size - 1
        s = np.concatenate([self.s[:n] + k * self.length for k in range(laps)]
                           + [[laps * self.length]])
        v = np.concatenate([self.v[:n]] * laps + [self.v[-1:]])
        label = f"{self.label} x{laps}" if self.label else f"x{laps}"
        return TimeLaw(self.dt, s, v, label)


def _grid(duration: float, dt: float) -> Array:
    positive(dt, "dt")
    n = max(1, int(math.ceil(positive(duration, "duration") / dt - 1e-9)))
    return np.arange(n + 1, dtype=np.float64) * dt
