"""Plants: axis dynamics, friction, ripple, disturbances, stages and the papers' presets."""

from __future__ import annotations

from contour_gym.plant.params import (
    AxisParams,
    CoulombFriction,
    Disturbance,
    LuGreFriction,
    Ripple,
    StribeckFriction,
)
from contour_gym.plant.presets import PRESETS, Preset, get_preset, pd_pole_placement
from contour_gym.plant.stage import Contour, Stage

__all__ = [
    "PRESETS",
    "AxisParams",
    "Contour",
    "CoulombFriction",
    "Disturbance",
    "LuGreFriction",
    "Preset",
    "Ripple",
    "Stage",
    "StribeckFriction",
    "get_preset",
    "pd_pole_placement",
]
