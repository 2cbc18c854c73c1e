"""Compiled per-axis controllers: PID, 2-DOF PID (003), SMC with/without DOB (001), robust PD (001).

Layouts: row tables with one row ``i`` per batch member and axis (``i = b * A + a``),
``p[i, CP_*]`` parameters and ``s[i, CS_*]`` state; the kernels index them rather than take
row views, which would each cost a reference-counting call (see
:mod:`contour_gym.plant._kernel`). :func:`axis_control` is the control of one tick (it only
reads the state); :func:`axis_commit` updates the state once the tick's total control is
known. Every axis measures only its position ``y``; velocities are backward differences of
``y``.

The PID integrates conditionally (the loop commits the integrator only when the summed
control is not saturated in the error's direction), so it does not wind up. Friction
compensation (paper 002 section 3) is an option of every controller, added to its output.

Plant model the model-based laws assume (per axis, from the stage's nominal parameters)::

    x'' = -a x' + b u + D,      a = damping / mass,  b = force_constant / mass

with ``D`` the lumped disturbance (external force, friction, ripple and model error, per unit
mass).
"""

from __future__ import annotations

import numba

from contour_gym.servo._friction import lugre_advance, lugre_force, lugre_rate, static_friction

CTRL_PID, CTRL_TWO_DOF_PID, CTRL_SMC, CTRL_PD_ROBUST = 0, 1, 2, 3

# parameter columns
CP_KP, CP_KI, CP_KD, CP_KFF = 0, 1, 2, 3  # pid; two_dof_pid uses kp, ki = kp/TI, kd = kp TD
CP_ALPHA, CP_BETA = 4, 5  # two_dof_pid set-point weights (003 eqs. 28-29)
CP_A, CP_B = 6, 7  # nominal damping/mass (1/s) and force_constant/mass (m/s^2 per unit u)
# smc: surface slope c (1/s), reaching gain lambda (1/s), switching gain eta (m/s^2), boundary
# layer phi (m/s), observer gain l (1/s; 0 = no observer)
CP_C, CP_LAMBDA, CP_ETA, CP_PHI, CP_L = 8, 9, 10, 11, 12
CP_PD_KP, CP_PD_KD = 13, 14  # pd_robust: 1/s^2, 1/s
CP_FR_MODE, CP_FR_INVK = 15, 16  # friction compensation mode, 1 / force_constant
CP_FR_S0, CP_FR_S1, CP_FR_S2, CP_FR_FC, CP_FR_FS, CP_FR_VS = 17, 18, 19, 20, 21, 22
N_CP = 24

FR_NONE, FR_FEEDFORWARD, FR_FEEDBACK, FR_FEEDBACK_STATIC = 0, 1, 2, 3

# state columns
CS_I, CS_EPREV, CS_HAS = 0, 1, 2  # pid (and the CCC, which reuses pid_output / pid_commit)
CS_N, CS_YPREV, CS_VPREV = 3, 4, 5  # ticks committed, last measurement, last velocity
CS_U1, CS_U2, CS_DHAT, CS_ZF = 6, 7, 8, 9  # applied u minus friction comp., DOB, bristle
N_CS = 12


@numba.njit(cache=True, inline="always")
def pid_output(p, pi, s, si, e, r_dot, ts):  # type: ignore[no-untyped-def]
    """PID with velocity feed-forward: ``kp e + ki (I + e ts) + kd de/dt + kff r_dot``.

    Gains come from row ``pi`` of ``p`` and the state from row ``si`` of ``s`` (an axis uses
    one row for both; the CCC keeps one state row per coordinate). The derivative is the
    backward difference of ``e`` (zero on the first tick).
    """
    de = (e - s[si, CS_EPREV]) / ts if s[si, CS_HAS] > 0.0 else 0.0
    integ = s[si, CS_I] + e * ts
    return p[pi, CP_KP] * e + p[pi, CP_KI] * integ + p[pi, CP_KD] * de + p[pi, CP_KFF] * r_dot


@numba.njit(cache=True, inline="always")
def pid_commit(s, si, e, ts, u_total, u_max):  # type: ignore[no-untyped-def]
    """Store ``e`` for the next derivative and integrate unless saturated the same way."""
    if abs(u_total) < u_max or e * u_total < 0.0:
        s[si, CS_I] += e * ts
    s[si, CS_EPREV] = e
    s[si, CS_HAS] = 1.0


@numba.njit(cache=True)
def measured_velocity(s, i, y, ts):  # type: ignore[no-untyped-def]
    """Backward difference of the measured position (0 on the first tick: it starts at rest)."""
    return (y - s[i, CS_YPREV]) / ts if s[i, CS_N] > 0.0 else 0.0


@numba.njit(cache=True)
def two_dof_pid_output(p, s, i, r, r_dot, y, ts):  # type: ignore[no-untyped-def]
    """2-DOF PID of paper 003, eq. 34 (one axis; eq. 35 is the same for y1, y2).

    ``u = Kp {(1 - alpha) r - y + 1/TI int e dt + TD [(1 - beta) r' - y']}``: the main PID
    ``Kp (1 + 1 / (TI s) + TD s)`` on ``e`` (eqs. 26-27, 30-31) minus the feed-forward PD
    ``Kp (alpha + beta TD s)`` on the command (eqs. 28-29, 32-33). The extraction lost the
    operators; the integral and the derivatives are restored from eqs. 26-29. ``y'`` is the
    backward difference of ``y``, ``r'`` the interpolator's exact command velocity. Stored as
    ``kp = Kp``, ``ki = Kp / TI``, ``kd = Kp TD``; the integral is the PID's (conditional).
    """
    e = r - y
    v = measured_velocity(s, i, y, ts)
    prop = (1.0 - p[i, CP_ALPHA]) * r - y
    deriv = (1.0 - p[i, CP_BETA]) * r_dot - v
    return p[i, CP_KP] * prop + p[i, CP_KI] * (s[i, CS_I] + e * ts) + p[i, CP_KD] * deriv


@numba.njit(cache=True)
def dob_estimate(p, s, i, v, ts):  # type: ignore[no-untyped-def]
    """Disturbance observer estimate ``D_hat`` after this tick's measurement (001 eqs. 15-16).

    001's observer equations are lost; its text (the observer "can be expressed as" a first-
    order convergence, and the stability proof assumes a slowly varying disturbance) is Chen's
    nonlinear DOB (Chen 2004): ``z' = -l z - l (l x' - a x' + b u)``, ``D_hat = z + l x'``,
    i.e. ``D_hat' = l (D - D_hat)``. Discretised with forward Euler in that z-form, which
    amounts to measuring the disturbance from the change of the backward-difference velocity;
    the velocity and the applied control are taken at the same instant (their midpoints)::

        D_meas = (v_k - v_{k-1}) / ts + a (v_k + v_{k-1}) / 2 - b (u_{k-1} + u_{k-2}) / 2
        D_hat <- D_hat + l ts (D_meas - D_hat)

    ``u`` is the applied (saturated) control minus any friction compensation, so the observer
    estimates what the compensation leaves. ``l = 0`` (no observer) or fewer than two
    velocities keep the stored estimate.
    """
    if p[i, CP_L] == 0.0 or s[i, CS_N] < 2.0:
        return s[i, CS_DHAT]
    acc = (v - s[i, CS_VPREV]) / ts
    u_mid = 0.5 * (s[i, CS_U1] + s[i, CS_U2])
    meas = acc + p[i, CP_A] * 0.5 * (v + s[i, CS_VPREV]) - p[i, CP_B] * u_mid
    return s[i, CS_DHAT] + p[i, CP_L] * ts * (meas - s[i, CS_DHAT])


@numba.njit(cache=True)
def smc_output(p, s, i, r, r_dot, r_ddot, y, ts):  # type: ignore[no-untyped-def]
    """Sliding-mode control with boundary layer and disturbance observer (paper 001).

    Reconstructed (001's eqs. 13-14 are lost; the text gives a sliding surface on the tracking
    error, a switching gain that the observer lets shrink, and a Lyapunov proof requiring the
    gain to exceed the observer's error) in the standard form for ``x'' = -a x' + b u + D``:

    * surface (eq. 13): ``S = e' + c e``, ``e = r - y``;
    * law (eq. 14): ``u = (r'' + a y' + c e' + lambda S + eta sat(S / phi) - D_hat) / b``,
      with the exponential reaching term ``lambda S`` and ``sat`` the boundary layer of width
      ``phi`` in place of ``sgn`` (the issue's "control law with a boundary layer");
    * then ``S' = -lambda S - eta sat(S / phi) - (D - D_hat)``; with ``V = S^2 / 2`` (eq.
      17), ``V' < 0`` outside the layer when ``eta > |D - D_hat|`` (eqs. 18-20). Without
      observer (``l = 0``, ``D_hat = 0``) that needs ``eta > |D|``: 001's large gain.
    """
    v = measured_velocity(s, i, y, ts)
    e_dot = r_dot - v
    surf = e_dot + p[i, CP_C] * (r - y)
    sat = min(1.0, max(-1.0, surf / p[i, CP_PHI]))
    acc = r_ddot + p[i, CP_A] * v + p[i, CP_C] * e_dot + p[i, CP_LAMBDA] * surf + p[i, CP_ETA] * sat
    return (acc - dob_estimate(p, s, i, v, ts)) / p[i, CP_B]


@numba.njit(cache=True)
def pd_robust_output(p, s, i, r, r_dot, r_ddot, y, ts):  # type: ignore[no-untyped-def]
    """Paper 001's comparison controller ("PD robust controller"; its equation is lost).

    Reconstructed as the robust PD of the robot-control literature for a second-order plant
    with bounded disturbance: nominal inverse-dynamics feed-forward plus PD feedback,
    ``u = (r'' + a y' + kp e + kd e') / b``, whose error is ultimately bounded by about
    ``|D|_max / kp`` without any switching term or observer.
    """
    v = measured_velocity(s, i, y, ts)
    acc = r_ddot + p[i, CP_A] * v + p[i, CP_PD_KP] * (r - y) + p[i, CP_PD_KD] * (r_dot - v)
    return acc / p[i, CP_B]


@numba.njit(cache=True)
def _friction_velocity(p, s, i, r_dot, y, ts):  # type: ignore[no-untyped-def]
    # feed-forward predicts from the command, feedback from the last measured motion
    return r_dot if p[i, CP_FR_MODE] == FR_FEEDFORWARD else measured_velocity(s, i, y, ts)


@numba.njit(cache=True)
def friction_output(p, s, i, r_dot, y, ts):  # type: ignore[no-untyped-def]
    """Friction compensation of paper 002 section 3: predicted friction / force constant.

    * Feed-forward (002 section 3.1, figs. 5-7): the LuGre model (eq. 1) with the identified
      parameters, driven by the command velocity ``r'``, so the compensation is ready before
      the motion it serves; its bristle state lives in ``s[i, CS_ZF]``.
    * Feedback, the traditional scheme 002 compares against (its equations are not given;
      the text only says it is driven by velocity feedback and lags a cycle): the same LuGre
      model driven by the measured velocity (the backward difference of ``y``).
    * Static feedback: the steady-state friction of 002 eq. 3 at the measured velocity, the
      classic Coulomb/Stribeck compensation without bristle dynamics.
    """
    mode = p[i, CP_FR_MODE]
    if mode == FR_NONE:
        return 0.0
    s2, fc, fs, vs = p[i, CP_FR_S2], p[i, CP_FR_FC], p[i, CP_FR_FS], p[i, CP_FR_VS]
    v = _friction_velocity(p, s, i, r_dot, y, ts)
    if mode == FR_FEEDBACK_STATIC:
        force = static_friction(s2, fc, fs, vs, v)
    else:
        a = lugre_rate(p[i, CP_FR_S0], fc, fs, vs, v)
        force = lugre_force(p[i, CP_FR_S0], p[i, CP_FR_S1], s2, a, s[i, CS_ZF], v)
    return force * p[i, CP_FR_INVK]


@numba.njit(cache=True, inline="always")
def axis_control(kind, p, s, i, r, r_dot, r_ddot, y, ts):  # type: ignore[no-untyped-def]
    """Control signal of one axis (before CCC and saturation) for controller ``kind``.

    Args:
        kind: Controller kind (CTRL_*), the same for every axis and member of a loop.
        p: (rows, N_CP) parameters.
        s: (rows, N_CS) state (read here; updated by :func:`axis_commit`).
        i: The row of this member and axis.
        r: Reference position, m.
        r_dot: Reference velocity, m/s.
        r_ddot: Reference acceleration, m/s^2.
        y: Measured position, m.
        ts: Servo tick, s.
    """
    if kind == CTRL_PID:
        u = pid_output(p, i, s, i, r - y, r_dot, ts)
    elif kind == CTRL_TWO_DOF_PID:
        u = two_dof_pid_output(p, s, i, r, r_dot, y, ts)
    elif kind == CTRL_SMC:
        u = smc_output(p, s, i, r, r_dot, r_ddot, y, ts)
    else:
        u = pd_robust_output(p, s, i, r, r_dot, r_ddot, y, ts)
    return u + friction_output(p, s, i, r_dot, y, ts)


@numba.njit(cache=True, inline="always")
def axis_commit(kind, p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_max):  # type: ignore[no-untyped-def]
    """Update the controller state once the tick's total (unsaturated) control is known."""
    if kind in (CTRL_PID, CTRL_TWO_DOF_PID):
        pid_commit(s, i, r - y, ts, u_total, u_max)
        if kind == CTRL_PID and p[i, CP_FR_MODE] == FR_NONE:
            return  # the plain PID (and the hot loop's default) needs no more state
    v = measured_velocity(s, i, y, ts)
    s[i, CS_DHAT] = dob_estimate(p, s, i, v, ts)
    u_comp = friction_output(p, s, i, r_dot, y, ts)
    mode = p[i, CP_FR_MODE]
    if mode in (FR_FEEDFORWARD, FR_FEEDBACK):
        vf = _friction_velocity(p, s, i, r_dot, y, ts)
        a = lugre_rate(p[i, CP_FR_S0], p[i, CP_FR_FC], p[i, CP_FR_FS], p[i, CP_FR_VS], vf)
        s[i, CS_ZF] = lugre_advance(a, s[i, CS_ZF], vf, ts)
    # the observer sees the friction compensation as part of the disturbance it cancels, so
    # the two do not both cancel the same friction
    s[i, CS_U2] = s[i, CS_U1]
    s[i, CS_U1] = min(max(u_total, -u_max), u_max) - u_comp
    s[i, CS_VPREV] = v
    s[i, CS_YPREV] = y
    s[i, CS_N] += 1.0
