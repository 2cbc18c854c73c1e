"""No friction: the axis is linear (``AxisParams.friction = None``)."""

from __future__ import annotations

import numba

from contour_gym._schema import Schema
from contour_gym.plant._kernel import linear_step
from contour_gym.plant.friction.base import FrictionLaw, register_friction_law


@numba.njit(cache=True, inline="always")
def substep(ax, fr, ad, bd, st, i, u, f_ext, h):
    """One substep of the linear axis."""
    linear_step(ad, bd, st, i, u, f_ext)


LAW = register_friction_law(FrictionLaw("none", type(None), Schema("none"), substep))
