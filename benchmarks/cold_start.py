"""What a new user waits for: cold starts, and warm speed beside the previous release.

Cold rows, each in a fresh subprocess; every row but the last two starts on a fresh, empty
``NUMBA_CACHE_DIR`` (a new user's first run):

* ``import contour_gym``;
* ``contour-gym simulate`` (000's circle without and with PID CCC, plot written);
* ``contour-gym bench`` (the default suite, its table);
* on the bench's cache: a new combination of built-in components (another machine, axis
  controller, estimator, CCC law and task kind than any cell of the suite), its first
  episode; and the README's toy estimator registered from a user's module, its first run.

Warm rows, for this checkout and (``--baseline DIR``) a checkout of the previous release run
from its own sources (``git worktree add /tmp/base REV``), interleaved in one run: the loop at
B = 1 and 1024 (``loop_throughput.py``), one env step with ``decision_ticks=1`` against
Gymnasium's ``Pendulum-v1`` (``env_step.py``), the wall time of protocols ``000_circle`` and
``003`` (``contour-gym tune``), and PPO's env-steps/s on the native vector env
(``train_throughput.py``). Each warm figure is the median of ``--repeats`` fresh processes
(the first process of each checkout fills its cache and is not counted).

Usage: ``python benchmarks/cold_start.py [--baseline DIR] [--repeats N] [--skip-bench]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

NEW_COMBINATION = """
import time, gymnasium as gym, numpy as np, contour_gym
t = time.perf_counter()
env = gym.make("contour_gym/CCC-v0", plant="xy_servo_coulomb", axis_controller="smc_dob",
               estimator="iterative", ccc_law="adaptive_fuzzy_pid", decision_ticks=20)
env.reset(seed=0)
done = False
while not done:
    _, _, term, trunc, _ = env.step(np.zeros(env.action_space.shape, np.float32))
    done = term or trunc
print(time.perf_counter() - t)
"""

# the README's toy estimator, from a user's module (tests/test_house.py)
USER_ESTIMATOR = """
import time, contour_gym
from contour_gym.contour import ContourEstimator, register_estimator
from tests.test_house import TOY, toy_foot
register_estimator(ContourEstimator("toy_tangent", TOY, toy_foot, doc="my estimator"))
t = time.perf_counter()
contour_gym.simulate(plant="xy_dc_servo", estimator="toy_tangent",
                     estimator_options={"bias": 2e-6})
print(time.perf_counter() - t)
"""

WARM = {
    "loop B = 1 (ticks/s)": "from loop_throughput import measure; print(measure(1, 2000))",
    "loop B = 1024 (ticks/s)": "from loop_throughput import measure; print(measure(1024, 1000))",
    "env step, decision_ticks=1 (steps/s)": (
        "import gymnasium as gym; from env_step import single_rate; "
        "print(single_rate(lambda: gym.make('contour_gym/CCC-v0', decision_ticks=1), 5000))"
    ),
    "Pendulum-v1 step (steps/s)": (
        "import gymnasium as gym; from env_step import single_rate; "
        "print(single_rate(lambda: gym.make('Pendulum-v1'), 5000))"
    ),
    "protocol 000_circle (s)": (
        "import time; from agents.tune import tune; t = time.perf_counter(); "
        "tune('000_circle', 'improved_pso', seed=0, progress=False); "
        "print(time.perf_counter() - t)"
    ),
    "protocol 003 (s)": (
        "import time; from agents.tune import tune; t = time.perf_counter(); "
        "tune('003', 'improved_abc', seed=0, progress=False); print(time.perf_counter() - t)"
    ),
    "PPO native vector env (env-steps/s)": (
        "import torch; torch.set_num_threads(1); "
        "from train_throughput import build, measure, load_config; "
        "c = load_config('ppo', 'contour_gym/CCC-Circle-v0', overrides={'n_envs': 16}); "
        "s = 2 * c.block['n_steps'] * 16; m, tm = build('native', c, 0); "
        "print(measure(m, tm, s, s // 2, 3)[0])"
    ),
}


def settle(cache: str) -> None:
    """Wait until the background compiles a run started on ``cache`` are done.

    A run of built-in components may leave a detached, niced process compiling (its own kernel,
    or the built-ins' one: ``contour_gym.jit.tiers``); the next row must not share the cores.
    """
    from contour_gym.jit.tiers import _busy

    for lock in Path(cache).rglob("background_*.lock"):
        while _busy(lock):
            time.sleep(0.5)


def settle_everywhere() -> None:
    """Wait for the background compiles of the user's own caches too: measure beside none."""
    from contour_gym import jit

    settle(str(jit.cache_root()))
    settle(str(Path(tempfile.gettempdir()) / "contour_gym_generated"))


def run(args: list[str], root: Path, cache: str, timeout: float = 3600.0) -> tuple[float, str]:
    """Run ``args`` from ``root``'s sources on numba cache ``cache``; wall seconds, stdout.

    The wall time is the run's own; its background compiles are then waited for (:func:`settle`).
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=cache,
               PYTHONPATH=os.pathsep.join([str(root), str(root / "benchmarks")]))
    start = time.perf_counter()
    out = subprocess.run(args, cwd=root, env=env, capture_output=True, text=True,
                         timeout=timeout, check=False)
    wall = time.perf_counter() - start
    if out.returncode != 0:
        raise RuntimeError(f"{args} failed ({out.returncode}):\n{out.stderr[-3000:]}")
    settle(cache)
    return wall, out.stdout


def python(code: str) -> list[str]:
    return [sys.executable, "-c", code]


def cli(*words: str) -> list[str]:
    return python(f"import sys; from agents.cli import main; sys.exit(main({list(words)!r}))")


def cold_rows(root: Path, skip_bench: bool) -> list[tuple[str, float]]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        rows.append(("import contour_gym", run(python("import contour_gym"), root,
                                               f"{tmp}/c0")[0]))
        plot = f"{tmp}/simulate.png"
        rows.append(("contour-gym simulate", run(cli("simulate", "--out", plot), root,
                                                 f"{tmp}/c1")[0]))
        cache = f"{tmp}/c2"
        if not skip_bench:
            wall, _ = run(cli("bench", "--out", f"{tmp}/bench", "--quiet"), root, cache)
            rows.append(("contour-gym bench (default suite)", wall))
            first = float(run(python(NEW_COMBINATION), root, cache)[1].split()[-1])
            rows.append(("new built-in combination, first episode (bench's cache)", first))
        first = float(run(python(USER_ESTIMATOR), root, cache)[1].split()[-1])
        rows.append(("user-registered estimator, first run (bench's cache)", first))
    return rows


def warm_rows(roots: dict[str, Path], repeats: int) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {name: {} for name in WARM}
    with tempfile.TemporaryDirectory() as tmp:
        caches = {label: f"{tmp}/{i}" for i, label in enumerate(roots)}
        for name, code in WARM.items():
            for label, root in roots.items():
                run(python(code), root, caches[label])  # fills the cache; not counted
            values: dict[str, list[float]] = {label: [] for label in roots}
            for _ in range(repeats):  # interleaved: a busy moment hits both checkouts
                for label, root in roots.items():
                    values[label].append(float(run(python(code), root, caches[label])[1]
                                               .split()[-1]))
            for label in roots:
                out[name][label] = statistics.median(values[label])
            print(f"  {name}: " + ", ".join(f"{k} {v:.4g}" for k, v in out[name].items()),
                  file=sys.stderr, flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, default=None, metavar="DIR",
                        help="checkout of the previous release, for the warm rows")
    parser.add_argument("--repeats", type=int, default=5, help="processes per warm figure")
    parser.add_argument("--skip-bench", action="store_true", help="no bench cold row")
    parser.add_argument("--skip-warm", action="store_true", help="no warm rows")
    args = parser.parse_args()
    settle_everywhere()
    print(f"# cold start, {os.cpu_count()} cores, fresh NUMBA_CACHE_DIR per row")
    print("| what | wall (s) |\n|---|---|")
    for name, wall in cold_rows(HERE, args.skip_bench):
        print(f"| {name} | {wall:.1f} |", flush=True)
    if args.skip_warm:
        return
    roots = {"this": HERE}
    if args.baseline is not None:
        roots["previous"] = args.baseline.resolve()
    table = warm_rows(roots, args.repeats)
    print(f"\n# warm, medians of {args.repeats} processes each")
    head = " | ".join(roots)
    print(f"| figure | {head} |" + (" this / previous |" if len(roots) > 1 else ""))
    print("|---|" + "---|" * (len(roots) + (len(roots) > 1)))
    for name, values in table.items():
        cells = " | ".join(f"{values[label]:.4g}" for label in roots)
        ratio = f" {values['this'] / values['previous']:.2f} |" if len(roots) > 1 else ""
        print(f"| {name} | {cells} |{ratio}")


if __name__ == "__main__":
    main()
