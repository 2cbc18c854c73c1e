"""Plants: axis dynamics, friction laws, ripple, disturbances, sensing, stages.

The papers' machines (presets) sit one layer up, in :mod:`contour_gym.presets`: they need the
servo gains too. :data:`AX`, :data:`ST` and :data:`STATE` are the axis kernel's column tables:
the parameter row's and the state row's columns by name (``AX.m``, ``ST.v``), for code that
reads or writes those rows.
"""

from __future__ import annotations

from contour_gym.plant._kernel import AX, ST, STATE
from contour_gym.plant.friction import (
    FRICTION_LAWS,
    CoulombFriction,
    FrictionLaw,
    LuGreFriction,
    StribeckFriction,
    register_friction_law,
)
from contour_gym.plant.params import AxisParams, Disturbance, Ripple
from contour_gym.plant.stage import Contour, Stage

__all__ = [
    "AX",
    "FRICTION_LAWS",
    "ST",
    "STATE",
    "AxisParams",
    "Contour",
    "CoulombFriction",
    "Disturbance",
    "FrictionLaw",
    "LuGreFriction",
    "Ripple",
    "Stage",
    "StribeckFriction",
    "register_friction_law",
]
