"""Speed against workers: the loop, a vector env, bench and tune, on this machine and on Ray.

Prints, for 1, 2, ... workers (up to the CPUs this process may use):

* **loop**: one :class:`~contour_gym.loop.ServoLoop` of B = 1024 members (000's machine on its
  circle, the rig) on ``threads`` threads: env-ticks/s (medians of ``--repeats``, the thread
  counts interleaved so a noisy neighbour hits them alike);
* **processes**: the same loop (B = 256) in N independent processes at once: the machine's
  ceiling, what any parallel scheme can reach;
* **vector env**: ``contour_gym/CCC-v1`` (``decision_ticks`` 10; 000's machine, the cheapest
  per member) and ``contour_gym/CCC-LuGre-BSpline-v1`` (002's) at several ``num_envs``, on 1
  thread, on every thread and on the default (its threads timed against one over the first
  steps, the faster kept: :class:`contour_gym.loop.threads.ThreadChoice`): env-ticks/s;
  ``--only-envs`` prints these tables alone;
* **bench**: the command ``contour-gym bench --suite S --workers N`` in a fresh process, as
  a user runs it (each suite of ``--suites``, default ``default`` and ``generalization``), into
  a fresh folder, after one untimed run (every kernel compiled and cached: the warm figure;
  the first run's is ``cold_start.py``'s), background compiles off;
* **tune**: ``agents.tune.tune("003", workers=N)`` (its full budget unless ``--tune-budget``):
  the run's wall time (threads in one process: no start-up differs between the counts);
  bench and tune rows are medians of ``--wall-repeats`` runs, the worker counts interleaved;
* **Ray**: bench (the last suite) and tune on a local two-node Ray cluster (a head and a worker
  node on 127.0.0.1, one CPU each), beside the one-worker local run; the cluster's start time
  apart.

Speed-up is against one worker in the same run; efficiency = speed-up / workers.

    python benchmarks/scaling.py [--suites default,generalization] [--repeats 5]
        [--wall-repeats 3] [--skip-ray] [--only-envs]
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from contour_gym.api import make_scenario
from contour_gym.loop.threads import available_cpus

LOOP_BATCH, LOOP_TICKS = 1024, 1000
PROCESS_BATCH = 256
ENV_SIZES = (16, 32, 48, 64, 128, 256, 1024)
# the cheapest env per member and step, and 002's (LuGre friction, B-spline): threads pay from
# different batch sizes
ENV_IDS = ("contour_gym/CCC-v1", "contour_gym/CCC-LuGre-BSpline-v1")


def _loop(batch: int, threads: int):  # type: ignore[no-untyped-def]
    sc = make_scenario("xy_dc_servo")
    loop = sc.loop(batch_size=batch, ccc_gains=sc.preset.ccc_gains.as_tuple(), threads=threads)
    loop.step(5)  # compiled, warm
    return loop


def _timed_step(loop, ticks: int) -> float:  # type: ignore[no-untyped-def]
    loop.reset(0)
    start = time.perf_counter()
    loop.step(ticks)
    return time.perf_counter() - start


def loop_rates(counts: list[int], repeats: int) -> dict[int, float]:
    """env-ticks/s of the B = 1024 loop on each thread count (interleaved medians)."""
    loops = {n: _loop(LOOP_BATCH, n) for n in counts}
    times: dict[int, list[float]] = {n: [] for n in counts}
    for _ in range(repeats):
        for n, loop in loops.items():
            times[n].append(_timed_step(loop, LOOP_TICKS))
    return {n: LOOP_BATCH * LOOP_TICKS / float(np.median(t)) for n, t in times.items()}


def _process_worker(args: tuple[int, int, multiprocessing.synchronize.Barrier]) -> float:
    ticks, repeats, barrier = args
    loop = _loop(PROCESS_BATCH, 1)
    rates = []
    for _ in range(repeats):
        barrier.wait()  # every process runs its repeat at the same time
        rates.append(PROCESS_BATCH * ticks / _timed_step(loop, ticks))
    return float(np.median(rates))


def process_rates(counts: list[int], repeats: int) -> dict[int, float]:
    """Aggregate env-ticks/s of N independent processes, each a B = 256 loop on one thread."""
    out = {}
    ctx = multiprocessing.get_context("spawn")
    for n in counts:
        with ctx.Manager() as manager:
            barrier = manager.Barrier(n)
            with ctx.Pool(n) as pool:
                out[n] = sum(pool.map(_process_worker, [(2 * LOOP_TICKS, repeats, barrier)] * n))
    return out


def env_rates(env_id: str, threads: int, repeats: int) -> dict[tuple[int, int | None], float]:
    """env-ticks/s of a vector env at each size: on 1 thread, on ``threads``, on the default.

    The default (``num_threads=None``) times its threads against one over its first steps
    and keeps the faster (:class:`contour_gym.loop.threads.ThreadChoice`): the first, untimed round
    covers those trials.
    """
    out: dict[tuple[int, int | None], float] = {}
    for size in ENV_SIZES:
        envs: dict[int | None, Any] = {}
        for n in (*sorted({1, threads}), None):
            env = gym.make_vec(env_id, num_envs=size, num_threads=n,
                               vectorization_mode="vector_entry_point")
            env.reset(seed=0)
            envs[n] = env
        steps = max(20, 20_000 // size)
        action = np.zeros(envs[1].action_space.shape, dtype=np.float32)
        times: dict[int | None, list[float]] = {n: [] for n in envs}
        for _ in range(repeats + 1):
            for n, env in envs.items():
                start = time.perf_counter()
                for _ in range(steps):
                    env.step(action)
                times[n].append(time.perf_counter() - start)
        ticks = envs[1].unwrapped.task.config.decision_ticks  # type: ignore[attr-defined]
        for n, env in envs.items():
            out[size, n] = size * steps * ticks / float(np.median(times[n][1:]))
            env.close()
    return out


def print_env_table(env_id: str, cpus: int, repeats: int) -> None:
    """The vector env table of ``env_id``: 1 thread, every thread, the default."""
    envs = env_rates(env_id, cpus, repeats)
    name = env_id.split("/")[-1]
    print(f"\n| vector env {name}, num_envs | 1 thread | {cpus} threads | speed-up "
          "| default | its speed-up |\n|---|---|---|---|---|---|")
    for size in ENV_SIZES:
        one, many, auto = envs[size, 1], envs[size, cpus], envs[size, None]
        print(f"| {size} | {one:.3g} | {many:.3g} | {many / one:.2f}x | {auto:.3g} "
              f"| {auto / one:.2f}x |")


def wall(job: Callable[[], object]) -> float:
    """Seconds ``job`` takes."""
    start = time.perf_counter()
    job()
    return time.perf_counter() - start


def median_walls(jobs: dict[int, Callable[[], object]], repeats: int) -> dict[int, float]:
    """Median seconds of each job over ``repeats`` rounds, the jobs interleaved in each round.

    Interleaved, a noisy neighbour hits every worker count alike.
    """
    times: dict[int, list[float]] = {n: [] for n in jobs}
    for _ in range(repeats):
        for n, job in jobs.items():
            times[n].append(wall(job))
    return {n: float(np.median(t)) for n, t in times.items()}


def bench_job(suite: str, root: Path, *flags: str) -> Callable[[], object]:
    """``contour-gym bench`` of ``suite`` in a fresh process, into a fresh folder."""

    def job() -> object:
        out = Path(tempfile.mkdtemp(dir=root))
        env = dict(os.environ, CONTOUR_GYM_BACKGROUND="0")
        try:
            return subprocess.run(
                [sys.executable, "-m", "agents.cli", "bench", "--suite", suite, "--quiet",
                 "--out", str(out), *flags], check=True, env=env, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL)
        finally:
            shutil.rmtree(out, ignore_errors=True)

    return job


def tune_job(budget: tuple[int, int] | None, **where: object) -> Callable[[], object]:
    """Protocol 003 (its budget, or ``(population, iterations)``), no run folder."""
    from agents.tune import tune

    size = {} if budget is None else {"population": budget[0], "iterations": budget[1]}
    return lambda: tune("003", progress=False, **size, **where)  # type: ignore[arg-type]


def row(label: str, workers: int, value: float, base: float, unit: str, faster: bool) -> str:
    """A table row: value, speed-up against ``base`` and efficiency."""
    speedup = value / base if faster else base / value
    return (f"| {label} | {workers} | {value:.3g} {unit} | {speedup:.2f}x | "
            f"{speedup / workers:.0%} |")


def main() -> None:
    """Measure and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suites", default="default,generalization")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--tune-budget", default=None, metavar="M,T",
                        help="population,iterations of protocol 003 (default: its own)")
    parser.add_argument("--wall-repeats", type=int, default=3,
                        help="runs of each bench and tune row (their median)")
    parser.add_argument("--skip-ray", action="store_true")
    parser.add_argument("--only-envs", action="store_true",
                        help="the vector env tables only")
    args = parser.parse_args()
    budget = None if args.tune_budget is None else tuple(
        int(v) for v in args.tune_budget.split(","))
    cpus = available_cpus()
    counts = list(range(1, cpus + 1))
    os.environ.setdefault("CONTOUR_GYM_BACKGROUND", "0")
    from contour_gym import precompile

    precompile(("loop", "env", "path_api"), progress=False)
    walls = "" if args.only_envs else f" (bench and tune: of {args.wall_repeats})"
    print(f"# scaling, {platform.machine()}, {cpus} CPUs usable, {os.cpu_count()} visible; "
          f"medians of {args.repeats}{walls}")
    if not args.only_envs:
        worker_rows(counts, args.repeats, args.suites.split(","), budget, args.wall_repeats,
                    not args.skip_ray)
    for env_id in ENV_IDS:
        print_env_table(env_id, cpus, args.repeats)


def worker_rows(
    counts: list[int], repeats: int, suites: list[str], budget: tuple[int, int] | None,
    wall_repeats: int, ray: bool,
) -> None:
    """The table against workers: the loop, processes, bench, tune (and on Ray)."""
    print("\n| what | workers | speed | speed-up | efficiency |\n|---|---|---|---|---|")
    loops = loop_rates(counts, repeats)
    for n in counts:
        print(row(f"loop, B = {LOOP_BATCH}, threads", n, loops[n], loops[1], "ticks/s", True))
    procs = process_rates(counts, repeats)
    for n in counts:
        print(row(f"loop, B = {PROCESS_BATCH}, processes", n, procs[n], procs[1], "ticks/s",
                  True))
    root = Path(tempfile.mkdtemp(prefix="scaling-"))
    try:
        for suite in suites:
            wall(bench_job(suite, root, "--workers", "1"))  # its kernels compiled and cached
            benches = median_walls({n: bench_job(suite, root, "--workers", str(n))
                                    for n in counts}, wall_repeats)
            for n in counts:
                print(row(f"bench {suite}", n, benches[n], benches[1], "s", False))
        wall(tune_job((4, 1), workers=1))  # its kernels cached
        tunes = median_walls({n: tune_job(budget, workers=n) for n in counts},
                             wall_repeats)
        for n in counts:
            print(row("tune 003", n, tunes[n], tunes[1], "s", False))
        if ray:
            ray_rows(suites[-1], budget, root, benches[1], tunes[1])
    finally:
        shutil.rmtree(root, ignore_errors=True)


def ray_rows(
    suite: str, budget: tuple[int, int] | None, root: Path, bench_one: float, tune_one: float
) -> None:
    """Bench and tune on a local two-node Ray cluster against one local worker."""
    try:
        from agents.parallel import local_cluster
    except ImportError:  # pragma: no cover - agents is here
        return
    start = time.perf_counter()
    try:
        cluster_cm = local_cluster(nodes=2, cpus_per_node=1)
        cluster = cluster_cm.__enter__()
    except ValueError as exc:  # no ray
        print(f"| Ray: {exc} | | | | |")
        return
    try:
        started = time.perf_counter() - start
        bench = wall(bench_job(suite, root, "--ray", cluster.address))
        tune = wall(tune_job(budget, ray=cluster.address))
    finally:
        cluster_cm.__exit__(None, None, None)
    print(row(f"bench {suite}, Ray 2 nodes", 2, bench, bench_one, "s", False))
    print(row("tune 003, Ray 2 nodes", 2, tune, tune_one, "s", False))
    print(f"| (Ray cluster start: {started:.1f} s, not counted) | | | | |")


if __name__ == "__main__":
    main()
