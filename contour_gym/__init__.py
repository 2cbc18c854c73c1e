"""contour-gym: Gymnasium environments for multi-axis CNC servo contouring.

``import contour_gym`` registers the environment ids (``contour_gym.ENV_IDS``) and never
imports torch.
"""

from __future__ import annotations

from contour_gym import jit

jit.configure()  # before any kernel module is imported

from contour_gym.api import make_scenario, simulate  # noqa: E402
from contour_gym.envs import ENV_IDS, register_envs  # noqa: E402
from contour_gym.jit.precompile import compile_builtins as precompile  # noqa: E402

__version__ = "0.1.0"

register_envs()

__all__ = ["ENV_IDS", "__version__", "make_scenario", "precompile", "simulate"]
