"""LuGre dynamic friction (paper 002 eq. 1): the one home of its model.

The plant's friction, the servo's friction compensation (002 section 3) and the friction
identification (002 section 2.2, ``agents.identify``) all call these kernels::

    dz/dt = v - a(v) z,     a(v) = sigma0 |v| / g(v)
    g(v)  = F_c + (F_s - F_c) exp(-(v / v_s)^2)
    F     = sigma0 z + sigma1 dz/dt + sigma2 v

002 prints ``- sigma1 dz/dt``; the standard model (Canudas de Wit et al. 1995, 002's ref. 16)
has ``+ sigma1 dz/dt``, which is what dissipates energy; we use ``+``. The bristle state is
advanced exactly for a velocity held over the step (``z`` relaxes to ``v / a`` with rate
``a``), so a model fed the plant's own velocity samples reproduces the plant's friction
exactly. The static (steady-state) friction of 002 eq. 3, ``g(v) sgn(v) + sigma2 v``, is what a
compensator without bristle dynamics uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from contour_gym._schema import Param, Schema
from contour_gym._validate import non_negative, positive
from contour_gym.plant._kernel import ST, linear_step
from contour_gym.plant.friction.base import FrictionLaw, register_friction_law


@dataclass(frozen=True)
class LuGreFriction:
    """LuGre dynamic friction (paper 002 eq. 1) with bristle state ``z``.

    Attributes:
        sigma0: Bristle stiffness, N/m (002 table 1: 560).
        sigma1: Bristle damping, N s/m (002 table 1: 300).
        sigma2: Viscous coefficient, N s/m (not published in 002; chosen per preset).
        fc: Coulomb force, N (not published in 002; chosen per preset).
        fs: Static force, N (002 table 1: 30).
        vs: Stribeck velocity, m/s (002 table 1: 0.5).
    """

    sigma0: float
    sigma1: float
    sigma2: float
    fc: float
    fs: float
    vs: float

    def __post_init__(self) -> None:
        positive(self.sigma0, "sigma0")
        non_negative(self.sigma1, "sigma1")
        non_negative(self.sigma2, "sigma2")
        positive(self.fc, "fc")
        if positive(self.fs, "fs") < self.fc:
            raise ValueError(f"fs must be >= fc, got fs={self.fs!r} < fc={self.fc!r}")
        positive(self.vs, "vs")

    def as_array(self) -> np.ndarray:
        """The parameters as a (6,) row in :data:`PARAMS` order."""
        return PARAMS.row(
            sigma0=self.sigma0, sigma1=self.sigma1, sigma2=self.sigma2, fc=self.fc, fs=self.fs,
            vs=self.vs,
        )


PARAMS = Schema(
    "lugre",
    sigma0=Param(check=positive, doc="bristle stiffness, N/m"),
    sigma1=Param(check=non_negative, doc="bristle damping, N s/m"),
    sigma2=Param(check=non_negative, doc="viscous coefficient, N s/m"),
    fc=Param(check=positive, doc="Coulomb force, N"),
    fs=Param(check=positive, doc="static force, N"),
    vs=Param(check=positive, doc="Stribeck velocity, m/s"),
)
C = PARAMS.col


@numba.njit(cache=True, inline="always")
def stribeck(fc, fs, vs, v):
    """Stribeck curve ``g(v)`` of 002 eq. 1, N."""
    r = v / vs
    return fc + (fs - fc) * math.exp(-r * r)


@numba.njit(cache=True, inline="always")
def lugre_rate(s0, fc, fs, vs, v):
    """Bristle relaxation rate ``a(v) = sigma0 |v| / g(v)``, 1/s."""
    return s0 * abs(v) / stribeck(fc, fs, vs, v)


@numba.njit(cache=True, inline="always")
def lugre_force(s0, s1, s2, a, z, v):
    """Friction ``sigma0 z + sigma1 (v - a z) + sigma2 v`` for bristle state ``z``, N."""
    return s0 * z + s1 * (v - a * z) + s2 * v


@numba.njit(cache=True, inline="always")
def lugre_advance(a, z, v, h):
    """Bristle state after ``h`` seconds at constant velocity ``v`` (exact solution)."""
    if a > 0.0:
        zeq = v / a
        return zeq + (z - zeq) * math.exp(-a * h)
    return z + v * h


@numba.njit(cache=True, inline="always")
def static_friction(s2, fc, fs, vs, v):
    """Steady-state LuGre friction, 002 eq. 3: ``g(v) sgn(v) + sigma2 v`` (0 at rest), N."""
    if v == 0.0:
        return 0.0
    g = stribeck(fc, fs, vs, v)
    return (g if v > 0.0 else -g) + s2 * v


@numba.njit(cache=True, inline="always")
def substep(ax, fr, ad, bd, st, i, u, f_ext, h):
    """One plant substep: friction from the bristle state, then z advanced exactly (v held)."""
    v = st[i, ST.v]
    a = lugre_rate(fr[i, C.sigma0], fr[i, C.fc], fr[i, C.fs], fr[i, C.vs], v)
    z = st[i, ST.z0]
    friction = lugre_force(fr[i, C.sigma0], fr[i, C.sigma1], fr[i, C.sigma2], a, z, v)
    linear_step(ad, bd, st, i, u, f_ext - friction)
    st[i, ST.z0] = lugre_advance(a, z, v, h)


@numba.njit(cache=True)
def lugre_response(theta, v, h, out):
    """Friction of a LuGre model driven by the velocity samples ``v`` (``z(0) = 0``).

    Args:
        theta (numpy.ndarray): (6,) parameters in :data:`PARAMS` order.
        v (numpy.ndarray): (T,) velocity held over each step of length ``h``, m/s.
        h (float): Step, s.
        out (numpy.ndarray): (T,) friction of each step, written in place, N.
    """
    s0, s1, s2 = theta[C.sigma0], theta[C.sigma1], theta[C.sigma2]
    fc, fs, vs = theta[C.fc], theta[C.fs], theta[C.vs]
    z = 0.0
    for k in range(v.shape[0]):
        a = lugre_rate(s0, fc, fs, vs, v[k])
        out[k] = lugre_force(s0, s1, s2, a, z, v[k])
        z = lugre_advance(a, z, v[k], h)


@numba.njit(cache=True)
def lugre_sse(thetas, v, f_meas, h):
    """Sum of squared friction errors (002 eq. 4, sampled) of each parameter row.

    Args:
        thetas (numpy.ndarray): (n, 6) candidate parameters in :data:`PARAMS` order.
        v (numpy.ndarray): (T,) measured velocity, m/s.
        f_meas (numpy.ndarray): (T,) measured friction, N.
        h (float): Sample step, s.

    Returns:
        sse (numpy.ndarray): (n,) ``sum_k (f_meas[k] - F_model[k])^2``; ``inf`` for a row whose
            Stribeck curve is not positive (no valid model).
    """
    n = thetas.shape[0]
    out = np.empty(n)
    buf = np.empty(v.shape[0])
    for i in range(n):
        th = thetas[i]
        if not (th[C.fc] > 0.0 and th[C.fs] > 0.0 and th[C.vs] > 0.0):
            out[i] = math.inf
            continue
        lugre_response(th, v, h, buf)
        acc = 0.0
        for k in range(v.shape[0]):
            d = f_meas[k] - buf[k]
            acc += d * d
        out[i] = acc
    return out


LAW = register_friction_law(
    FrictionLaw(
        "lugre", LuGreFriction, PARAMS, substep,
        scale=("sigma0", "sigma2", "fc", "fs"), break_away=lambda m: m.fs
    )
)
