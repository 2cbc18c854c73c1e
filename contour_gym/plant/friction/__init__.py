"""Friction laws by registration: a model dataclass, its parameter schema, its compiled substep.

| law | model (``AxisParams.friction``) | source |
|---|---|---|
| ``none`` | ``None`` | linear axis |
| ``coulomb`` | :class:`CoulombFriction` | Coulomb with stiction (004 table 4.1) |
| ``stribeck`` | :class:`StribeckFriction` | 003 eqs. 7-8, with stiction |
| ``lugre`` | :class:`LuGreFriction` | 002 eq. 1 (dynamic, bristle state) |

Add a law in one module of your own::

    @dataclass(frozen=True)
    class MyFriction:
        c: float

    PARAMS = Schema("my_friction", c=Param(check=non_negative))

    @numba.njit(cache=True, inline="always")
    def substep(ax, fr, ad, bd, st, i, u, f_ext, h):
        ...  # advance st[i] by one substep h (plant._kernel.linear_step / stiction_step help)

    register_friction_law(FrictionLaw("my_friction", MyFriction, PARAMS, substep,
                                      break_away=lambda m: m.c))

and put ``MyFriction(...)`` into an axis. ``substep`` reads its parameters as
``fr[i, PARAMS.col.c]``; ``st[i, ST.z0]`` and ``st[i, ST.z1]`` are its state.
"""

from __future__ import annotations

from contour_gym.plant.friction import coulomb, lugre, none, stribeck  # noqa: F401
from contour_gym.plant.friction.base import (
    FRICTION_FAMILY,
    FRICTION_LAWS,
    FrictionLaw,
    law_for,
    register_friction_law,
)
from contour_gym.plant.friction.coulomb import CoulombFriction
from contour_gym.plant.friction.lugre import LuGreFriction
from contour_gym.plant.friction.stribeck import StribeckFriction

__all__ = [
    "FRICTION_FAMILY",
    "FRICTION_LAWS",
    "CoulombFriction",
    "FrictionLaw",
    "LuGreFriction",
    "StribeckFriction",
    "law_for",
    "register_friction_law",
]
