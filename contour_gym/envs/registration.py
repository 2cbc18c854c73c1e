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

from contour_gym.envs.config import EnvConfig

# 003 case 2 runs its three-leaf with the y offsets +30/+90 mm (case 1's circle: +70/+210)
GANTRY_LEAF = {
    "preset": "xyy_gantry",
    "stage": {"contours": {0: {"offset": (0.0, 0.03)}, 1: {"offset": (0.0, 0.09)}}},
}

# id -> (task, env kwargs): one per paper scenario. Unset keys take the preset's paper
# settings (estimator, tolerance, axis controller, CCC injection, laps).
SCENARIOS: dict[str, tuple[str, dict[str, Any]]] = {
    "CCC-v0": ("CCC", {}),
    "Feedrate-v0": ("Feedrate", {"plant": "xy_servo_coulomb"}),
    "CCC-Circle-v0": ("CCC", {"plant": "xy_dc_servo", "path": "circle_r10"}),
    "CCC-Infinity-v0": (
        "CCC", {"plant": "xy_dc_servo", "path": "infinity", "estimator": "two_circle"}
    ),
    "CCC-Trident-v0": (
        "CCC", {"plant": "xy_dc_servo", "path": "trident", "estimator": "two_circle"}
    ),
    "CCC-PMLSM-Helix-v0": ("CCC", {"plant": "xyz_pmlsm", "path": "helix"}),
    "CCC-LuGre-BSpline-v0": ("CCC", {"plant": "lugre_linear_motor", "path": "bspline_complex"}),
    "CCC-XYYGantry-Circle-v0": ("CCC", {"plant": "xyy_gantry", "path": "circle_r50"}),
    "CCC-XYYGantry-ThreeLeaf-v0": ("CCC", {"plant": GANTRY_LEAF, "path": "three_leaf", "laps": 20}),
    "Feedrate-Circle-v0": ("Feedrate", {"plant": "xy_servo_coulomb", "path": "circle_r20"}),
    "Feedrate-Corner-v0": (
        "Feedrate",
        {"plant": "xy_servo_coulomb", "path": "corner", "feedrate": 0.048, "path_control": "G61",
         "tolerance": 4.5e-6},
    ),
}

_ENTRY = {
    "CCC": ("contour_gym.envs.ccc:CCCEnv", "contour_gym.envs.ccc:CCCVectorEnv"),
    "Feedrate": (
        "contour_gym.envs.feedrate:FeedrateEnv",
        "contour_gym.envs.feedrate:FeedrateVectorEnv",
    ),
}


def register_envs() -> None:
    """Register every id (idempotent): each scenario as ``-v0`` (v0's observation) and ``-v1``."""
    for name, (task, kwargs) in SCENARIOS.items():
        single, vector = _ENTRY[task]
        for version, extra in (("v0", {"observation": "v0"}), ("v1", {})):
            env_id = f"contour_gym/{name.removesuffix('-v0')}-{version}"
            if env_id not in gym.registry:
                gym.register(id=env_id, entry_point=single, vector_entry_point=vector,
                             kwargs={**kwargs, **extra})


# every scenario with v0's observation, then with v1's
ENV_IDS = tuple(f"contour_gym/{name.removesuffix('-v0')}-{version}"
                for version in ("v0", "v1") for name in SCENARIOS)


def scenario_table() -> list[dict[str, Any]]:
    """One row per registered id with the settings it runs.

    Machine, path, laps, feedrate, estimator, tolerance, axis controller and CCC injection, read
    from the scenario the env builds (the preset's paper settings where the id is silent).
    """
    rows = []
    for name, (task, kwargs) in SCENARIOS.items():
        config = EnvConfig.from_kwargs(dict(kwargs))
        sc = config.scenario()
        rows.append({
            "id": f"contour_gym/{name}", "task": task, "plant": sc.preset.name,
            "path": config.path or sc.preset.path, "laps": sc.laps,
            "feedrate": "time law" if sc.path.time_law is not None else sc.feedrate,
            "path_control": config.path_control or "none",
            "estimator": sc.options["estimator"], "tolerance": config.tolerance_for(sc.preset),
            "axis_controller": sc.options["axis_controller"],
            "ccc_injection": sc.options["ccc_injection"],
        })
    return rows
