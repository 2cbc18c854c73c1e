"""Paper 001's comparison controller ("PD robust controller"; its equation is lost).

Reconstructed as the robust PD of the robot-control literature for a second-order plant with
bounded disturbance: nominal inverse-dynamics feed-forward plus PD feedback,
``u = (r'' + a y' + kp e + kd e') / b``, whose error is ultimately bounded by about
``|D|_max / kp`` without any switching term or observer. Defaults: ``kp = 2 omega^2``,
``kd = 3 omega`` (``omega`` the preset PID's bandwidth): the linear part of ``smc_dob`` inside
its boundary layer, so the comparison isolates the observer and the switching term.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import ArrayLike

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import non_negative, positive
from contour_gym.servo.base import (
    AxisController,
    measured_velocity,
    nominal_model,
    option,
    register_controller,
    rows,
)
from contour_gym.servo.smc import smc_defaults

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage
    from contour_gym.servo.gains import PIDGains

PARAMS = Schema(
    "pd_robust",
    kp=Param(check=positive, doc="1/s^2"), kd=Param(check=non_negative, doc="1/s"),
    a=Param(check=non_negative, doc="nominal damping / mass, 1/s"),
    b=Param(check=positive, doc="nominal force constant / mass"),
)
STATE = state_schema("pd_robust state", "n", "y_prev")
C, S = PARAMS.col, STATE.col


@numba.njit(cache=True, inline="always")
def control(p, s, i, r, r_dot, r_ddot, y, ts):
    """Inverse-dynamics feed-forward plus PD (module docstring)."""
    v = measured_velocity(s[i, S.n], s[i, S.y_prev], y, ts)
    acc = r_ddot + p[i, C.a] * v + p[i, C.kp] * (r - y) + p[i, C.kd] * (r_dot - v)
    return acc / p[i, C.b]


@numba.njit(cache=True, inline="always")
def commit(p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max):
    """Remember the measurement for the velocity."""
    s[i, S.y_prev] = y
    s[i, S.n] += 1.0


def build(
    stage: Stage, gains: Sequence[PIDGains], batch: int, *, kp: ArrayLike | None = None,
    kd: ArrayLike | None = None, mass: ArrayLike | None = None,
    damping: ArrayLike | None = None, force_constant: ArrayLike | None = None,
) -> np.ndarray:
    """The defaults of the module docstring, any option overridden."""
    n, d = stage.n_axes, smc_defaults(stage, gains, observer=True)
    layer = d["reaching"] + d["eta"] / d["phi"]  # smc_dob's gain on S inside its layer
    a, b = nominal_model(stage, mass, damping, force_constant)
    return rows(
        PARAMS, batch, n, kp=option(kp, d["c"] * layer, n, "kp"),
        kd=option(kd, d["c"] + layer, n, "kd"), a=a, b=b,
    )


CONTROLLER = register_controller(
    AxisController("pd_robust", PARAMS, STATE, control, commit, build,
                   doc="001's comparison: robust PD with nominal-model feed-forward")
)
