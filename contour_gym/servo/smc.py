"""Paper 001's sliding-mode control, with disturbance observer (``smc_dob``) and without (``smc``).

Plant model the law assumes (per axis, from the stage's nominal parameters)::

    x'' = -a x' + b u + D,      a = damping / mass,  b = force_constant / mass

with ``D`` the lumped disturbance (external force, friction, ripple and model error, per unit
mass). Reconstructed (001's eqs. 13-16 are lost; the text gives a sliding surface on the
tracking error, a switching gain the observer lets shrink, and a Lyapunov proof requiring the
gain to exceed the observer's error) in the standard form:

* surface (eq. 13): ``S = e' + c e``, ``e = r - y``;
* law (eq. 14): ``u = (r'' + a y' + c e' + lambda S + eta sat(S / phi) - D_hat) / b``, with the
  exponential reaching term ``lambda S`` and ``sat`` the boundary layer of width ``phi`` in
  place of ``sgn``;
* then ``S' = -lambda S - eta sat(S / phi) - (D - D_hat)``; with ``V = S^2 / 2`` (eq. 17),
  ``V' < 0`` outside the layer when ``eta > |D - D_hat|`` (eqs. 18-20). Without observer
  (``l = 0``, ``D_hat = 0``) that needs ``eta > |D|``: 001's large gain.

Disturbance observer (eqs. 15-16, lost): Chen's nonlinear DOB (Chen 2004),
``z' = -l z - l (l x' - a x' + b u)``, ``D_hat = z + l x'``, i.e. ``D_hat' = l (D - D_hat)``,
discretised with forward Euler in that z-form, which amounts to measuring the disturbance from
the change of the backward-difference velocity, the velocity and the applied control taken at
the same instant (their midpoints)::

    D_meas = (v_k - v_{k-1}) / ts + a (v_k + v_{k-1}) / 2 - b (u_{k-1} + u_{k-2}) / 2
    D_hat <- D_hat + l ts (D_meas - D_hat)

``u`` is the control that drove the plant (saturated; on the rig, the delayed command) minus the
friction compensation, so the observer estimates what the compensation leaves.

Defaults (``omega`` the bandwidth of the preset's PID, ``D_max`` :func:`disturbance_bound`):
``c = lambda = omega``; ``eta = 0.1 D_max`` with the observer (it only covers the observer's
residual), ``D_max`` without; ``phi = 0.1 D_max / omega`` (inside the layer the switching term
is a linear gain ``omega`` with the observer); observer gain ``l = min(8 omega, 0.8 / ts)``
(chosen on ``xyz_pmlsm``: the documentation's "Measurements and design notes"). Without the
observer the gain on S inside the layer is ``11 omega``; where
``11 omega ts > 1`` the sampled layer overshoots every tick: 001's chattering.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import ArrayLike

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import non_negative, positive
from contour_gym.plant.friction import law_for
from contour_gym.servo.base import (
    AxisController,
    loop_bandwidth,
    measured_velocity,
    nominal_model,
    option,
    register_controller,
    rows,
)

if TYPE_CHECKING:
    from contour_gym.plant.params import AxisParams
    from contour_gym.plant.stage import Stage
    from contour_gym.servo.gains import PIDGains

ETA_DOB_RATIO = 0.1  # smc_dob switching gain as a fraction of D_max
DOB_SPEEDUP = 8.0  # observer bandwidth / loop bandwidth
DOB_MAX_STEP = 0.8  # largest Euler step l ts of the observer
D_FLOOR = 0.01  # least disturbance bound, fraction of the axis' peak acceleration K u_max / m

PARAMS = Schema(
    "smc",
    c=Param(check=positive, doc="surface slope, 1/s"),
    reaching=Param(check=non_negative, doc="reaching gain lambda, 1/s"),
    eta=Param(check=positive, doc="switching gain, m/s^2"),
    phi=Param(check=positive, doc="boundary layer, m/s"),
    observer_gain=Param(0.0, non_negative, "observer gain l, 1/s (0 = no observer)"),
    a=Param(check=non_negative, doc="nominal damping / mass, 1/s"),
    b=Param(check=positive, doc="nominal force constant / mass"),
)
STATE = state_schema("smc state", "n", "y_prev", "v_prev", "u1", "u2", "d_hat")
C, S = PARAMS.col, STATE.col


def disturbance_bound(axis: AxisParams) -> float:
    """Bound ``D_max`` of the lumped disturbance acceleration of an axis, m/s^2.

    ``(|step| + |sinusoid| + 3 sigma_random + F_break_away + F_ripple) / m``, with the friction
    law's break-away force and the ripple's summed amplitudes, and at least ``D_FLOOR`` of the
    peak acceleration ``K u_max / m`` (for unmodelled dynamics when the axis has none).
    """
    force = 0.0
    d = axis.disturbance
    if d is not None:
        force += abs(d.step_amp) + abs(d.sin_amp) + 3.0 * d.random_std
    force += law_for(axis.friction).break_away(axis.friction)
    if axis.ripple is not None:
        force += float(np.sum(np.hypot(axis.ripple.sin_amp, axis.ripple.cos_amp)))
    floor = D_FLOOR * axis.force_constant * axis.u_max
    return max(force, floor) / axis.mass


@numba.njit(cache=True, inline="always")
def dob_estimate(p, s, i, v, ts):
    """The observer's ``D_hat`` after this tick's measurement (module docstring)."""
    if p[i, C.observer_gain] == 0.0 or s[i, S.n] < 2.0:
        return s[i, S.d_hat]
    acc = (v - s[i, S.v_prev]) / ts
    u_mid = 0.5 * (s[i, S.u1] + s[i, S.u2])
    meas = acc + p[i, C.a] * 0.5 * (v + s[i, S.v_prev]) - p[i, C.b] * u_mid
    return s[i, S.d_hat] + p[i, C.observer_gain] * ts * (meas - s[i, S.d_hat])


@numba.njit(cache=True, inline="always")
def control(p, s, i, r, r_dot, r_ddot, y, ts):
    """001's sliding-mode law with boundary layer, minus the observed disturbance."""
    v = measured_velocity(s[i, S.n], s[i, S.y_prev], y, ts)
    e_dot = r_dot - v
    surf = e_dot + p[i, C.c] * (r - y)
    sat = min(1.0, max(-1.0, surf / p[i, C.phi]))
    acc = r_ddot + p[i, C.a] * v + p[i, C.c] * e_dot + p[i, C.reaching] * surf + p[i, C.eta] * sat
    return (acc - dob_estimate(p, s, i, v, ts)) / p[i, C.b]


@numba.njit(cache=True, inline="always")
def commit(p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max):
    """Advance the observer; remember the measurement, velocity and applied control."""
    v = measured_velocity(s[i, S.n], s[i, S.y_prev], y, ts)
    s[i, S.d_hat] = dob_estimate(p, s, i, v, ts)
    s[i, S.u2] = s[i, S.u1]
    s[i, S.u1] = u_applied - u_comp
    s[i, S.v_prev] = v
    s[i, S.y_prev] = y
    s[i, S.n] += 1.0


def smc_defaults(stage: Stage, gains: Sequence[PIDGains], observer: bool) -> dict[str, np.ndarray]:
    """Default ``c``, ``reaching``, ``eta``, ``phi``, ``observer_gain`` per axis (module doc)."""
    omega = loop_bandwidth(stage, gains)
    d_max = np.array([disturbance_bound(a) for a in stage.axes])
    eta_dob = ETA_DOB_RATIO * d_max
    gain = np.minimum(DOB_SPEEDUP * omega, DOB_MAX_STEP / stage.ts)
    return {
        "c": omega,
        "reaching": omega,
        "eta": eta_dob if observer else d_max,
        "phi": eta_dob / omega,
        "observer_gain": gain if observer else np.zeros_like(omega),
    }


def _build(
    stage: Stage, gains: Sequence[PIDGains], batch: int, *, observer: bool,
    c: ArrayLike | None = None, reaching: ArrayLike | None = None, eta: ArrayLike | None = None,
    phi: ArrayLike | None = None, observer_gain: ArrayLike | None = None,
    mass: ArrayLike | None = None, damping: ArrayLike | None = None,
    force_constant: ArrayLike | None = None,
) -> np.ndarray:
    n, d = stage.n_axes, smc_defaults(stage, gains, observer)
    if not observer and observer_gain is not None:
        raise ValueError("smc has no observer; use smc_dob to set observer_gain")
    gain = np.zeros(n)
    if observer:
        gain = option(observer_gain, d["observer_gain"], n, "observer_gain")
    if np.any(gain * stage.ts > 1.0):
        raise ValueError(f"observer_gain * ts must be <= 1, got {(gain * stage.ts).tolist()}")
    a, b = nominal_model(stage, mass, damping, force_constant)
    return rows(
        PARAMS, batch, n, c=option(c, d["c"], n, "c"),
        reaching=option(reaching, d["reaching"], n, "reaching", allow_zero=True),
        eta=option(eta, d["eta"], n, "eta"), phi=option(phi, d["phi"], n, "phi"),
        observer_gain=gain, a=a, b=b,
    )


def build_dob(
    stage: Stage, gains: Sequence[PIDGains], batch: int, *, c: ArrayLike | None = None,
    reaching: ArrayLike | None = None, eta: ArrayLike | None = None,
    phi: ArrayLike | None = None, observer_gain: ArrayLike | None = None,
    mass: ArrayLike | None = None, damping: ArrayLike | None = None,
    force_constant: ArrayLike | None = None,
) -> np.ndarray:
    """``smc_dob`` rows: the defaults of the module docstring, any option overridden."""
    return _build(
        stage, gains, batch, observer=True, c=c, reaching=reaching, eta=eta, phi=phi,
        observer_gain=observer_gain, mass=mass, damping=damping, force_constant=force_constant,
    )


def build_plain(
    stage: Stage, gains: Sequence[PIDGains], batch: int, *, c: ArrayLike | None = None,
    reaching: ArrayLike | None = None, eta: ArrayLike | None = None,
    phi: ArrayLike | None = None, observer_gain: ArrayLike | None = None,
    mass: ArrayLike | None = None, damping: ArrayLike | None = None,
    force_constant: ArrayLike | None = None,
) -> np.ndarray:
    """``smc`` rows (no observer, 001's large switching gain)."""
    return _build(
        stage, gains, batch, observer=False, c=c, reaching=reaching, eta=eta, phi=phi,
        observer_gain=observer_gain, mass=mass, damping=damping, force_constant=force_constant,
    )


SMC_DOB = register_controller(
    AxisController("smc_dob", PARAMS, STATE, control, commit, build_dob,
                   doc="001: sliding-mode control with disturbance observer")
)
SMC = register_controller(
    AxisController("smc", PARAMS, STATE, control, commit, build_plain,
                   doc="001: sliding-mode control without observer (large switching gain)")
)
