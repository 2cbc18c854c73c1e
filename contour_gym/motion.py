"""Interpolator: commanded feedrate -> arc length of the reference, one servo tick at a time.

The feedrate ``F`` (m/s along the path) may change at any decision; the path speed follows it
within an acceleration limit (and optionally a jerk limit), with a start ramp from rest and a
stop ramp that brings the reference to rest exactly at the end of the path.

Per batch member the kernel keeps ``ip_s = (s, v, a, done_tick)`` and reads
``ip_p = (F, a_max, j_max)``; ``inf`` limits mean "none". With ``a_max = inf`` the reference
moves at ``F`` from the first tick (the papers' ``x = R cos(w t)`` references) and
``s_k = k F Ts`` exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from contour_gym._validate import positive

IP_F, IP_AMAX, IP_JMAX = 0, 1, 2
N_IP = 3
IS_S, IS_V, IS_A, IS_DONE = 0, 1, 2, 3
N_IS = 4


@dataclass(frozen=True)
class Interpolator:
    """Feedrate profile settings.

    Attributes:
        feedrate: Commanded feedrate F, m/s (> 0).
        accel: Tangential acceleration limit, m/s^2 (``inf`` = step to F at once).
        jerk: Tangential jerk limit, m/s^3 (``inf`` = none).
    """

    feedrate: float
    accel: float = math.inf
    jerk: float = math.inf

    def __post_init__(self) -> None:
        positive(self.feedrate, "feedrate")
        if not math.isinf(self.accel):
            positive(self.accel, "accel")
        elif self.accel < 0:
            raise ValueError(f"accel must be > 0, got {self.accel!r}")
        if not math.isinf(self.jerk):
            positive(self.jerk, "jerk")
        elif self.jerk < 0:
            raise ValueError(f"jerk must be > 0, got {self.jerk!r}")

    def params(self, batch: int) -> np.ndarray:
        """Kernel parameter rows (batch, N_IP)."""
        out = np.empty((batch, N_IP))
        out[:] = (self.feedrate, self.accel, self.jerk)
        return out


def initial_state(batch: int) -> np.ndarray:
    """Kernel state rows (batch, N_IS) at rest at the start of the path."""
    out = np.zeros((batch, N_IS))
    out[:, IS_DONE] = -1.0
    return out


@numba.njit(cache=True, inline="always")
def stop_speed(remaining, v, a_max, j_max, ts):  # type: ignore[no-untyped-def]
    """Highest speed for the coming tick from which the reference can still stop in time.

    Picks ``v_new`` so that after this tick's travel ``(v + v_new) ts / 2`` the rest of the
    path still holds the braking distance ``v_new^2 / (2A) + v_new A / J``::

        v_new^2 / (2A) + v_new (A / J + ts / 2) <= remaining - v ts / 2

    ``A/J`` is twice the trapezoidal-acceleration profile's ramp term ``A/(2J)``: with that
    margin the jerk-limited profile joins the stop curve from below and never needs more
    than ``J``; the price is a final approach that decays with time constant ``A/J``. Without
    a jerk limit the term vanishes and the stop is the exact discrete constant-deceleration
    ramp.
    """
    if math.isinf(a_max):
        return math.inf
    room = remaining - 0.5 * v * ts
    if room <= 0.0:
        return 0.0
    c = 0.5 * ts + (0.0 if math.isinf(j_max) else 4.0 * a_max / (2.0 * j_max))
    return -a_max * c + math.sqrt((a_max * c) ** 2 + 2.0 * a_max * room)


@numba.njit(cache=True, inline="always")
def interp_tick(length, ts, p, st, b, k):  # type: ignore[no-untyped-def]
    """Advance member ``b``'s reference by one tick; marks ``done_tick`` at the path end.

    Args:
        length: Path length, m.
        ts: Tick, s.
        p: (B, N_IP) feedrate and limits.
        st: (B, N_IS) state; row ``b`` is updated in place.
        b: The member.
        k: Index of the tick being produced (``s`` after this call is the reference at k).
    """
    if st[b, IS_DONE] >= 0.0:
        return
    s, v, a = st[b, IS_S], st[b, IS_V], st[b, IS_A]
    a_max, j_max = p[b, IP_AMAX], p[b, IP_JMAX]
    target = min(max(p[b, IP_F], 0.0), stop_speed(length - s, v, a_max, j_max, ts))
    if math.isinf(a_max):
        v_new, a_new = target, 0.0
        s_new = s + v_new * ts
    else:
        dv = target - v
        if math.isinf(j_max):
            a_new = min(max(dv / ts, -a_max), a_max)
        else:
            # time-optimal approach to the target speed with zero final acceleration
            a_des = math.copysign(min(math.sqrt(2.0 * j_max * abs(dv)), a_max, abs(dv) / ts), dv)
            a_new = min(max(a_des, a - j_max * ts), a + j_max * ts)
        v_new = max(v + a_new * ts, 0.0)
        s_new = s + 0.5 * (v + v_new) * ts
    if s_new >= length - 1e-12 or (v_new == 0.0 and length - s_new < 1e-9):
        s_new, v_new, a_new = length, 0.0, 0.0
        st[b, IS_DONE] = k
    st[b, IS_S], st[b, IS_V], st[b, IS_A] = s_new, v_new, a_new
