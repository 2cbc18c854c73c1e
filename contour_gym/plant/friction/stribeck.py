"""Stribeck friction in the form of paper 003 (eqs. 7-8), with stiction."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba

from contour_gym._schema import Param, Schema
from contour_gym._validate import non_negative, positive
from contour_gym.plant._kernel import ST, stiction_step
from contour_gym.plant.friction.base import FrictionLaw, register_friction_law


@dataclass(frozen=True)
class StribeckFriction:
    """Stribeck friction, paper 003 eqs. 7-8.

    ``F = {fc + (fs - fc) exp(-(|v| / vs)^delta) + fv |v|} sgn(v)``; at rest it holds up to
    ``fs`` (stiction).

    Attributes:
        fc: Coulomb friction, N.
        fs: Static friction, N (>= fc).
        vs: Stribeck velocity, m/s (003 calls it the lubricant parameter).
        delta: Empirical Stribeck exponent (003's delta; 2 is Gaussian).
        fv: Viscous friction coefficient, N s/m (in addition to the axis damping ``b``).
    """

    fc: float
    fs: float
    vs: float
    delta: float = 2.0
    fv: float = 0.0

    def __post_init__(self) -> None:
        non_negative(self.fc, "fc")
        if non_negative(self.fs, "fs") < self.fc:
            raise ValueError(f"fs must be >= fc, got fs={self.fs!r} < fc={self.fc!r}")
        positive(self.vs, "vs")
        positive(self.delta, "delta")
        non_negative(self.fv, "fv")


PARAMS = Schema(
    "stribeck",
    fc=Param(check=non_negative), fs=Param(check=non_negative), vs=Param(check=positive),
    delta=Param(2.0, positive), fv=Param(0.0, non_negative),
)
C = PARAMS.col


@numba.njit(cache=True, inline="always")
def kinetic(fr, i, v):
    """Friction force opposing a velocity v != 0 (003 eqs. 7-8), N."""
    av = abs(v)
    r = av / fr[i, C.vs]
    p = r * r if fr[i, C.delta] == 2.0 else r ** fr[i, C.delta]  # pow is a slow call
    stribeck = (fr[i, C.fs] - fr[i, C.fc]) * math.exp(-p)
    force = fr[i, C.fc] + stribeck + fr[i, C.fv] * av
    return force if v > 0.0 else -force


@numba.njit(cache=True, inline="always")
def substep(ax, fr, ad, bd, st, i, u, f_ext, h):
    """One substep with Stribeck friction and stiction."""
    stiction_step(ax, ad, bd, st, i, u, f_ext, kinetic(fr, i, st[i, ST.v]), fr[i, C.fs])


LAW = register_friction_law(
    FrictionLaw(
        "stribeck", StribeckFriction, PARAMS, substep,
        scale=("fc", "fs", "fv"), break_away=lambda m: m.fs
    )
)
