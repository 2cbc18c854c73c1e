"""Paper 003's 2-DOF PID (eqs. 26-35): main PID plus a feed-forward PD with set-point weights.

``u = Kp {(1 - alpha) r - y + 1/TI int e dt + TD [(1 - beta) r' - y']}`` (eq. 34; eq. 35 is the
same for y1, y2): the main PID ``Kp (1 + 1 / (TI s) + TD s)`` on ``e`` (eqs. 26-27, 30-31) minus
the feed-forward PD ``Kp (alpha + beta TD s)`` on the command (eqs. 28-29, 32-33). The
extraction lost the operators; the integral and the derivatives are restored from eqs. 26-29.
``y'`` is the backward difference of ``y``, ``r'`` the interpolator's exact command velocity.
Stored as ``kp = Kp``, ``ki = Kp / TI``, ``kd = Kp TD``; the integral is the PID's
(conditional). Default (``build``): the preset's PID with ``alpha = beta = 0``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import ArrayLike

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import as_finite_array, non_negative
from contour_gym.servo.base import (
    AxisController,
    measured_velocity,
    register_controller,
)
from contour_gym.servo.pid import pid_commit

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage
    from contour_gym.servo.gains import PIDGains

PARAMS = Schema(
    "two_dof_pid",
    kp=Param(check=non_negative, doc="Kp, u per m"),
    ki=Param(0.0, non_negative, "Kp / TI, u per m s"),
    kd=Param(0.0, non_negative, "Kp TD, u s per m"),
    alpha=Param(0.0, doc="set-point weight of the P term (003's alpha)"),
    beta=Param(0.0, doc="set-point weight of the D term (003's beta)"),
)
STATE = state_schema("two_dof_pid state", "integral", "e_prev", "started", "n", "y_prev")
C, S = PARAMS.col, STATE.col
NAMES = ("kp", "ti", "td", "alpha", "beta")  # 003's five tunable numbers per axis


@numba.njit(cache=True, inline="always")
def control(p, s, i, r, r_dot, r_ddot, y, ts):
    """003 eq. 34 (module docstring)."""
    e = r - y
    v = measured_velocity(s[i, S.n], s[i, S.y_prev], y, ts)
    prop = (1.0 - p[i, C.alpha]) * r - y
    deriv = (1.0 - p[i, C.beta]) * r_dot - v
    return p[i, C.kp] * prop + p[i, C.ki] * (s[i, S.integral] + e * ts) + p[i, C.kd] * deriv


@numba.njit(cache=True, inline="always")
def commit(p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max):
    """Conditional integration; remember the measurement for the velocity."""
    pid_commit(s, i, r - y, ts, u_total, u_max)
    s[i, S.y_prev] = y
    s[i, S.n] += 1.0


def values_of(gains: Sequence[PIDGains]) -> np.ndarray:
    """The five tunable numbers (Kp, TI, TD, alpha, beta) per axis of a PID, (A, 5).

    ``TI = kp / ki`` (``inf`` when ``ki = 0``), ``TD = kd / kp``, ``alpha = beta = 0``.
    """
    return np.array(
        [[g.kp, g.kp / g.ki if g.ki > 0 else math.inf, g.kd / g.kp, 0.0, 0.0] for g in gains]
    )


def params_of(values: ArrayLike) -> np.ndarray:
    """Kernel rows of 003's 2-DOF PID from its five tunable numbers per axis.

    This is what an optimiser tuning 003's 15 axis parameters (eqs. 34-35) maps its points
    through before :meth:`contour_gym.loop.ServoLoop.set_controller_params`.

    Args:
        values: ``(..., n_axes, 5)`` of ``(Kp, TI, TD, alpha, beta)``: ``Kp > 0``,
            ``TI > 0`` (``inf`` = no integral), ``TD >= 0``, ``alpha`` and ``beta`` finite
            (003 eqs. 28-29; ``alpha = beta = 0`` is a plain PID). E.g. an optimiser's
            ``(B, 15)`` population reshaped to ``(B, 3, 5)``.

    Returns:
        ``(..., n_axes, PARAMS.size)`` rows (a new array).

    Raises:
        ValueError: for a wrong shape or an out-of-range value, naming it.
    """
    v = np.asarray(values, dtype=np.float64)
    if v.ndim < 2 or v.shape[-1] != 5:
        raise ValueError(f"two_dof_pid values must have shape (..., n_axes, 5), got {v.shape}")
    kp, ti, td, alpha, beta = np.moveaxis(v, -1, 0)
    as_finite_array(np.stack([kp, td, alpha, beta]), "two_dof_pid Kp, TD, alpha, beta")
    if np.any(np.isnan(ti)) or np.any(ti <= 0) or np.any(kp <= 0) or np.any(td < 0):
        raise ValueError("two_dof_pid needs Kp > 0, TI > 0 (inf allowed) and TD >= 0")
    out = np.zeros(v.shape[:-1] + (PARAMS.size,))
    out[..., C.kp], out[..., C.ki], out[..., C.kd] = kp, kp / ti, kp * td
    out[..., C.alpha], out[..., C.beta] = alpha, beta
    return out


def build(
    stage: Stage, gains: Sequence[PIDGains], batch: int, *, kp: ArrayLike | None = None,
    ti: ArrayLike | None = None, td: ArrayLike | None = None, alpha: ArrayLike | None = None,
    beta: ArrayLike | None = None,
) -> np.ndarray:
    """The preset's PID as a 2-DOF PID, any of the five numbers overridden per axis."""
    values = values_of(gains)
    for j, (name, given) in enumerate(zip(NAMES, (kp, ti, td, alpha, beta), strict=True)):
        if given is not None:
            arr = np.asarray(given, dtype=float)
            if arr.ndim > 1 or arr.size not in (1, stage.n_axes):
                raise ValueError(
                    f"{name} must be a scalar or {stage.n_axes} values, got {arr.shape}"
                )
            values[:, j] = np.broadcast_to(arr, (stage.n_axes,))
    return params_of(np.repeat(values[None], batch, axis=0))


CONTROLLER = register_controller(
    AxisController("two_dof_pid", PARAMS, STATE, control, commit, build,
                   doc="003 eqs. 26-35: 2-DOF PID with set-point weights")
)
