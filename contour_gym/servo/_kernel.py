"""Compiled per-axis controllers.

Layouts per batch member and axis: ``ctrl_p[..., CP_*]`` gains, ``ctrl_s[..., CS_*]`` state.
The PID integrates conditionally (the loop commits the integrator only when the summed
control is not saturated in the error's direction), so it does not wind up.
"""

from __future__ import annotations

import numba

CTRL_PID = 0

CP_KP, CP_KI, CP_KD, CP_KFF = 0, 1, 2, 3
N_CP = 8
CS_I, CS_EPREV, CS_HAS = 0, 1, 2
N_CS = 4


@numba.njit(cache=True)
def pid_output(p, s, e, r_dot, ts):  # type: ignore[no-untyped-def]
    """PID with velocity feed-forward: ``kp e + ki (I + e ts) + kd de/dt + kff r_dot``.

    The derivative is the backward difference of ``e`` (zero on the first tick).
    """
    de = (e - s[CS_EPREV]) / ts if s[CS_HAS] > 0.0 else 0.0
    integ = s[CS_I] + e * ts
    return p[CP_KP] * e + p[CP_KI] * integ + p[CP_KD] * de + p[CP_KFF] * r_dot


@numba.njit(cache=True)
def pid_commit(s, e, ts, u_total, u_max):  # type: ignore[no-untyped-def]
    """Store ``e`` for the next derivative and integrate unless saturated the same way."""
    if abs(u_total) < u_max or e * u_total < 0.0:
        s[CS_I] += e * ts
    s[CS_EPREV] = e
    s[CS_HAS] = 1.0
