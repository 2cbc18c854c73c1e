"""Is every registered task a real trade-off? A constant-action sweep over each id.

For every id in ``contour_gym.ENV_IDS`` (default arguments: the rig, the paper's estimator and
tolerance), one episode per constant action ``a`` in {-1, -0.5, 0, 0.5, 1} (every component
alike), run together as one native vector env (member i holds action i, seed 0):

* the episode return of each action, which is best, and how much worse the all-ones action
  (the largest gains, or the fastest feedrate) scores than the best (issue 9 item 2 asks for
  an interior best and all-ones at least 25 % worse on the CCC ids);
* the failure rule's margin: the lowest return of a completed or truncated episode minus the
  return every failed episode gets (``N r_lo - failure_penalty``); positive means failing never
  pays (item 3);
* for the feedrate ids, the peak contour error over the tolerance at the slowest and the
  fastest constant feedrate the action range allows (item 4: the slowest keeps the tolerance,
  the fastest breaks it), measured with ``simulate`` on the env's scenario.

Prints one table; ``--ids`` restricts it. Not a test: ``tests/test_tasks.py`` checks the same
properties on two ids with smaller budgets.

``--random N`` sweeps the same actions over N random paths instead (``path="random"`` on the
given ids, e.g. ``contour_gym/CCC-v1``; path seeds 1000 to 1000 + N - 1, every action on the
same path: the members share the seed): one row per path with its family, length, the returns,
the best action and each action's peak contour error. A task fit for a general agent has no
single best constant action across paths.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import contour_gym
from agents.evaluate import run_policy_batch
from agents.policies import make_policy
from contour_gym.api import simulate

ACTIONS = (-1.0, -0.5, 0.0, 0.5, 1.0)


def sweep(env_id: str, seed: int = 0) -> dict[str, object]:
    """Returns and failures of one episode per constant action (member i: action i)."""
    task = gym.make(env_id).unwrapped.task  # the env's step limit, reward range and scenario
    actions = np.repeat(np.asarray(ACTIONS)[:, None], task.n_actions, axis=1)
    out = run_policy_batch(env_id, make_policy("constant", action=actions),
                           num_envs=len(ACTIONS), seed=seed)
    floor = task.max_episode_steps * min(task.reward_range[0], 0.0) - task.config.failure_penalty
    return {"returns": out["return"], "failed": out["failed"], "floor": floor, "task": task}


def feedrate_peaks(task: object) -> tuple[float, float]:
    """Peak contour error / tolerance at the slowest and fastest constant feedrate."""
    cfg = task.config  # type: ignore[attr-defined]
    sc = task.scenario  # type: ignore[attr-defined]
    out = []
    for scale in cfg.feedrate_range:
        m = simulate(plant=sc.preset, path=sc.path, ccc_gains=cfg.ccc_gains,  # as the env runs
                     feedrate=sc.feedrate * scale, **dict(sc.options))
        out.append(m["max_contour_error"] / task.tolerance)  # type: ignore[attr-defined]
    return out[0], out[1]


def random_sweep(env_id: str, seed: int) -> dict[str, object]:
    """One episode per constant action on one random path (every member seeded ``seed``)."""
    venv = gym.make_vec(env_id, num_envs=len(ACTIONS), path="random", decision_ticks=20)
    n = len(ACTIONS)
    actions = np.repeat(np.asarray(ACTIONS)[:, None], venv.single_action_space.shape[0], axis=1)
    venv.reset(seed=[seed] * n)
    ret, failed, peak, live = np.zeros(n), np.zeros(n, bool), np.zeros(n), np.ones(n, bool)
    while live.any():
        _, reward, terminated, truncated, info = venv.step(actions)
        ret[live] += reward[live]
        failed |= live & info["failure"]
        ended = live & (terminated | truncated)
        if ended.any():
            peak[ended] = info["metrics"]["max_contour_error"][ended]
        live &= ~ended
    path = venv.unwrapped.task.loop.paths[0]
    venv.close()
    return {"returns": ret, "failed": failed, "peak": peak, "path": path}


def random_main(ids: list[str], count: int) -> None:
    """The ``--random`` table (module docstring)."""
    for env_id in ids:
        print(f"{env_id}, path=random (decision_ticks 20): return, F failed, peak um")
        best = []
        for k in range(count):
            res = random_sweep(env_id, 1000 + k)
            r, failed, peak, path = res["returns"], res["failed"], res["peak"], res["path"]
            best.append(ACTIONS[int(np.argmax(r))])
            cells = " ".join(f"{x:>9.4g}{'F' if f else ' '}{p * 1e6:>7.1f}"
                             for x, f, p in zip(r, failed, peak, strict=True))
            print(f"  {1000 + k} {path.name:<17} {path.length * 1e3:>5.0f} mm {cells} "
                  f"best {best[-1]:+.1f}")
        print(f"  best action per path: {best}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ids", nargs="*", default=list(contour_gym.ENV_IDS))
    parser.add_argument("--random", type=int, default=0, metavar="N",
                        help="sweep N random paths on --ids instead")
    args = parser.parse_args()
    if args.random:
        random_main(args.ids, args.random)
        return
    head = "returns at a = " + " / ".join(f"{a:+.1f}" for a in ACTIONS)
    print(f"{'id':<34} {head:<58} {'best':>5} {'ones vs best':>12} {'fail margin':>11} "
          f"{'slow/tol':>8} {'fast/tol':>8} {'s':>5}")
    for env_id in args.ids:
        start = time.perf_counter()
        res = sweep(env_id)
        r, failed = res["returns"], res["failed"]
        best = int(np.argmax(r))
        worse = (r[best] - r[-1]) / abs(r[best]) if r[best] != 0 else float("nan")
        kept = r[~failed]
        margin = (kept.min() - res["floor"]) if kept.size else float("nan")
        cells = " ".join(f"{x:>10.4g}{'F' if f else ' '}" for x, f in zip(r, failed, strict=True))
        slow = fast = float("nan")
        if "Feedrate" in env_id:
            slow, fast = feedrate_peaks(res["task"])
        print(f"{env_id:<34} {cells:<58} {ACTIONS[best]:>+5.1f} {worse:>12.1%} {margin:>11.4g} "
              f"{slow:>8.2f} {fast:>8.2f} {time.perf_counter() - start:>5.0f}")
    print("F: the episode failed. ones vs best: how much lower the all-ones return is than the "
          "best (CCC ids want >= 25 %, best interior).")


if __name__ == "__main__":
    main()
