"""Coulomb friction with stiction (004 table 4.1): ``F = fc sgn(v)``; at rest it holds up to fs."""

from __future__ import annotations

from dataclasses import dataclass

import numba

from contour_gym._schema import Param, Schema
from contour_gym._validate import non_negative
from contour_gym.plant._kernel import ST, stiction_step
from contour_gym.plant.friction.base import FrictionLaw, register_friction_law


@dataclass(frozen=True)
class CoulombFriction:
    """Coulomb friction with stiction: ``F = fc sgn(v)``; at rest it holds up to ``fs``.

    Attributes:
        fc: Coulomb (kinetic) friction force, N.
        fs: Static (break-away) force, N; defaults to ``fc``.
    """

    fc: float
    fs: float | None = None

    def __post_init__(self) -> None:
        non_negative(self.fc, "fc")
        if self.fs is not None and non_negative(self.fs, "fs") < self.fc:
            raise ValueError(f"fs must be >= fc, got fs={self.fs!r} < fc={self.fc!r}")

    @property
    def static(self) -> float:
        """Break-away force, N."""
        return self.fc if self.fs is None else float(self.fs)


PARAMS = Schema(
    "coulomb",
    fc=Param(check=non_negative, doc="Coulomb force, N"),
    fs=Param(check=non_negative, doc="break-away force, N"),
)
C = PARAMS.col


@numba.njit(cache=True, inline="always")
def substep(ax, fr, ad, bd, st, i, u, f_ext, h):
    """One substep with Coulomb friction and stiction."""
    kinetic = fr[i, C.fc] if st[i, ST.v] > 0.0 else -fr[i, C.fc]
    stiction_step(ax, ad, bd, st, i, u, f_ext, kinetic, fr[i, C.fs])


LAW = register_friction_law(
    FrictionLaw(
        "coulomb", CoulombFriction, PARAMS, substep,
        scale=("fc", "fs"), break_away=lambda m: m.static,
        values=lambda m: {"fc": m.fc, "fs": m.static},
    )
)
