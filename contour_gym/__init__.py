"""contour-gym: Gymnasium environments for multi-axis CNC servo contouring.

``import contour_gym`` registers the environment ids (``contour_gym.envs.ENV_IDS``) and
never imports torch.
"""

from __future__ import annotations

from contour_gym.api import make_scenario, simulate
from contour_gym.envs import ENV_IDS, register_envs

__version__ = "0.1.0"

register_envs()

__all__ = ["ENV_IDS", "__version__", "make_scenario", "simulate"]
