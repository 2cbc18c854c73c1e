"""Compiled per-axis plant step (the hot loop's plant part).

Array layouts (one row per batch member and axis; built by :mod:`contour_gym.plant.stage`):

* ``ax_p[..., AX_*]``: axis parameters (see the AX_ constants).
* ``rip[..., 6, 3]``: ripple harmonics (a_j, b_j, w_j).
* ``dist[..., DS_*]``: disturbance parameters.
* ``ad[..., 3, 3]``, ``bd[..., 3, 2]``: zero-order-hold discretisation of the linear part over
  one substep for the state (x, v, i) and inputs (u, f_ext).
* ``st[..., ST_*]``: state (x, v, i, z, d_rand).
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
def ripple_force(rip, nrip, x):  # type: ignore[no-untyped-def]
    """Ripple force at position x (003 eqs. 5-6)."""
    f = 0.0
    for j in range(nrip):
        wx = rip[j, 2] * x
        f += rip[j, 0] * math.sin(wx) + rip[j, 1] * math.cos(wx)
    return f


@numba.njit(cache=True, inline="always")
def disturbance_force(dist, st, t, w):  # type: ignore[no-untyped-def]
    """Advance the band-limited random state with normal ``w`` and return d(t), N."""
    d = 0.0
    if t >= dist[DS_STEP_T]:
        d += dist[DS_STEP_A]
    if dist[DS_SIN_A] != 0.0:
        d += dist[DS_SIN_A] * math.sin(dist[DS_SIN_W] * t + dist[DS_SIN_PH])
    std = dist[DS_RND_STD]
    if std > 0.0:
        a = dist[DS_RND_ALPHA]
        st[ST_D] = a * st[ST_D] + math.sqrt(1.0 - a * a) * std * w
        d += st[ST_D]
    return d


@numba.njit(cache=True, inline="always")
def kinetic_friction(p, v):  # type: ignore[no-untyped-def]
    """Coulomb or Stribeck friction force opposing velocity v != 0 (003 eqs. 7-8)."""
    sgn = 1.0 if v > 0.0 else -1.0
    if p[AX_FKIND] == FRIC_COULOMB:
        return p[AX_FC] * sgn
    av = abs(v)
    stribeck = (p[AX_FS] - p[AX_FC]) * math.exp(-((av / p[AX_VS]) ** p[AX_DELTA]))
    return (p[AX_FC] + stribeck + p[AX_FV] * av) * sgn


@numba.njit(cache=True, inline="always")
def _linear_step(ad, bd, st, u, f):  # type: ignore[no-untyped-def]
    x, v, i = st[ST_X], st[ST_V], st[ST_I]
    st[ST_X] = ad[0, 0] * x + ad[0, 1] * v + ad[0, 2] * i + bd[0, 0] * u + bd[0, 1] * f
    st[ST_V] = ad[1, 0] * x + ad[1, 1] * v + ad[1, 2] * i + bd[1, 0] * u + bd[1, 1] * f
    st[ST_I] = ad[2, 0] * x + ad[2, 1] * v + ad[2, 2] * i + bd[2, 0] * u + bd[2, 1] * f


@numba.njit(cache=True, inline="always")
def _lugre_substep(p, ad, bd, st, u, f_ext, h):  # type: ignore[no-untyped-def]
    # 002 eq. 1 with the standard +sigma1 sign; z advanced exactly for v frozen over h.
    v = st[ST_V]
    dv = v / p[AX_VS]
    g = p[AX_FC] + (p[AX_FS] - p[AX_FC]) * math.exp(-dv * dv)
    a = p[AX_S0] * abs(v) / g
    z = st[ST_Z]
    zdot = v - a * z
    friction = p[AX_S0] * z + p[AX_S1] * zdot + p[AX_S2] * v
    _linear_step(ad, bd, st, u, f_ext - friction)
    if a > 0.0:
        zeq = v / a
        st[ST_Z] = zeq + (z - zeq) * math.exp(-a * h)
    else:
        st[ST_Z] = z + v * h


@numba.njit(cache=True, inline="always")
def _static_friction_substep(p, ad, bd, st, u, f_ext):  # type: ignore[no-untyped-def]
    # Coulomb/Stribeck with stiction: at v == 0 the axis stays put while the applied force
    # is within the break-away force; a velocity sign change inside a substep is clamped
    # to rest, so friction never drives the axis backwards (Karnopp-style clamp).
    v = st[ST_V]
    if v == 0.0:
        drive = st[ST_I] if p[AX_TAU] > 0.0 else u
        applied = p[AX_K] * drive - p[AX_KS] * st[ST_X] + f_ext
        if abs(applied) <= p[AX_FS]:
            x = st[ST_X]
            _linear_step(ad, bd, st, u, 0.0)  # advances the current state only
            st[ST_X] = x
            st[ST_V] = 0.0
            return
        friction = p[AX_FS] if applied > 0.0 else -p[AX_FS]
    else:
        friction = kinetic_friction(p, v)
    _linear_step(ad, bd, st, u, f_ext - friction)
    if v * st[ST_V] < 0.0:
        st[ST_V] = 0.0


@numba.njit(cache=True, inline="always")
def axis_tick(p, rip, dist, ad, bd, st, u, t, ts, nsub, w):  # type: ignore[no-untyped-def]
    """Advance one axis by one servo tick ``ts`` with the control ``u`` held (ZOH).

    Args:
        p: Axis parameters (N_AX,).
        rip: Ripple harmonics (6, 3).
        dist: Disturbance parameters (N_DS,).
        ad: ZOH state matrix over one substep (3, 3).
        bd: ZOH input matrix over one substep (3, 2).
        st: State (N_ST,), updated in place.
        u: Saturated control signal.
        t: Time at the start of the tick, s.
        ts: Tick length, s.
        nsub: Substeps per tick.
        w: Standard normal draw for the random disturbance.
    """
    d = disturbance_force(dist, st, t, w)
    h = ts / nsub
    kind = p[AX_FKIND]
    nrip = int(p[AX_NRIP])
    for _ in range(nsub):
        f_ext = d
        if nrip > 0:
            f_ext -= ripple_force(rip, nrip, st[ST_X])
        if kind == FRIC_LUGRE:
            _lugre_substep(p, ad, bd, st, u, f_ext, h)
        elif kind == FRIC_NONE:
            _linear_step(ad, bd, st, u, f_ext)
        else:
            _static_friction_substep(p, ad, bd, st, u, f_ext)
    if p[AX_TAU] == 0.0:
        st[ST_I] = u


@numba.njit(cache=True, inline="always")
def measure(p, x, w):  # type: ignore[no-untyped-def]
    """Encoder reading of true position ``x``: quantised, plus noise ``noise_std * w``."""
    q = p[AX_ENC]
    y = x if q == 0.0 else q * math.floor(x / q + 0.5)
    return y + p[AX_NOISE] * w
