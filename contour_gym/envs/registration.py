"""Registered environment ids.

Grammar: ``contour_gym/<Task>[-<Machine>]-<Path>-v<N>`` with Task ``CCC`` or ``Feedrate``; the
generic ``contour_gym/CCC-v0`` and ``contour_gym/Feedrate-v0`` take every argument. Each id
registers ``entry_point`` (single env) and ``vector_entry_point`` (native vector env). No
``max_episode_steps`` is registered: every env truncates itself at its own limit, computed
from its own path, feedrate and decision time (so a user's path or feedrate given to
``gym.make`` runs to its end), and puts the episode's metrics into that step's info.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

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
            kwargs=dict(kwargs),
        )


ENV_IDS = tuple(f"contour_gym/{name}" for name in SCENARIOS)
