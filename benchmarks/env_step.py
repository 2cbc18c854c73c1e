"""Env steps per second, measured in one run: contour-gym vs gym-electric-motor vs Pendulum.

* ``contour_gym/CCC-v0`` with ``decision_ticks=1`` (one servo tick per step), through
  ``gymnasium.make`` (the wrappers a user gets);
* gym-electric-motor's ``Cont-CC-PMSM-v0`` wrapped in ``FlattenObservation`` (its Tuple
  observation is what SB3 rejects); install it only for this benchmark:
  ``pip install gym-electric-motor`` (it is not a project dependency);
* Gymnasium's ``Pendulum-v1``;
* the native vector env at num_envs = 64 and 1024 (env-steps/s = num_envs x steps/s).

Zero actions, auto-reset on episode end, medians of 5 repeats. Target (issue 4):
contour-gym >= 5x gym-electric-motor.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import contour_gym  # noqa: F401  (registers the ids)

REPEATS = 5


def single_rate(make: Callable[[], Any], steps: int) -> float:
    env = make()
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape, dtype=env.action_space.dtype)
    rates = []
    for _ in range(REPEATS + 1):
        start = time.perf_counter()
        for _ in range(steps):
            _, _, term, trunc, _ = env.step(action)
            if term or trunc:
                env.reset()
        rates.append(steps / (time.perf_counter() - start))
    return float(np.median(rates[1:]))  # the first repeat warms up


def vector_rate(num_envs: int, steps: int) -> float:
    venv = gym.make_vec("contour_gym/CCC-v0", num_envs=num_envs, decision_ticks=1)
    venv.reset(seed=0)
    action = np.zeros(venv.action_space.shape, dtype=np.float32)
    rates = []
    for _ in range(REPEATS + 1):
        start = time.perf_counter()
        for _ in range(steps):
            venv.step(action)
        rates.append(num_envs * steps / (time.perf_counter() - start))
    return float(np.median(rates[1:]))


def gem_maker() -> Callable[[], Any] | None:
    try:
        import gym_electric_motor as gem
    except ImportError:
        return None
    return lambda: gym.wrappers.FlattenObservation(gem.make("Cont-CC-PMSM-v0"))


def main() -> None:
    warnings.filterwarnings("ignore")
    rows: list[tuple[str, float | None]] = [
        (
            "contour_gym/CCC-v0 (decision_ticks=1)",
            single_rate(lambda: gym.make("contour_gym/CCC-v0", decision_ticks=1), 5000),
        ),
    ]
    gem = gem_maker()
    rows.append(("gym-electric-motor Cont-CC-PMSM-v0", single_rate(gem, 3000) if gem else None))
    rows.append(("gymnasium Pendulum-v1", single_rate(lambda: gym.make("Pendulum-v1"), 5000)))
    rows.append(("contour_gym/CCC-v0 vector, num_envs=64", vector_rate(64, 500)))
    rows.append(("contour_gym/CCC-v0 vector, num_envs=1024", vector_rate(1024, 100)))
    ours = rows[0][1]
    print(f"{'environment':<44} {'(env-)steps/s':>14}")
    for name, rate in rows:
        print(f"{name:<44} {'not installed' if rate is None else f'{rate:14.4g}':>14}")
    if rows[1][1]:
        print(f"ratio contour-gym / gym-electric-motor: {ours / rows[1][1]:.2f} (target >= 5)")


if __name__ == "__main__":
    main()
