"""Compiled per-axis controllers.

Layouts per batch member and axis: ``ctrl_p[..., CP_*]`` gains, ``ctrl_s[..., CS_*]`` state.
The PID integrates conditionally (the loop commits the integrator only when the summed
control is not saturated in the error's direction), so it does not wind up.
"""

from __future__ import annotations

import numba

CTRL_PID = 0

CP_KP, CP_KI, CP_KD, CP_KFF = 0, 1, 2, 3
N_CP = 24
CS_I, CS_EPREV, CS_HAS = 0, 1, 2
N_CS = 12


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


@numba.njit(cache=True)
def axis_control(kind, p, s, r, r_dot, r_ddot, y, ts):  # type: ignore[no-untyped-def]
    """Control signal of one axis (before CCC and saturation) for controller ``kind``.

    Args:
        kind: Controller kind (CTRL_*), the same for every axis and member of a loop.
        p: (N_CP,) parameters of this axis.
        s: (N_CS,) state of this axis (read here; updated by :func:`axis_commit`).
        r: Reference position, m.
        r_dot: Reference velocity, m/s.
        r_ddot: Reference acceleration, m/s^2.
        y: Measured position, m.
        ts: Servo tick, s.
    """
    return pid_output(p, s, r - y, r_dot, ts)


@numba.njit(cache=True)
def axis_commit(kind, p, s, r, r_dot, r_ddot, y, ts, u_total, u_max):  # type: ignore[no-untyped-def]
    """Update the controller state once the tick's total (unsaturated) control is known."""
    pid_commit(s, r - y, ts, u_total, u_max)
