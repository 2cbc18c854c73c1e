"""Gymnasium environments: CCC gains or feedrate changes as actions; registered ids."""

from __future__ import annotations

from contour_gym._envstate import CURVATURE_SCALE
from contour_gym.envs.ccc import CCCEnv, CCCVectorEnv
from contour_gym.envs.config import EnvConfig
from contour_gym.envs.feedrate import FeedrateEnv, FeedrateVectorEnv
from contour_gym.envs.registration import ENV_IDS, register_envs

__all__ = [
    "CURVATURE_SCALE",
    "ENV_IDS",
    "CCCEnv",
    "CCCVectorEnv",
    "EnvConfig",
    "FeedrateEnv",
    "FeedrateVectorEnv",
    "register_envs",
]
