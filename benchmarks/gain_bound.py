"""How far can any CCC gain policy go? A per-path search that knows the path, as a bound.

For each path, CMA-ES (``agents.optim.minimize("cma", ...)``, the project's optimiser
interface) searches the CCC env's actions to minimise the episode's peak contour error on that
one path: first one constant action, then, from the best constant, a schedule of ``--segments``
constant actions over equal shares of the episode's decisions. The search knows the whole path
and sees every trial's outcome, which no controller can, so its peak bounds what a policy of the
env's actions reaches there (up to the search's own shortfall). A failed or unfinished trial
scores ``inf`` in the search; a reference that fails shows its peak until then, marked F, as
the bench harness counts it.

Paths: random paths of ``--seeds`` on ``--plant`` (the env's ``path="random"`` draw for that
seed), registered ids (``--ids``: their own paths), library paths (``--library``) and G-code
files (``--gcode``, with ``--path-tolerance``), each with ``--env-kwargs``; the search alone
also with ``--search-kwargs`` (e.g. an agent's wider action map). Prints one row per path
(no CCC, the PID CCC, the best constant, the best schedule, in um) and the medians. It is the
bound docs/measurements.md quotes for 002's machine::

    cd tests/data/gcode && python ../../../benchmarks/gain_bound.py \\
        --plant lugre_linear_motor --seeds 7000-7011 --ids contour_gym/CCC-LuGre-BSpline-v1 \\
        --path-tolerance 1.29e-5 --gcode part_2d.ngc cam_bracket.nc fanuc_plate.nc \\
        grbl_engrave.gcode linuxcnc_pocket.ngc
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path as FilePath
from typing import Any

import gymnasium as gym
import numpy as np

import contour_gym  # noqa: F401 (registers the ids)
from agents.evaluate import make_vector_env, run_episodes, run_policy_batch
from agents.optim import minimize
from agents.policies import Policy, make_policy
from contour_gym.paths import from_gcode

POPULATION = 16  # members of the search's vector env, and CMA-ES's population


class Schedule(Policy):
    """Member b holds ``table[b, k]`` over the k-th of ``segments`` shares of ``decisions``."""

    tasks = ("ccc",)

    def __init__(self, decisions: int, segments: int) -> None:
        self.decisions, self.segments, self.k = decisions, segments, 0
        self.table = np.zeros((POPULATION, segments, 0))  # set by :func:`search`

    def reset(self, env: Any = None) -> None:
        """Back to the first decision."""
        self.k = 0

    def act(self, obs: Any) -> np.ndarray:
        """Each member's action of the current share."""
        n_seg = self.table.shape[1]
        seg = min(self.k * n_seg // self.decisions, n_seg - 1)
        self.k += 1
        return self.table[:, seg, :]


def failed(out: dict[str, np.ndarray]) -> np.ndarray:
    """Each member: failed, or never in position at the end."""
    return np.asarray(out["failed"] | ~out["finished"].astype(bool))


def search(venv: gym.vector.VectorEnv, policy: Schedule, x0: np.ndarray, n_seg: int,
           generations: int, seed: int) -> tuple[float, np.ndarray]:
    """CMA-ES over ``n_seg`` actions per member from ``x0``: the best peak (um), its point."""
    n_act = venv.single_action_space.shape[0]

    def objective(x: np.ndarray) -> np.ndarray:
        peaks = np.empty(len(x))
        for i in range(0, len(x), POPULATION):  # whole batches of the env's members
            chunk = x[i:i + POPULATION]
            rows = np.vstack([chunk, np.repeat(chunk[-1:], POPULATION - len(chunk), axis=0)])
            policy.table = np.repeat(rows.reshape(POPULATION, n_seg, n_act),
                                     policy.segments // n_seg, axis=1)
            out, _ = run_episodes(venv, policy, seed=seed)
            peak = np.where(failed(out), np.inf, out["max_contour_error"] * 1e6)
            peaks[i:i + len(chunk)] = peak[:len(chunk)]
        return peaks

    res = minimize("cma", objective, [[-1.0, 1.0]] * (n_seg * n_act), population=POPULATION,
                   iterations=generations, seed=seed, x0=x0[None, :],
                   sigma0=0.2 if n_seg == 1 else 0.1)
    return float(res.fun), np.asarray(res.x)


def bound(spec: dict[str, Any], seed: int, segments: int, generations: int,
          search_kwargs: dict[str, Any]) -> dict[str, float]:
    """The row of one path: no CCC, PID CCC, best constant, best schedule (um).

    The references run in ``spec``; the search in ``spec`` and ``search_kwargs``.
    """
    row, decisions = {}, 1
    for name in ("no_ccc", "pid_ccc"):
        out = run_policy_batch(spec, make_policy(name), num_envs=1, seed=seed)
        row[name] = float(out["max_contour_error"][0] * 1e6)
        if failed(out)[0]:
            row[f"{name} failed"] = 1.0
        decisions = max(decisions, int(out["steps"][0]))
    policy = Schedule(decisions, segments)
    venv = make_vector_env({**spec, **search_kwargs}, policy, num_envs=POPULATION)
    try:
        x0 = np.zeros(venv.single_action_space.shape[0])
        row["constant"], x1 = search(venv, policy, x0, 1, generations // 2, seed)
        row["schedule"], _ = search(venv, policy, np.tile(x1, segments), segments, generations,
                                    seed)
    finally:
        venv.close()
    row["schedule"] = min(row["schedule"], row["constant"])
    return row


def random_specs(plant: str, seeds: list[int]) -> list[tuple[str, dict[str, Any], int]]:
    """The random path ``env.reset(seed=seed)`` runs on ``plant``, with its corner blending."""
    if not seeds:
        return []
    task = gym.make("contour_gym/CCC-v1", plant=plant, path="random").unwrapped.task
    out = []
    for seed in seeds:
        sc = task.config.random_scenario(np.random.default_rng(seed), task.task_kind,
                                         as_reset=True)
        control = {k: sc.options[k] for k in ("path_control", "path_tolerance")}
        out.append((str(seed), {"id": "contour_gym/CCC-v1", "plant": plant, "path": sc.path,
                                **control}, seed))
    return out


def add_path_arguments(parser: argparse.ArgumentParser, gcode: bool = True) -> None:
    """The path options (module docstring): ``--plant``, ``--seeds``, ``--ids``, ``--library``,
    ``--gcode`` and ``--path-tolerance`` (if ``gcode``), ``--env-kwargs``."""
    parser.add_argument("--plant", default="lugre_linear_motor")
    parser.add_argument("--seeds", type=seed_range, default=[])
    parser.add_argument("--ids", nargs="*", default=[])
    parser.add_argument("--library", nargs="*", default=[], help="library path names")
    if gcode:
        parser.add_argument("--gcode", nargs="*", default=[])
        parser.add_argument("--path-tolerance", type=float, default=None)
    parser.add_argument("--env-kwargs", type=json_object, default={},
                        help='more env keyword arguments, JSON (e.g. \'{"controller_options": '
                        '{"friction": "feedforward"}}\')')


def paths(args: argparse.Namespace) -> list[tuple[str, dict[str, Any], int]]:
    """(name, env spec, seed) of every path asked for, ``--env-kwargs`` not yet applied."""
    out = random_specs(args.plant, args.seeds)
    out += [(env_id.split("/")[-1], {"id": env_id}, 0) for env_id in args.ids]
    out += [(name, {"id": "contour_gym/CCC-v1", "plant": args.plant, "path": name}, 0)
            for name in args.library]
    for file in getattr(args, "gcode", []):
        part = from_gcode(FilePath(file).read_text(encoding="utf-8"), name=FilePath(file).stem)
        spec = {"id": "contour_gym/CCC-v1", "plant": args.plant, "path": part}
        if args.path_tolerance is not None:
            spec["path_tolerance"] = args.path_tolerance
        out.append((part.name, spec, 0))
    return out


def seed_range(text: str) -> list[int]:
    """``"7000-7011"`` or ``"7000,7003"`` as a list of seeds."""
    if "-" in text:
        lo, hi = (int(v) for v in text.split("-"))
        if hi < lo:
            raise argparse.ArgumentTypeError(f"empty seed range {text!r}")
        return list(range(lo, hi + 1))
    return [int(v) for v in text.split(",") if v]


def json_object(text: str) -> dict[str, Any]:
    """A JSON object of keyword arguments."""
    value = json.loads(text)
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"not a JSON object: {text!r}")
    return value


def at_least(low: int) -> Any:
    """An argparse type: an int >= ``low``."""
    def parse(text: str) -> int:
        if int(text) < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, got {text!r}")
        return int(text)
    return parse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_path_arguments(parser)
    parser.add_argument("--search-kwargs", type=json_object, default={},
                        help="env keyword arguments of the search alone, JSON (an agent's "
                        "action map: ccc_gains, kd_scale)")
    parser.add_argument("--segments", type=at_least(1), default=8)
    parser.add_argument("--generations", type=at_least(2), default=60,
                        help="of the schedule's search; the constant's gets half")
    args = parser.parse_args()
    if not (args.seeds or args.ids or args.library or args.gcode):
        parser.error("give paths: --seeds, --ids, --library or --gcode")
    cols = ("no_ccc", "pid_ccc", "constant", "schedule")
    print(f"| path | {' | '.join(cols)} | schedule vs PID CCC | s |\n|---|{'---|' * 6}")
    rows = []
    for name, spec, seed in paths(args):
        spec = {**spec, **args.env_kwargs}
        start = time.perf_counter()
        row = bound(spec, seed, args.segments, args.generations, args.search_kwargs)
        rows.append(row)
        cells = " | ".join(f"{row[c]:.1f}{' F' if f'{c} failed' in row else ''}" for c in cols)
        print(f"| {name} | {cells} | {row['schedule'] / row['pid_ccc'] - 1:+.0%} | "
              f"{time.perf_counter() - start:.0f} |", flush=True)
    medians = {c: float(np.median([r[c] for r in rows])) for c in cols}
    print(f"| median | {' | '.join(f'{medians[c]:.1f}' for c in cols)} | "
          f"{medians['schedule'] / medians['pid_ccc'] - 1:+.0%} | |")
    print(f"Peak contour error, um ({args.segments} segments, {args.generations} generations of "
          f"{POPULATION}; rows 20 % below the PID CCC: "
          f"{sum(r['schedule'] <= 0.8 * r['pid_ccc'] for r in rows)} of {len(rows)}).")


if __name__ == "__main__":
    main()
