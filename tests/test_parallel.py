"""Every core and a cluster: the same numbers for any number of threads, workers or nodes."""

from __future__ import annotations

import builtins
import hashlib
import importlib.util
import json
import os
import subprocess
import sys
import threading
import time
import zipfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

from agents.bench import _plot_names, run_cell, run_suite
from agents.cli import main
from agents.parallel import RAY_HINT, Processes, Runner, runner, start_method
from agents.rl.sweep import parse_grid, run_trials, trials
from agents.suites import load_suite
from agents.tune import tune
from contour_gym.api import make_scenario
from contour_gym.loop.threads import (
    MIN_MEMBERS_PER_THREAD,
    RECHECK,
    TRIALS,
    ThreadChoice,
    available_cpus,
    check_threads,
    default_threads,
    split,
)

SUITE = "tiny"
ENV, STEPS = "contour_gym/CCC-Circle-v0", 1000  # two 1000-step runs (seeds 0, 1)


def episodes(folder: Path) -> dict[str, Any]:
    # every cell's episodes (their metrics), by file: what must not depend on where they ran
    return {str(f.relative_to(folder)): json.loads(f.read_text())["episodes"]
            for f in sorted((folder / "cells").glob("*/*.json"))}


def weights(run: Path) -> str:
    with zipfile.ZipFile(run / "model.zip") as z:
        return hashlib.sha256(z.read("policy.pth")).hexdigest()


@pytest.fixture(scope="module")
def local_bench(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The tiny suite's cells, run in this process."""
    out = tmp_path_factory.mktemp("bench") / "one"
    run_suite(SUITE, out, progress=False, workers=1)
    return episodes(out)


@pytest.fixture(scope="module")
def parallel_runs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Seeds 0 and 1 of a 1000-step PPO run, trained at once on two worker processes."""
    out = tmp_path_factory.mktemp("train") / "two"
    return run_trials(trials(ENV, ["ppo"], [0, 1], {}, out, STEPS), workers=2)


# ------------------------------------------------------------------------------ threads
def test_parts_cover_the_batch_evenly_and_the_default_pays() -> None:
    assert split(7, 3) == ((0, 3, 0), (3, 5, 1), (5, 7, 2))
    assert check_threads(8, 3) == 3  # at most one per member
    assert default_threads(MIN_MEMBERS_PER_THREAD - 1) == 1
    with pytest.raises(ValueError, match="num_threads"):
        check_threads(0, 4)


def test_the_loop_on_threads_equals_one_thread_bit_for_bit() -> None:
    sc = make_scenario("xy_dc_servo", ideal=False)
    out = []
    for threads in (1, 3):
        loop = sc.loop(batch_size=5, ccc_gains=sc.preset.ccc_gains.as_tuple(), threads=threads)
        loop.set_ccc_gains(np.linspace(0.5, 2.0, 5)[:, None, None] * sc.preset.ccc_gains.as_tuple())
        loop.reset(7)
        loop.step(300)
        out.append((loop.ax_s.copy(), loop.sums.contour.copy(), loop.metrics()))
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1], out[1][1])
    for key, value in out[0][2].items():
        np.testing.assert_array_equal(value, out[1][2][key], err_msg=key)


def test_the_thread_choice_keeps_the_faster_after_its_trials_and_tries_again() -> None:
    for one_seconds, kept in ((1.0, 1), (3.0, 2)):
        choice = ThreadChoice(split(64, 2))
        for call in range(2 * TRIALS + 1):
            parts = choice.parts()
            assert choice.kept is None
            assert len(parts) == (1 if call % 2 else 2)  # all parts first (a warm-up), then turns
            seconds = 100.0 if call == 0 else (one_seconds if len(parts) == 1 else 2.0)
            choice.record(parts, 10 * seconds, 10)
        assert choice.kept is not None and len(choice.kept) == kept
        assert choice.kept == (((0, 64, 0),) if kept == 1 else split(64, 2))
        for _ in range(RECHECK):
            assert choice.parts() == choice.kept
            choice.record(choice.kept, 1.0, 10)
        assert choice.kept is None and len(choice.parts()) == 2  # on trial again


@pytest.mark.skipif(available_cpus() < 2, reason="the default is one thread on one CPU")
def test_a_loop_on_the_default_threads_chooses_and_equals_one_thread_bit_for_bit() -> None:
    sc = make_scenario("xy_dc_servo", ideal=False)
    batch = 2 * MIN_MEMBERS_PER_THREAD
    out = []
    for threads in (1, None):
        loop = sc.loop(batch_size=batch, ccc_gains=sc.preset.ccc_gains.as_tuple(),
                       threads=threads)
        loop.set_ccc_gains(np.linspace(0.5, 2.0, batch)[:, None, None]
                           * sc.preset.ccc_gains.as_tuple())
        loop.reset(7)
        for _ in range(2 * TRIALS + 3):
            loop.step(40)
        out.append((loop.ax_s.copy(), loop.sums.contour.copy()))
    assert loop._choice is not None and loop._choice.kept is not None  # chosen during the run
    np.testing.assert_array_equal(out[0][0], out[1][0])
    np.testing.assert_array_equal(out[0][1], out[1][1])


@pytest.mark.parametrize("env_id", ["contour_gym/CCC-v1", "contour_gym/Feedrate-v1"])
def test_a_vector_env_on_threads_equals_one_thread_bit_for_bit(env_id: str) -> None:
    runs = []
    for threads in (1, 2, None):  # None: the default's threads on trial, then chosen
        env = gym.make_vec(env_id, num_envs=2 * MIN_MEMBERS_PER_THREAD,
                           vectorization_mode="vector_entry_point", num_threads=threads,
                           path="random", decision_ticks=20, max_episode_steps=15)
        rng = np.random.default_rng(3)
        obs, _ = env.reset(seed=11)
        steps = [obs]
        for _ in range(40):  # episodes of 15 steps: every member auto-resets (a new path)
            obs, reward, term, trunc, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
            steps.append((obs, reward, term, trunc, info["contour_error"], info["s"]))
        runs.append(steps)
        env.close()
    assert sum(int(np.sum(s[2] | s[3])) for s in runs[0][1:]) >= 5  # the resets happened
    for other in runs[1:]:
        for a, b in zip(runs[0], other, strict=True):
            np.testing.assert_equal(a, b)


# ------------------------------------------------------------------------ processes
@pytest.fixture
def workers_from_the_start(monkeypatch: pytest.MonkeyPatch) -> None:
    # a tiny run ends before a spawned worker has started: make the workers take units
    monkeypatch.setattr(Processes, "wait_for_workers", True)


def test_bench_on_worker_processes_equals_one_process(
    local_bench: dict[str, Any], tmp_path: Path, workers_from_the_start: None
) -> None:
    result = run_suite(SUITE, tmp_path / "two", progress=False, workers=2)
    assert len(result.computed) == len(local_bench)
    assert episodes(tmp_path / "two") == local_bench
    assert sorted(p.name for p in (tmp_path / "two" / "plots").iterdir())


LINUX = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork on Linux only")


def fresh_python(code: str) -> str:
    """``code`` run by a new interpreter in the repository; its stdout (its stderr if it fails).

    For what pytest's own process cannot show: it runs threads (its workers spawn) and has
    imported torch.
    """
    done = subprocess.run([sys.executable, "-c", code], cwd=Path(__file__).parent.parent,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


@LINUX
def test_a_fresh_process_forks_its_workers_and_their_bench_equals_one_process(
    local_bench: dict[str, Any], tmp_path: Path
) -> None:
    # pytest's own threads make this process spawn: a command's fresh interpreter forks
    code = ("import os, sys, time\n"
            "from agents.bench import run_suite\n"
            "from agents.parallel import Processes, start_method\n"
            "def pid(_):\n    time.sleep(0.2)\n    return os.getpid()\n"
            "assert start_method() == 'fork', start_method()\n"
            "Processes.wait_for_workers = True\n"
            "with Processes(2) as where:\n"
            "    print(len(set(dict(where.map(pid, range(6))).values())))\n"
            f"run_suite({SUITE!r}, {str(tmp_path / 'f')!r}, progress=False, workers=2)\n"
            "print(start_method())\n")
    assert fresh_python(code).split() == ["2", "fork"]  # two processes took units; still forkable
    assert episodes(tmp_path / "f") == local_bench


@LINUX
def test_a_process_with_threads_or_torch_spawns_its_workers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(threading, "active_count", lambda: 1)
    monkeypatch.setitem(sys.modules, "torch", sys.modules.get("torch") or builtins)
    assert start_method() == "spawn"  # torch imported
    monkeypatch.delitem(sys.modules, "torch")
    assert start_method() == "fork"
    monkeypatch.setattr(threading, "active_count", lambda: 2)
    assert start_method() == "spawn"  # a thread besides this one


def test_workers_keep_the_commands_warning_filters(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], workers_from_the_start: None
) -> None:
    # the tiny suite runs -v0 ids, whose deprecation the CLI silences: in its workers too
    assert main(["bench", "--suite", SUITE, "--workers", "2", "--quiet",
                 "--out", str(tmp_path / "b")]) == 0
    assert "out of date" not in capfd.readouterr().err


def test_a_units_error_is_raised_after_the_running_ones_finish(
    workers_from_the_start: None,
) -> None:
    with Processes(2) as where:
        got = []
        with pytest.raises(ZeroDivisionError):
            for i, value in where.map(_inverse, [1, 0, 2, 4]):
                got.append((i, value))
    assert (0, 1.0) in got


def _inverse(x: int) -> float:
    return 1.0 / x


@LINUX
def test_a_worker_ends_when_its_parent_is_killed() -> None:
    # an out-of-memory kill of a command's process left its worker waiting for ever
    code = ("import os, time\nfrom agents.parallel import Processes\nwhere = Processes(2)\n"
            "where.warm()\nprint(where._executor().submit(os.getpid).result(), flush=True)\n"
            "time.sleep(120)\n")
    parent = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert parent.stdout is not None
        worker = int(parent.stdout.readline())
        assert _alive(worker)
    finally:
        parent.kill()
        parent.wait()
    deadline = time.monotonic() + 20
    while _alive(worker) and time.monotonic() < deadline:
        time.sleep(0.1)
    ended = not _alive(worker)
    if not ended:  # leave no orphan behind a failure
        os.kill(worker, 9)
    assert ended


def _alive(pid: int) -> bool:
    # running, not a zombie nobody reaps (a container's first process may not)
    try:
        with open(f"/proc/{pid}/status") as fh:
            return not any(line.startswith("State:\tZ") for line in fh)
    except FileNotFoundError:
        return False


def test_units_done_before_the_workers_start_do_not_wait_for_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "slow_start.py").write_text("import time\ntime.sleep(60)\n")
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))  # the spawned worker imports it
    start = time.perf_counter()
    with Processes(2) as where:
        where.warm("slow_start")
        got = dict(where.map(_pid_of, [1, 2, 3]))
    assert set(got.values()) == {os.getpid()}  # every unit here
    assert time.perf_counter() - start < 30  # the worker was stopped, not waited for


def _pid_of(_: int) -> int:
    return os.getpid()


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS runs one thread on one core")
def test_each_process_runs_its_units_on_one_blas_thread(
    workers_from_the_start: None, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a spawned worker loads numpy's OpenBLAS before its initializer sets the variables: its
    # threads are set at run time; this process's for the run only. Both start with two
    # threads here whatever the environment says, so that the test can fail
    from threadpoolctl import threadpool_limits

    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        monkeypatch.setenv(name, "2")  # what the spawned worker's OpenBLAS starts with
    with threadpool_limits(2, user_api="blas"):
        before = _blas_threads(0)[1]
        assert set(before) == {2}
        with Processes(2) as where:
            got = dict(where.map(_blas_threads, range(6)))
        assert _blas_threads(0)[1] == before
    assert {threads for _, threads in got.values()} == {(1,) * len(before)}
    assert len({pid for pid, _ in got.values()}) == 2  # this process and the worker


def _blas_threads(_: int) -> tuple[int, tuple[int, ...]]:
    from threadpoolctl import threadpool_info

    time.sleep(0.2)  # long enough for both processes to take units
    return os.getpid(), tuple(p["num_threads"] for p in threadpool_info()
                              if p["user_api"] == "blas")


def test_torch_imported_inside_a_unit_runs_on_one_thread_until_the_section_ends() -> None:
    # a saved agent imports torch when it first acts, inside a unit: one thread there, torch's
    # own count after; in a fresh interpreter (here torch is imported already), where torch
    # starts on two threads whatever the machine, so that the test can fail
    code = ("import os, sys; os.environ.update(OMP_NUM_THREADS='2', MKL_NUM_THREADS='2')\n"
            "from agents.parallel import _one_thread, limit_new_torch\n"
            "assert 'torch' not in sys.modules\n"
            "undo = _one_thread(); import torch; own = torch.get_num_threads()\n"
            "limit_new_torch(); inside = torch.get_num_threads(); undo()\n"
            "print(own, inside, torch.get_num_threads())")
    own, inside, after = map(int, fresh_python(code).split())
    assert own == 2 and inside == 1 and after == own


@pytest.mark.slow
def test_seeds_train_in_parallel_with_the_weights_of_one_at_a_time(
    parallel_runs: list[Path], tmp_path: Path
) -> None:
    alone = run_trials(trials(ENV, ["ppo"], [1], {}, tmp_path / "one", STEPS), workers=1)
    assert [r.name for r in parallel_runs] == ["CCC-Circle-v0_ppo_seed0", "CCC-Circle-v0_ppo_seed1"]
    assert weights(parallel_runs[1]) == weights(alone[0])
    assert weights(parallel_runs[0]) != weights(parallel_runs[1])
    again = run_trials(trials(ENV, ["ppo"], [0, 1], {}, parallel_runs[0].parent, STEPS),
                       workers=2)  # finished runs are not trained again
    assert [weights(r) for r in again] == [weights(r) for r in parallel_runs]


@LINUX
def test_seeds_train_on_forked_workers_with_the_weights_of_spawned_ones(
    parallel_runs: list[Path], tmp_path: Path
) -> None:
    # the fixture's workers were spawned (pytest runs threads); a fresh interpreter forks
    code = ("from agents.parallel import start_method\n"
            "from agents.rl.sweep import run_trials, trials\n"
            "assert start_method() == 'fork', start_method()\n"
            f"run_trials(trials({ENV!r}, ['ppo'], [0, 1], {{}}, {str(tmp_path)!r}, {STEPS}),"
            " workers=2)\n")
    fresh_python(code)
    forked = sorted(tmp_path.glob("*/model.zip"))
    assert [f.parent.name for f in forked] == [r.name for r in parallel_runs]
    assert [weights(f.parent) for f in forked] == [weights(r) for r in parallel_runs]


def test_a_sweep_grid_names_its_folders_by_value(tmp_path: Path) -> None:
    grid = parse_grid(["learning_rate=1e-4,3e-4", "n_epochs=2"])
    assert grid == {"learning_rate": [1e-4, 3e-4], "n_epochs": [2]}
    todo = trials("contour_gym/CCC-Circle-v0", ["ppo", "sac"], [0], grid, tmp_path)
    assert len(todo) == 4
    assert todo[1].run == tmp_path / "learning_rate=0.0003,n_epochs=2" / "CCC-Circle-v0_ppo_seed0"
    for bad in (["learning_rate"], ["=1"], ["a=1", "a=2"]):
        with pytest.raises(ValueError):
            parse_grid(bad)


def test_the_train_command_reads_seeds_algorithms_and_sweeps(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from agents.cli import _parser

    args = _parser().parse_args(["train", ENV, "--seeds", "0,1", "--algo", "ppo,sac",
                                 "--sweep", "learning_rate=1e-4,3e-4", "--workers", "2"])
    assert (args.seeds, args.algo, args.sweep, args.workers) == (
        [0, 1], ["ppo", "sac"], ["learning_rate=1e-4,3e-4"], 2)
    for bad in (["--seeds", "0,x"], ["--algo", "ppo,nope"], ["--workers", "0"],
                ["--seed", "1", "--seeds", "2,3"]):
        with pytest.raises(SystemExit):
            _parser().parse_args(["train", ENV, *bad])
    assert "nope" in capsys.readouterr().err


def test_runner_picks_the_place() -> None:
    assert type(runner(1)) is Runner and isinstance(runner(2), Processes)
    with pytest.raises(ValueError, match="workers"):
        runner(0)


def test_without_ray_every_command_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    real_import = builtins.__import__

    def no_ray(name: str, *args: Any, **kwargs: Any) -> Any:
        if name == "ray" or name.startswith("ray."):
            raise ImportError("No module named 'ray'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ray)
    monkeypatch.delitem(sys.modules, "ray", raising=False)
    for argv in (["bench", "--suite", SUITE, "--ray", "auto", "--out", str(tmp_path / "b")],
                 ["tune", "003", "--ray", "auto", "--population", "4", "--iterations", "1",
                  "--out", str(tmp_path / "t")],
                 ["train", "contour_gym/CCC-Circle-v0", "--ray", "auto", "--out",
                  str(tmp_path / "r")]):
        assert main(argv) == 2
        assert RAY_HINT in capsys.readouterr().err


def test_a_stopped_tuning_run_resumes_from_its_evaluations(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from agents.tune.objective import PopulationObjective

    real = PopulationObjective._simulate
    calls: list[int] = []  # candidates simulated, per call
    stop_at = [0]

    def counting(self: PopulationObjective, x: np.ndarray) -> Any:
        if len(calls) + 1 == stop_at[0]:
            raise KeyboardInterrupt  # a Ctrl-C in that call
        calls.append(len(x))
        return real(self, x)

    monkeypatch.setattr(PopulationObjective, "_simulate", counting)
    budget: dict[str, Any] = dict(population=6, iterations=3, progress=False, workers=1)
    whole = tune("003", out=tmp_path / "whole", **budget)
    total, calls[:] = sum(calls), []
    stop_at[0] = 3
    with pytest.raises(KeyboardInterrupt):
        tune("003", out=tmp_path / "cut", **budget)
    assert (tmp_path / "cut" / "evaluations.npz").is_file()
    first, calls[:], stop_at[0] = sum(calls), [], 0
    resumed = tune("003", out=tmp_path / "cut", **budget)
    assert resumed.params == whole.params and resumed.history == whole.history
    assert sum(calls) == total - first  # what the stopped run evaluated was read back
    calls[:] = []
    tune("003", out=tmp_path / "cut", overwrite=True, **budget)
    assert sum(calls) == total  # --overwrite replays nothing


# ------------------------------------------------------------------------------- Ray
needs_ray = pytest.mark.skipif(importlib.util.find_spec("ray") is None,
                               reason='the ray extra is not installed: pip install ".[ray]"')


@pytest.mark.slow
@needs_ray
def test_bench_tune_and_training_on_a_two_node_cluster_equal_a_local_run(
    local_bench: dict[str, Any], parallel_runs: list[Path], tmp_path: Path
) -> None:
    from agents.parallel import local_cluster

    protocol: dict[str, Any] = dict(protocol="003", population=6, iterations=1, progress=False)
    local_tune = tune(**protocol, workers=1)
    with local_cluster(nodes=2, cpus_per_node=1) as cluster:  # a head and a worker node
        assert cluster.address.startswith("127.0.0.1:")
        run_suite(SUITE, tmp_path / "ray", progress=False, ray=cluster.address)
        remote_tune = tune(**protocol, ray=cluster.address)
        remote_runs = run_trials(trials(ENV, ["ppo"], [0, 1], {}, tmp_path / "runs", STEPS),
                                 ray=cluster.address)
    assert episodes(tmp_path / "ray") == local_bench
    suite = load_suite(SUITE)  # each scenario's plots, drawn on the nodes and written here
    assert sorted(p.name for p in (tmp_path / "ray" / "plots").iterdir()) == sorted(
        name for sc in suite.scenarios for name in _plot_names(sc))
    assert remote_tune.params == local_tune.params
    assert remote_tune.history == local_tune.history
    assert [weights(r) for r in remote_runs] == [weights(r) for r in parallel_runs]
    assert all((r / "eval.csv").is_file() and (r / "args.yml").is_file() for r in remote_runs)


def _slow_cell(unit: Any) -> Any:
    time.sleep(1.5)  # long enough to be running when its node dies
    return run_cell(unit)


@pytest.mark.slow
@needs_ray
def test_a_node_that_dies_mid_run_loses_only_its_unfinished_units(
    local_bench: dict[str, Any],
) -> None:
    from ray import cloudpickle

    from agents.parallel import RayRunner, local_cluster

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import tests
    suite = load_suite(SUITE)
    units = [(suite, (sc.name, label), None) for sc in suite.scenarios for label in sc.policies]
    with local_cluster(nodes=2, cpus_per_node=1) as cluster:
        worker = next(iter(cluster.worker_nodes))
        results = {}
        with RayRunner(cluster.address) as where:
            for i, cell in where.map(_slow_cell, units):  # one unit on each node at a time
                results[i] = cell
                if worker is not None:  # the worker node is running its second unit
                    cluster.remove_node(worker, allow_graceful=False)
                    worker = None
    assert worker is None and sorted(results) == list(range(len(units)))
    got = {f"cells/{c.scenario}/{c.policy}.json": c.episodes for c in results.values()}
    assert got == local_bench
