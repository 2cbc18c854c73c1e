"""Train stable-baselines3 agents on the registered contour-gym ids.

Hyperparameters come from ``configs/rl/<algo>.yaml`` (SB3 argument names), overridable per
call. Checkpoints are written every ``checkpoint_every`` steps and the model is saved when
training ends, including on KeyboardInterrupt, so an interrupted run loses nothing.
Needs the ``rl`` extra (stable-baselines3, torch).
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path
from typing import Any

import gymnasium as gym
import yaml

import contour_gym  # noqa: F401  (registers the ids)

ALGOS = ("ppo", "sac")


def load_hyperparameters(algo: str) -> dict[str, Any]:
    """The YAML hyperparameters of ``algo`` shipped in ``configs/rl``."""
    if algo not in ALGOS:
        raise ValueError(f"unknown algo {algo!r}; accepted: {', '.join(ALGOS)}")
    # configs/ ships inside the wheel as agents/configs (a link in the source tree)
    text = (importlib.resources.files("agents") / "configs" / "rl" / f"{algo}.yaml").read_text()
    data = yaml.safe_load(text)
    if not isinstance(data, dict):
        raise ValueError(f"configs/rl/{algo}.yaml must hold a mapping")
    return data


def train(
    env_id: str,
    algo: str = "ppo",
    total_timesteps: int = 10_000,
    seed: int = 0,
    out_dir: str | Path = "runs",
    env_kwargs: dict[str, Any] | None = None,
    checkpoint_every: int = 10_000,
    **overrides: Any,
) -> Path:
    """Train an agent and save it; returns the saved model's path (``.zip``).

    Args:
        env_id: A registered id, e.g. ``"contour_gym/CCC-Circle-v0"``.
        algo: ``"ppo"`` or ``"sac"``.
        total_timesteps: Env steps to train for.
        seed: Seed of the agent and the env.
        out_dir: Folder for checkpoints, the final model and TensorBoard-free logs.
        env_kwargs: Arguments of the env (``gymnasium.make`` kwargs).
        checkpoint_every: Steps between checkpoints.
        **overrides: SB3 constructor arguments replacing the YAML ones.

    Returns:
        Path of the final model.
    """
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import CheckpointCallback

    params = {**load_hyperparameters(algo), **overrides}
    policy = params.pop("policy")
    env = gym.make(env_id, **(env_kwargs or {}))
    cls = {"ppo": PPO, "sac": SAC}[algo]
    model = cls(policy, env, seed=seed, verbose=0, **params)
    out = Path(out_dir) / f"{env_id.replace('/', '_')}_{algo}_seed{seed}"
    out.mkdir(parents=True, exist_ok=True)
    checkpoints = CheckpointCallback(
        max(1, checkpoint_every), str(out / "checkpoints"), name_prefix=algo
    )
    try:
        model.learn(total_timesteps=total_timesteps, callback=checkpoints)
    finally:  # also on KeyboardInterrupt: keep what was learned
        model.save(out / "model")
        env.close()
    return out / "model.zip"
