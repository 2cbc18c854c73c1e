"""Registered environment ids.

Grammar: ``contour_gym/<Task>[-<Machine>]-<Path>-v<N>`` with Task ``CCC`` or ``Feedrate``; the
generic ``contour_gym/CCC-v0`` and ``contour_gym/Feedrate-v0`` take every argument. Each id
registers ``entry_point`` (single env), ``vector_entry_point`` (native vector env) and
``max_episode_steps`` = ``EPISODE_MARGIN`` x (nominal cycle time / decision time) for the
CCC env and ``1 / F_min`` times that for the feedrate env, so truncation only ends
episodes that stalled.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym

from contour_gym.api import make_scenario
from contour_gym.envs.config import EnvConfig

EPISODE_MARGIN = 2.0

# id -> (task, env kwargs): one per paper scenario
SCENARIOS: dict[str, tuple[str, dict[str, Any]]] = {
    "CCC-v0": ("CCC", {}),
    "Feedrate-v0": ("Feedrate", {"plant": "xy_servo_coulomb"}),
    "CCC-Circle-v0": ("CCC", {"plant": "xy_dc_servo", "path": "circle_r10"}),
    "CCC-Infinity-v0": ("CCC", {"plant": "xy_dc_servo", "path": "infinity"}),
    "CCC-Trident-v0": ("CCC", {"plant": "xy_dc_servo", "path": "trident"}),
    "CCC-PMLSM-Helix-v0": ("CCC", {"plant": "xyz_pmlsm", "path": "helix"}),
    "CCC-LuGre-BSpline-v0": ("CCC", {"plant": "lugre_linear_motor", "path": "bspline_complex"}),
    "CCC-XYYGantry-Circle-v0": ("CCC", {"plant": "xyy_gantry", "path": "circle_r50"}),
    "CCC-XYYGantry-ThreeLeaf-v0": ("CCC", {"plant": "xyy_gantry", "path": "three_leaf"}),
    "Feedrate-Circle-v0": ("Feedrate", {"plant": "xy_servo_coulomb", "path": "circle_r20"}),
    "Feedrate-Corner-v0": ("Feedrate", {"plant": "xy_servo_coulomb", "path": "corner"}),
}

_ENTRY = {
    "CCC": ("contour_gym.envs.ccc:CCCEnv", "contour_gym.envs.ccc:CCCVectorEnv"),
    "Feedrate": (
        "contour_gym.envs.feedrate:FeedrateEnv",
        "contour_gym.envs.feedrate:FeedrateVectorEnv",
    ),
}


def max_episode_steps(task: str, kwargs: dict[str, Any]) -> int:
    """Registered step limit of a scenario (see the module docstring)."""
    cfg = EnvConfig.from_kwargs(kwargs)
    sc = make_scenario(cfg.plant, cfg.path, cfg.feedrate)
    decisions = sc.path.length / sc.feedrate / (cfg.decision_ticks * sc.preset.stage.ts)
    slow = 1.0 / cfg.feedrate_range[0] if task == "Feedrate" else 1.0
    return int(math.ceil(EPISODE_MARGIN * slow * decisions)) + 10


def register_envs() -> None:
    """Register every id (idempotent)."""
    for name, (task, kwargs) in SCENARIOS.items():
        env_id = f"contour_gym/{name}"
        if env_id in gym.registry:
            continue
        single, vector = _ENTRY[task]
        gym.register(
            id=env_id,
            entry_point=single,
            vector_entry_point=vector,
            max_episode_steps=max_episode_steps(task, kwargs),
            kwargs=dict(kwargs),
        )


ENV_IDS = tuple(f"contour_gym/{name}" for name in SCENARIOS)
