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
                           num_envs=len(ACTIONS), seed=seed)  # fmt: skip
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ids", nargs="*", default=list(contour_gym.ENV_IDS))
    args = parser.parse_args()
    head = "returns at a = " + " / ".join(f"{a:+.1f}" for a in ACTIONS)
    print(f"{'id':<34} {head:<58} {'best':>5} {'ones vs best':>12} {'fail margin':>11} "
          f"{'slow/tol':>8} {'fast/tol':>8} {'s':>5}")  # fmt: skip
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
              f"{slow:>8.2f} {fast:>8.2f} {time.perf_counter() - start:>5.0f}")  # fmt: skip
    print("F: the episode failed. ones vs best: how much lower the all-ones return is than the "
          "best (CCC ids want >= 25 %, best interior).")


if __name__ == "__main__":
    main()
