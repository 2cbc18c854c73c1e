"""Compiled per-axis plant step (the hot loop's plant part).

Array layouts (built by :mod:`contour_gym.plant.stage` with a leading (batch, axis) shape;
the kernels take them as row tables, one row ``i`` per member and axis, ``i = b * A + a``):

* ``p[i, AX_*]``: axis parameters (see the AX_ constants).
* ``rip[i, 6, 3]``: ripple harmonics (a_j, b_j, w_j).
* ``dist[i, DS_*]``: disturbance parameters.
* ``ad[i, 3, 3]``, ``bd[i, 3, 2]``: zero-order-hold discretisation of the linear part over
  one substep for the state (x, v, i) and inputs (u, f_ext).
* ``st[i, ST_*]``: state (x, v, i, z, d_rand).

The kernels index the tables (``p[i, AX_M]``) rather than take row views (``p[i]``): every
view numba makes in compiled code is a call to its reference counting, and in the servo
loop's tick those calls cost ~11 % (perf).
"""

from __future__ import annotations

import math

import numba

AX_M, AX_B, AX_KS, AX_K, AX_UMAX, AX_TAU = 0, 1, 2, 3, 4, 5
AX_FKIND, AX_FC, AX_FS, AX_VS, AX_DELTA, AX_FV = 6, 7, 8, 9, 10, 11
AX_S0, AX_S1, AX_S2, AX_ENC, AX_NOISE, AX_NRIP = 12, 13, 14, 15, 16, 17
N_AX = 18

FRIC_NONE, FRIC_COULOMB, FRIC_STRIBECK, FRIC_LUGRE = 0, 1, 2, 3

DS_STEP_T, DS_STEP_A, DS_SIN_A, DS_SIN_W, DS_SIN_PH, DS_RND_STD, DS_RND_ALPHA = range(7)
N_DS = 7

ST_X, ST_V, ST_I, ST_Z, ST_D = 0, 1, 2, 3, 4
N_ST = 5


@numba.njit(cache=True, inline="always")
def ripple_force(rip, i, nrip, x):  # type: ignore[no-untyped-def]
    """Ripple force of row ``i`` at position x (003 eqs. 5-6)."""
    f = 0.0
    for j in range(nrip):
        wx = rip[i, j, 2] * x
        f += rip[i, j, 0] * math.sin(wx) + rip[i, j, 1] * math.cos(wx)
    return f


@numba.njit(cache=True, inline="always")
def disturbance_force(dist, st, i, t, w):  # type: ignore[no-untyped-def]
    """Advance row ``i``'s band-limited random state with normal ``w``; return d(t), N."""
    d = 0.0
    if t >= dist[i, DS_STEP_T]:
        d += dist[i, DS_STEP_A]
    if dist[i, DS_SIN_A] != 0.0:
        d += dist[i, DS_SIN_A] * math.sin(dist[i, DS_SIN_W] * t + dist[i, DS_SIN_PH])
    std = dist[i, DS_RND_STD]
    if std > 0.0:
        a = dist[i, DS_RND_ALPHA]
        st[i, ST_D] = a * st[i, ST_D] + math.sqrt(1.0 - a * a) * std * w
        d += st[i, ST_D]
    return d


@numba.njit(cache=True, inline="always")
def kinetic_friction(p, i, v):  # type: ignore[no-untyped-def]
    """Coulomb or Stribeck friction force opposing velocity v != 0 (003 eqs. 7-8)."""
    sgn = 1.0 if v > 0.0 else -1.0
    if p[i, AX_FKIND] == FRIC_COULOMB:
        return p[i, AX_FC] * sgn
    av = abs(v)
    stribeck = (p[i, AX_FS] - p[i, AX_FC]) * math.exp(-((av / p[i, AX_VS]) ** p[i, AX_DELTA]))
    return (p[i, AX_FC] + stribeck + p[i, AX_FV] * av) * sgn


@numba.njit(cache=True, inline="always")
def _linear_step(ad, bd, st, i, u, f):  # type: ignore[no-untyped-def]
    x, v, c = st[i, ST_X], st[i, ST_V], st[i, ST_I]
    for r in range(3):  # the state columns ST_X, ST_V, ST_I
        lin = ad[i, r, 0] * x + ad[i, r, 1] * v + ad[i, r, 2] * c
        st[i, r] = lin + bd[i, r, 0] * u + bd[i, r, 1] * f


@numba.njit(cache=True, inline="always")
def _lugre_substep(p, ad, bd, st, i, u, f_ext, h):  # type: ignore[no-untyped-def]
    # 002 eq. 1 with the standard +sigma1 sign; z advanced exactly for v frozen over h.
    v = st[i, ST_V]
    dv = v / p[i, AX_VS]
    g = p[i, AX_FC] + (p[i, AX_FS] - p[i, AX_FC]) * math.exp(-dv * dv)
    a = p[i, AX_S0] * abs(v) / g
    z = st[i, ST_Z]
    zdot = v - a * z
    friction = p[i, AX_S0] * z + p[i, AX_S1] * zdot + p[i, AX_S2] * v
    _linear_step(ad, bd, st, i, u, f_ext - friction)
    if a > 0.0:
        zeq = v / a
        st[i, ST_Z] = zeq + (z - zeq) * math.exp(-a * h)
    else:
        st[i, ST_Z] = z + v * h


@numba.njit(cache=True, inline="always")
def _static_friction_substep(p, ad, bd, st, i, u, f_ext):  # type: ignore[no-untyped-def]
    # Coulomb/Stribeck with stiction: at v == 0 the axis stays put while the applied force
    # is within the break-away force; a velocity sign change inside a substep is clamped
    # to rest, so friction never drives the axis backwards (Karnopp-style clamp).
    v = st[i, ST_V]
    if v == 0.0:
        drive = st[i, ST_I] if p[i, AX_TAU] > 0.0 else u
        applied = p[i, AX_K] * drive - p[i, AX_KS] * st[i, ST_X] + f_ext
        if abs(applied) <= p[i, AX_FS]:
            x = st[i, ST_X]
            _linear_step(ad, bd, st, i, u, 0.0)  # advances the current state only
            st[i, ST_X] = x
            st[i, ST_V] = 0.0
            return
        friction = p[i, AX_FS] if applied > 0.0 else -p[i, AX_FS]
    else:
        friction = kinetic_friction(p, i, v)
    _linear_step(ad, bd, st, i, u, f_ext - friction)
    if v * st[i, ST_V] < 0.0:
        st[i, ST_V] = 0.0


@numba.njit(cache=True, inline="always")
def axis_tick(p, rip, dist, ad, bd, st, i, u, t, ts, nsub, w):  # type: ignore[no-untyped-def]
    """Advance axis row ``i`` by one servo tick ``ts`` with the control ``u`` held (ZOH).

    Args:
        p: Axis parameters (rows, N_AX).
        rip: Ripple harmonics (rows, 6, 3).
        dist: Disturbance parameters (rows, N_DS).
        ad: ZOH state matrices over one substep (rows, 3, 3).
        bd: ZOH input matrices over one substep (rows, 3, 2).
        st: States (rows, N_ST); row ``i`` is updated in place.
        i: The row.
        u: Saturated control signal.
        t: Time at the start of the tick, s.
        ts: Tick length, s.
        nsub: Substeps per tick.
        w: Standard normal draw for the random disturbance.
    """
    d = disturbance_force(dist, st, i, t, w)
    h = ts / nsub
    kind = p[i, AX_FKIND]
    nrip = int(p[i, AX_NRIP])
    for _ in range(nsub):
        f_ext = d
        if nrip > 0:
            f_ext -= ripple_force(rip, i, nrip, st[i, ST_X])
        if kind == FRIC_LUGRE:
            _lugre_substep(p, ad, bd, st, i, u, f_ext, h)
        elif kind == FRIC_NONE:
            _linear_step(ad, bd, st, i, u, f_ext)
        else:
            _static_friction_substep(p, ad, bd, st, i, u, f_ext)
    if p[i, AX_TAU] == 0.0:
        st[i, ST_I] = u


@numba.njit(cache=True, inline="always")
def measure(p, i, x, w):  # type: ignore[no-untyped-def]
    """Row ``i``'s encoder reading of true position ``x``: quantised, plus ``noise_std * w``."""
    q = p[i, AX_ENC]
    y = x if q == 0.0 else q * math.floor(x / q + 0.5)
    return y + p[i, AX_NOISE] * w
