"""PID with velocity feed-forward: the presets' baseline axis controller (and the CCC's core).

``u = kp e + ki (I + e ts) + kd de/dt + kff r'``, ``e = r - y``; the derivative is the backward
difference of ``e`` (zero on the first tick). The integral is conditional: it is committed only
when the summed control is not saturated in the error's direction, so it does not wind up.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import non_negative, positive
from contour_gym.servo.base import AxisController, register_controller, rows

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage
    from contour_gym.servo.gains import PIDGains

PARAMS = Schema(
    "pid",
    kp=Param(check=positive, doc="proportional gain, u per m"),
    ki=Param(0.0, non_negative, "integral gain, u per m s"),
    kd=Param(0.0, non_negative, "derivative gain, u s per m"),
    kff=Param(0.0, non_negative, "velocity feed-forward, u s per m"),
)
STATE = state_schema("pid state", "integral", "e_prev", "started")
C, S = PARAMS.col, STATE.col


@numba.njit(cache=True, inline="always")
def pid_terms(kp, ki, kd, s, si, e, ts):
    """``kp e + ki (I + e ts) + kd de/dt`` with the PID state in row ``si`` of ``s``."""
    de = (e - s[si, S.e_prev]) / ts if s[si, S.started] > 0.0 else 0.0
    return kp * e + ki * (s[si, S.integral] + e * ts) + kd * de


@numba.njit(cache=True, inline="always")
def pid_commit(s, si, e, ts, u_total, u_max):
    """Store ``e`` for the next derivative and integrate unless saturated the same way."""
    if abs(u_total) < u_max or e * u_total < 0.0:
        s[si, S.integral] += e * ts
    s[si, S.e_prev] = e
    s[si, S.started] = 1.0


@numba.njit(cache=True, inline="always")
def control(p, s, i, r, r_dot, r_ddot, y, ts):
    """The PID's control of this tick (module docstring)."""
    u = pid_terms(p[i, C.kp], p[i, C.ki], p[i, C.kd], s, i, r - y, ts)
    return u + p[i, C.kff] * r_dot


@numba.njit(cache=True, inline="always")
def commit(p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max):
    """Commit the PID state (conditional integration)."""
    pid_commit(s, i, r - y, ts, u_total, u_max)


def pid_params(gains: Sequence[PIDGains], batch: int) -> np.ndarray:
    """Kernel parameter rows (batch, n_axes, PARAMS.size) for the given per-axis gains."""
    return rows(
        PARAMS, batch, len(gains), kp=[g.kp for g in gains], ki=[g.ki for g in gains],
        kd=[g.kd for g in gains], kff=[g.kff for g in gains],
    )


def build(stage: Stage, gains: Sequence[PIDGains], batch: int) -> np.ndarray:
    """The preset's gains."""
    return pid_params(gains, batch)


CONTROLLER = register_controller(
    AxisController("pid", PARAMS, STATE, control, commit, build,
                   doc="PID with velocity feed-forward (the presets' baseline)")
)
