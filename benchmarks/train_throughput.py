"""PPO and SAC training throughput: the native vector env against DummyVecEnv of single envs.

Both backends train the same algo with the id's block of ``configs/rl/<algo>.yml`` at the same
``n_envs`` (16 by default), wrapped the same way (the flattened observation, VecMonitor,
VecNormalize as configured), one torch thread. Each repeat times ``model.learn`` over a fixed
number of env steps (learning included; SAC after its ``learning_starts``) on the same model,
so the median is over repeats of one run. ``env share`` is the fraction of that time spent
inside the VecEnv's ``step_wait`` (the env, and for DummyVecEnv its Python loop); the rest is
SB3 (policy forward passes, buffers, gradient steps). ``PPO, Dict observation`` trains on the
env's Dict (``MultiInputPolicy``, no ``env_wrapper``), as the configs did before they flattened
it. The ``env only`` row steps the same wrapped VecEnvs with random actions, without the
wrappers and the agent: the ratio's ceiling were SB3 free. The last lines give the other
ceiling, were the native env free: DummyVecEnv's time per step over SB3's own (the native
run's time outside ``step_wait``).

    python benchmarks/train_throughput.py [--env ID] [--n-envs 16] [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3.common.vec_env import (
    DummyVecEnv,
    VecEnvWrapper,
    VecMonitor,
    VecNormalize,
)

import contour_gym  # noqa: F401
from agents.rl.config import algo_class, load_config
from agents.rl.train import flattens
from agents.rl.vec_env import make_native_vec_env


class StepTimer(VecEnvWrapper):
    """Accumulates the wall time spent in the wrapped env's ``step_wait``."""

    def __init__(self, venv: Any) -> None:
        super().__init__(venv)
        self.seconds = 0.0

    def reset(self) -> Any:
        return self.venv.reset()

    def step_wait(self) -> Any:
        start = time.perf_counter()
        out = self.venv.step_wait()
        self.seconds += time.perf_counter() - start
        return out


def build(backend: str, config: Any, seed: int) -> tuple[Any, StepTimer]:
    n, kwargs, flat = config.n_envs, config.env_kwargs, flattens(config)
    if backend == "native":
        base: Any = make_native_vec_env(config.env_id, n, flatten=flat, **kwargs)
    else:
        def single() -> gym.Env[Any, Any]:
            env = gym.make(config.env_id, **kwargs)
            return gym.wrappers.FlattenObservation(env) if flat else env

        base = DummyVecEnv([single for _ in range(n)])
    timer = StepTimer(base)
    venv: Any = VecMonitor(timer)
    if config.normalize is not None:
        venv = VecNormalize(venv, **config.normalize)
    n_actions = int(np.prod(venv.action_space.shape))
    model = algo_class(config.algo)(env=venv, seed=seed, device="cpu",
                                    **config.model_kwargs(n_actions))
    return model, timer


def measure(
    model: Any, timer: StepTimer, steps: int, warmup: int, repeats: int
) -> tuple[float, float]:
    model.learn(warmup, reset_num_timesteps=False)
    rates, shares = [], []
    for _ in range(repeats):
        timer.seconds = 0.0
        start, before = time.perf_counter(), model.num_timesteps
        model.learn(steps, reset_num_timesteps=False)
        elapsed = time.perf_counter() - start
        rates.append((model.num_timesteps - before) / elapsed)
        shares.append(timer.seconds / elapsed)
    return statistics.median(rates), statistics.median(shares)


def env_only(config: Any, backend: str, steps: int, repeats: int) -> float:
    model, timer = build(backend, config, seed=0)
    venv = timer.venv  # the bare VecEnv: no VecMonitor, no VecNormalize, no agent
    venv.seed(0)
    venv.reset()
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (64, config.n_envs, *venv.action_space.shape)).astype(np.float32)
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for k in range(steps // config.n_envs):
            venv.step(actions[k % len(actions)])
        rates.append(steps // config.n_envs * config.n_envs / (time.perf_counter() - start))
    venv.close()
    return statistics.median(rates)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="contour_gym/CCC-Circle-v0")
    parser.add_argument("--n-envs", type=int, default=16)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--algos", nargs="+", default=["ppo", "sac"])
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows = []
    for algo in args.algos:
        config = load_config(algo, args.env, overrides={"n_envs": args.n_envs})
        if algo == "ppo":  # two updates per repeat
            steps = 2 * config.block["n_steps"] * args.n_envs
            warmup = steps // 2
        else:  # past learning_starts, then 256 vector steps per repeat
            steps = 256 * args.n_envs
            warmup = config.block.get("learning_starts", 100) + 16 * args.n_envs
        result = {}
        for backend in ("native", "dummy"):
            model, timer = build(backend, config, seed=0)
            result[backend] = measure(model, timer, steps, warmup, args.repeats)
            model.get_env().close()
        rows.append((algo.upper(), result))
        if algo == "ppo":  # the same on the Dict observation (no FlattenObservation)
            dict_config = load_config(algo, args.env, overrides={
                "n_envs": args.n_envs, "env_wrapper": None, "policy": "MultiInputPolicy"})
            result = {}
            for backend in ("native", "dummy"):
                model, timer = build(backend, dict_config, seed=0)
                result[backend] = measure(model, timer, steps, warmup, args.repeats)
                model.get_env().close()
            rows.append(("PPO, Dict observation", result))
    config = load_config("ppo", args.env, overrides={"n_envs": args.n_envs})
    rows.append(("env only", {b: (env_only(config, b, 4096, args.repeats), 1.0)
                              for b in ("native", "dummy")}))
    print(f"{args.env}, n_envs = {args.n_envs}, medians of {args.repeats} repeats, 1 torch thread")
    print("| algo | native env-steps/s | native env share | DummyVecEnv env-steps/s "
          "| DummyVecEnv env share | native / DummyVecEnv |")
    print("|---|---|---|---|---|---|")
    for algo, r in rows:
        (nat, nat_share), (dum, dum_share) = r["native"], r["dummy"]
        print(f"| {algo} | {nat:,.0f} | {nat_share:.0%} | {dum:,.0f} | {dum_share:.0%} "
              f"| {nat / dum:.2f}x |")
    for algo, r in rows[:-1]:
        (nat, nat_share), (dum, _) = r["native"], r["dummy"]
        sb3 = (1.0 - nat_share) / nat  # s per env step outside the env
        print(f"{algo}: SB3 takes {sb3 * 1e6:.0f} us per env step; with a free env the ratio "
              f"could reach at most {1.0 / dum / sb3:.2f}x")


if __name__ == "__main__":
    main()
