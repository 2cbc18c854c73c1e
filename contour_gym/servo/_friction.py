"""Compiled LuGre friction model used by the compensators and by the identification.

Paper 002 eq. 1 with the standard ``+ sigma1 dz/dt`` (see
:class:`contour_gym.plant.params.LuGreFriction`)::

    dz/dt = v - a(v) z,     a(v) = sigma0 |v| / g(v)
    g(v)  = F_c + (F_s - F_c) exp(-(v / v_s)^2)
    F     = sigma0 z + sigma1 dz/dt + sigma2 v

The bristle state is advanced exactly for a velocity held over the step (``z`` relaxes to
``v / a`` with rate ``a``), the discretisation the plant uses, so a model fed the plant's own
velocity samples reproduces the plant's friction exactly. The static (steady-state) friction of
002 eq. 3, ``g(v) sgn(v) + sigma2 v``, is what a compensator without bristle dynamics uses.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# order of a LuGre parameter vector in these kernels
LG_S0, LG_S1, LG_S2, LG_FC, LG_FS, LG_VS = 0, 1, 2, 3, 4, 5
N_LG = 6


@numba.njit(cache=True)
def stribeck(fc, fs, vs, v):  # type: ignore[no-untyped-def]
    """Stribeck curve ``g(v)`` of 002 eq. 1, N."""
    r = v / vs
    return fc + (fs - fc) * math.exp(-r * r)


@numba.njit(cache=True)
def lugre_rate(s0, fc, fs, vs, v):  # type: ignore[no-untyped-def]
    """Bristle relaxation rate ``a(v) = sigma0 |v| / g(v)``, 1/s."""
    return s0 * abs(v) / stribeck(fc, fs, vs, v)


@numba.njit(cache=True)
def lugre_force(s0, s1, s2, a, z, v):  # type: ignore[no-untyped-def]
    """Friction ``sigma0 z + sigma1 (v - a z) + sigma2 v`` for bristle state ``z``, N."""
    return s0 * z + s1 * (v - a * z) + s2 * v


@numba.njit(cache=True)
def lugre_advance(a, z, v, h):  # type: ignore[no-untyped-def]
    """Bristle state after ``h`` seconds at constant velocity ``v`` (exact solution)."""
    if a > 0.0:
        zeq = v / a
        return zeq + (z - zeq) * math.exp(-a * h)
    return z + v * h


@numba.njit(cache=True)
def static_friction(s2, fc, fs, vs, v):  # type: ignore[no-untyped-def]
    """Steady-state LuGre friction, 002 eq. 3: ``g(v) sgn(v) + sigma2 v`` (0 at rest), N."""
    if v == 0.0:
        return 0.0
    g = stribeck(fc, fs, vs, v)
    return (g if v > 0.0 else -g) + s2 * v


@numba.njit(cache=True)
def lugre_response(theta, v, h, out):  # type: ignore[no-untyped-def]
    """Friction of a LuGre model driven by the velocity samples ``v`` (``z(0) = 0``).

    Args:
        theta: (N_LG,) parameters in LG_* order.
        v: (T,) velocity held over each step of length ``h``, m/s.
        h: Step, s.
        out: (T,) friction of each step, written in place, N.
    """
    s0, s1, s2 = theta[LG_S0], theta[LG_S1], theta[LG_S2]
    fc, fs, vs = theta[LG_FC], theta[LG_FS], theta[LG_VS]
    z = 0.0
    for k in range(v.shape[0]):
        a = lugre_rate(s0, fc, fs, vs, v[k])
        out[k] = lugre_force(s0, s1, s2, a, z, v[k])
        z = lugre_advance(a, z, v[k], h)


@numba.njit(cache=True)
def lugre_sse(thetas, v, f_meas, h):  # type: ignore[no-untyped-def]
    """Sum of squared friction errors (002 eq. 4, sampled) of each parameter row.

    Args:
        thetas: (n, N_LG) candidate parameters.
        v: (T,) measured velocity, m/s.
        f_meas: (T,) measured friction, N.
        h: Sample step, s.

    Returns:
        (n,) ``sum_k (f_meas[k] - F_model[k])^2``; ``inf`` for a row whose Stribeck curve is
        not positive (no valid model).
    """
    n = thetas.shape[0]
    out = np.empty(n)
    buf = np.empty(v.shape[0])
    for i in range(n):
        th = thetas[i]
        if not (th[LG_FC] > 0.0 and th[LG_FS] > 0.0 and th[LG_VS] > 0.0):
            out[i] = math.inf
            continue
        lugre_response(th, v, h, buf)
        acc = 0.0
        for k in range(v.shape[0]):
            d = f_meas[k] - buf[k]
            acc += d * d
        out[i] = acc
    return out
