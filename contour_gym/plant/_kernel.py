"""Compiled per-axis plant pieces: parameter and state layouts by name, integration helpers.

Every axis obeys (DESIGN.md)::

    m x'' = K i - b x' - k x - F_friction - F_ripple(x) + d(t)
    tau i' = u - i            (first-order current loop; tau = 0 means i = u)

Row tables (built by :mod:`contour_gym.plant.stage`, one row ``i = b * A + a`` per member and
axis; the kernels index the tables rather than take row views, because every view numba makes
costs a reference-counting call in the hot loop):

* ``ax[i, AX.*]``: :data:`AXIS` (mass, damping, ..., the friction law's slot ``law``);
* ``fr[i, :]``: the friction law's own parameters (its schema, at most :data:`N_FR` columns);
* ``rip[i, 6, 3]``: ripple harmonics (a_j, b_j, w_j);
* ``dist[i, DS.*]``: :data:`DISTURBANCE`;
* ``ad[i, 3, 3]``, ``bd[i, 3, 2]``: zero-order-hold discretisation of the linear part over one
  substep for the state (x, v, i) and inputs (u, f_ext);
* ``st[i, ST.*]``: :data:`STATE` (x, v, i, friction state z0 and z1, random disturbance d).

The friction law of each axis advances the substep (:mod:`contour_gym.plant.friction`); the
servo loop dispatches on ``AX.law`` among the (at most :data:`MAX_LAWS`) laws of its stage.
"""

from __future__ import annotations

import math

import numba

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import number

AXIS = Schema(
    "axis", m=1.0, b=0.0, ks=0.0, k=1.0, u_max=1.0, tau=0.0, enc=0.0, noise=0.0, nrip=0.0,
    harm=0.0, law=0.0, in_ticks=1.0,
)
AX = AXIS.col
STATE = state_schema("axis state", "x", "v", "i", "z0", "z1", "d")
ST = STATE.col
DISTURBANCE = Schema(
    "disturbance", step_t=Param(math.inf, number), step_a=0.0, sin_a=0.0, sin_w=0.0, sin_ph=0.0,
    rnd_std=0.0, rnd_alpha=0.0,
)
DS = DISTURBANCE.col
N_FR = 8  # friction-law parameter columns (the widest law's schema)
MAX_LAWS = 4  # distinct friction laws one stage may use
MAX_HARMONICS = 6


@numba.njit(cache=True, inline="always")
def ripple_force(rip, i, nrip, harmonic, x):
    """Ripple force of row ``i`` at position x (003 eqs. 5-6).

    With ``harmonic`` (the wavenumbers are ``j w_1``, :attr:`Ripple.harmonic`) the harmonics
    come from one sine and cosine by the angle-addition recurrence: 2 calls instead of
    ``2 nrip``, within 3e-12 of the direct sum for unit amplitudes (tested over the gantry's
    six harmonics).
    """
    if harmonic:
        s1 = math.sin(rip[i, 0, 2] * x)
        c1 = math.cos(rip[i, 0, 2] * x)
        s, c = s1, c1
        f = rip[i, 0, 0] * s + rip[i, 0, 1] * c
        for j in range(1, nrip):
            s, c = s * c1 + c * s1, c * c1 - s * s1
            f += rip[i, j, 0] * s + rip[i, j, 1] * c
        return f
    f = 0.0
    for j in range(nrip):
        wx = rip[i, j, 2] * x
        f += rip[i, j, 0] * math.sin(wx) + rip[i, j, 1] * math.cos(wx)
    return f


@numba.njit(cache=True, inline="always")
def disturbance_force(dist, st, i, t, w):
    """Advance row ``i``'s band-limited random state with normal ``w``; return d(t), N."""
    d = 0.0
    if t >= dist[i, DS.step_t]:
        d += dist[i, DS.step_a]
    if dist[i, DS.sin_a] != 0.0:
        d += dist[i, DS.sin_a] * math.sin(dist[i, DS.sin_w] * t + dist[i, DS.sin_ph])
    std = dist[i, DS.rnd_std]
    if std > 0.0:
        a = dist[i, DS.rnd_alpha]
        st[i, ST.d] = a * st[i, ST.d] + math.sqrt(1.0 - a * a) * std * w
        d += st[i, ST.d]
    return d


@numba.njit(cache=True, inline="always")
def linear_step(ad, bd, st, i, u, f):
    """Advance (x, v, i) of row ``i`` over one substep with control ``u`` and force ``f`` held."""
    x, v, c = st[i, ST.x], st[i, ST.v], st[i, ST.i]
    for r in range(3):  # the state columns x, v, i
        lin = ad[i, r, 0] * x + ad[i, r, 1] * v + ad[i, r, 2] * c
        st[i, r] = lin + bd[i, r, 0] * u + bd[i, r, 1] * f


@numba.njit(cache=True, inline="always")
def stiction_step(ax, ad, bd, st, i, u, f_ext, f_kinetic, f_static):
    """One substep of a static friction law with stiction (Karnopp-style clamp).

    At ``v == 0`` the axis stays put while the applied force is within the break-away force
    ``f_static``; moving, the kinetic friction ``f_kinetic`` (signed, opposing v) acts, and a
    velocity sign change inside a substep is clamped to rest, so friction never drives the
    axis backwards.
    """
    v = st[i, ST.v]
    if v == 0.0:
        drive = st[i, ST.i] if ax[i, AX.tau] > 0.0 else u
        applied = ax[i, AX.k] * drive - ax[i, AX.ks] * st[i, ST.x] + f_ext
        if abs(applied) <= f_static:
            x = st[i, ST.x]
            linear_step(ad, bd, st, i, u, 0.0)  # advances the current state only
            st[i, ST.x] = x
            st[i, ST.v] = 0.0
            return
        friction = f_static if applied > 0.0 else -f_static
    else:
        friction = f_kinetic
    linear_step(ad, bd, st, i, u, f_ext - friction)
    if v * st[i, ST.v] < 0.0:
        st[i, ST.v] = 0.0


@numba.njit(cache=True, inline="always")
def measure(ax, i, x, w):
    """Row ``i``'s encoder reading of true position ``x``: quantised, plus ``noise * w``."""
    q = ax[i, AX.enc]
    y = x if q == 0.0 else q * math.floor(x / q + 0.5)
    return y + ax[i, AX.noise] * w
