"""The evaluation harness (agents.bench, agents.suites, ``contour-gym bench``), tiny suite."""

from __future__ import annotations

import csv
import io
import math
import shutil
import sys
import textwrap

import numpy as np
import pytest

from agents import bench
from agents.bench import COLUMNS, Progress, plan, run_suite
from agents.cli import main
from agents.evaluate import make_vector_env, run_episodes, run_policy_batch
from agents.policies import available, make
from agents.suites import load_suite
from contour_gym.envs.registration import SCENARIOS

TINY_CELLS = [("000-circle", "no_ccc"), ("000-circle", "pid_ccc"),
              ("004-corner", "constant_feedrate"), ("004-corner", "cnc_g64")]
METRICS = ("max_contour_error_um", "mean_contour_error_um", "rms_contour_error_um",
           "max_tracking_error_um", "cycle_time_s", "chattering")
SUITE = """\
policies:
  no_ccc:
  pid_ccc:
scenarios:
  000-circle:
    env: contour_gym/CCC-Circle-v0
    baseline: no_ccc
"""


def _rows(folder):
    with open(folder / "results.csv", newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    """The tiny suite run once from scratch (its folder and the call's result)."""
    out = tmp_path_factory.mktemp("bench") / "tiny"
    return out, run_suite("tiny", out, progress=False)


@pytest.fixture
def counted(monkeypatch):
    """Patch the harness's cell evaluation to record the cells it is called for."""
    calls = []
    real = bench.evaluate_cell

    def spy(scenario, spec, envs):
        calls.append((scenario.name, spec.label))
        return real(scenario, spec, envs)

    monkeypatch.setattr(bench, "evaluate_cell", spy)
    return calls


def test_the_tiny_suite_writes_its_tables_and_plots(tiny_run):
    out, result = tiny_run
    assert result.computed == TINY_CELLS
    rows = _rows(out)
    assert list(rows[0]) == [key for key, _ in COLUMNS]
    assert [(r["scenario"], r["policy"]) for r in rows] == TINY_CELLS
    for r in rows:
        assert all(math.isfinite(float(r[key])) and float(r[key]) > 0 for key in METRICS), r
        assert r["seeds"] == "1" and r["failures"] == "0"
    ccc, feed = rows[:2], rows[2:]
    assert [r["note"] for r in rows] == ["baseline", "", "baseline", ""]
    assert float(ccc[0]["max_contour_error_vs_baseline_pct"]) == 0.0
    # the PID CCC halves 000's no-CCC peak (46.1 -> 22.8 um, ccc_policies' table)
    assert float(ccc[1]["max_contour_error_vs_baseline_pct"]) == pytest.approx(
        100 * (float(ccc[1]["max_contour_error_um"]) / float(ccc[0]["max_contour_error_um"]) - 1))
    assert float(ccc[1]["max_contour_error_um"]) < 0.6 * float(ccc[0]["max_contour_error_um"])
    assert ccc[0]["cycle_time_vs_baseline_pct"] == ""  # a CCC scenario compares errors only
    assert float(feed[1]["cycle_time_vs_baseline_pct"]) < 0.0  # G64 blends through the corner
    md = (out / "results.md").read_text()
    assert md == result.markdown
    header, rule, *lines = md.splitlines()
    assert header.count("|") == len(COLUMNS) + 1 and rule == "|" + "---|" * len(COLUMNS)
    assert [ln.split(" | ")[:2] for ln in lines[:4]] == [[f"| {s}", p] for s, p in TINY_CELLS]
    plots = sorted(p.name for p in (out / "plots").iterdir())
    assert plots == ["000-circle_contour.png", "004-corner_contour.png", "004-corner_feedrate.png"]
    assert not list(out.rglob("*.tmp"))  # every write was renamed into place


def test_a_deleted_cell_is_the_only_one_recomputed(tiny_run, tmp_path, counted):
    out, _ = tiny_run
    copy = tmp_path / "run"
    shutil.copytree(out, copy)
    (copy / "cells" / "004-corner" / "constant_feedrate.json").unlink()
    result = run_suite("tiny", copy, progress=False)
    assert counted == [("004-corner", "constant_feedrate")] == result.computed
    assert _rows(copy) == _rows(out)  # same seed, same numbers


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_a_corrupt_cell_file_is_named_and_the_cell_recomputed(tiny_run, tmp_path, counted, suffix):
    out, _ = tiny_run
    copy = tmp_path / "run"
    shutil.copytree(out, copy)
    cells = sorted((copy / "cells").rglob(f"*{suffix}"))
    victim = cells[0]
    victim.write_bytes(victim.read_bytes()[: len(victim.read_bytes()) // 2])  # truncated
    with pytest.warns(UserWarning, match=f"{victim.name} cannot be read"):
        result = run_suite("tiny", copy, progress=False)
    assert counted == [(victim.parent.name, victim.stem)] == result.computed
    assert _rows(copy) == _rows(out)


def test_an_interrupted_run_resumes_without_recomputing_finished_cells(
    tiny_run, tmp_path, monkeypatch, counted
):
    real = bench.evaluate_cell  # the spy

    def dies_after_the_first(scenario, spec, envs):
        if counted:
            raise KeyboardInterrupt
        return real(scenario, spec, envs)

    monkeypatch.setattr(bench, "evaluate_cell", dies_after_the_first)
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        run_suite("tiny", out, progress=False)
    assert counted == TINY_CELLS[:1]
    assert not (out / "results.csv").exists()
    monkeypatch.setattr(bench, "evaluate_cell", real)
    result = run_suite("tiny", out, progress=False)
    assert counted == TINY_CELLS and result.computed == TINY_CELLS[1:]
    assert _rows(out) == _rows(tiny_run[0])


def test_a_folder_of_another_suite_is_refused_before_any_work(tiny_run, tmp_path, counted):
    other = tmp_path / "other.yaml"
    other.write_text(SUITE)
    with pytest.raises(ValueError, match=r"holds a run of suite 'tiny' .* pass another --out"):
        run_suite(other, tiny_run[0], progress=False)
    assert counted == []


def test_a_folder_computed_by_other_code_is_refused_before_any_work(
    tiny_run, tmp_path, monkeypatch, counted
):
    copy = tmp_path / "run"
    shutil.copytree(tiny_run[0], copy)
    monkeypatch.setattr(bench, "code_digest", lambda: "f" * 64)  # an upgrade, a changed policy
    with pytest.raises(ValueError, match=r"holds a run computed by other contour-gym code "
                                         r"\(code digest \w{12}, this code's f{12}\)"):
        run_suite("tiny", copy, progress=False)
    assert counted == []


def test_the_default_folder_is_named_by_the_suite_and_the_code(monkeypatch):
    suite = bench.load_suite("tiny")
    here = bench.default_out(suite)
    monkeypatch.setattr(bench, "code_digest", lambda: "f" * 64)
    assert bench.default_out(suite) != here
    assert bench.default_out(suite).parent == here.parent
    assert here.name.startswith(f"{suite.name}-")


def _bad(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(textwrap.dedent(text))
    return path


@pytest.mark.parametrize(("text", "message"), [
    (SUITE.replace("CCC-Circle-v0", "CCC-Nope-v0"),
     r"scenarios\.000-circle\.env: unknown env 'contour_gym/CCC-Nope-v0'; accepted: .*"
     r"contour_gym/CCC-Circle-v0"),
    (SUITE.replace("  pid_ccc:", "  pid_cc:"),
     r"policies\.pid_cc: unknown policy 'pid_cc'; accepted: " + ", ".join(available())),
    (SUITE + "    policies: [no_ccc, pid_ccc, fuzzy]\n",
     r"scenarios\.000-circle\.policies\[2\]: unknown policy 'fuzzy'; the suite's policies: "
     r"no_ccc, pid_ccc"),
    (SUITE.replace("  pid_ccc:\n", "  pid_ccc:\n  feed: {policy: constant_feedrate}\n")
     + "    policies: [no_ccc, feed]\n",
     r"scenarios\.000-circle\.policies\[1\]: policy 'feed' acts in feedrate envs, the "
     r"scenario is ccc"),
    (SUITE + "    seed: 3\n",
     r"scenarios\.000-circle: unknown key 'seed'; accepted: env, task"),
    ("colour: red\n" + SUITE, r"top level: unknown key 'colour'; accepted: description"),
    (SUITE.replace("  pid_ccc:", "  pid_ccc: {parms: {}}"),
     r"policies\.pid_ccc: unknown key 'parms'; accepted: policy, params"),
    (SUITE.replace("  pid_ccc:", "  pid_ccc: {policy: fuzzy_pid_ccc, params: {k_x: 1}}"),
     r"policies\.pid_ccc: unknown parameter\(s\) \['k_x'\] of policy 'fuzzy_pid_ccc'"),
    (SUITE + "    env_kwargs: {decision_tick: 5}\n",
     r"scenarios\.000-circle\.env_kwargs: unknown argument\(s\) \['decision_tick'\]"),
    (SUITE + "    seeds: three\n",
     r"scenarios\.000-circle\.seeds: expected an int >= 1 \(a count\) or a list of distinct "
     r"ints >= 0, got 'three' \(str\)"),
    (SUITE + "    ideal: 'yes'\n",
     r"scenarios\.000-circle\.ideal: expected true or false, got 'yes' \(str\)"),
    (SUITE + "    magnify: [2]\n",
     r"scenarios\.000-circle\.magnify: expected a number > 0, got \[2\] \(list\)"),
    (SUITE.replace("    baseline: no_ccc\n", ""),
     r"scenarios\.000-circle: missing key 'baseline'"),
    (SUITE.replace("    baseline: no_ccc", "    baseline: 7"),
     r"scenarios\.000-circle\.baseline: expected a policy label, got 7 \(int\)"),
    (SUITE + "    env_kwargs: {decision_ticks: ten}\n",
     r"scenarios\.000-circle\.env_kwargs: decision_ticks must be a positive int, got 'ten'"),
    (SUITE + "    plant: {preset: xy_dc_servo, stage: {mas: 1}}\n",
     r"scenarios\.000-circle\.plant: unknown field\(s\) \['mas'\] of plant\.stage"),
])
def test_bad_input_is_refused_naming_file_and_key_before_any_work(
    tmp_path, counted, text, message
):
    path = _bad(tmp_path, text)
    with pytest.raises(ValueError, match=f"^{path}: {message}"):
        run_suite(path, tmp_path / "run", progress=False)
    assert counted == [] and not (tmp_path / "run").exists()


def test_an_unknown_suite_name_lists_the_shipped_ones(counted):
    with pytest.raises(ValueError, match=r"unknown suite 'tinny'; shipped: default, "
                                         r"generalization, tiny"):
        run_suite("tinny", progress=False)
    assert counted == []


def test_the_default_suite_covers_every_paper_scenario_and_reference_policy():
    # ... and the generalization suite every general agent (on paths they never saw)
    suite, general = load_suite("default"), load_suite("generalization")
    papers = {f"contour_gym/{k}" for k in SCENARIOS} - {
        "contour_gym/CCC-v0", "contour_gym/Feedrate-v0"}  # the generic ids
    assert {sc.env_id for sc in suite.scenarios} == papers
    ran = {s.policies[label].target for s in (suite, general) for sc in s.scenarios
           for label in sc.policies}
    assert ran == set(available())
    assert {label for label in available() if label.endswith("_general")} <= {
        general.policies[label].target for sc in general.scenarios for label in sc.policies}
    assert all(note == "" for note in plan(suite).values())  # no cell is skipped
    assert all(note == "" for note in plan(general).values())


def test_a_policy_needing_what_the_scenario_sets_otherwise_is_skipped_with_a_note(tmp_path):
    path = _bad(tmp_path, """\
        policies:
          constant_feedrate:
          cnc_lookahead:
        scenarios:
          corner:
            env: Feedrate-Corner-v0
            env_kwargs: {path_control: G61}
            baseline: constant_feedrate
        """)
    notes = plan(load_suite(path))
    assert notes[("corner", "constant_feedrate")] == ""
    assert notes[("corner", "cnc_lookahead")].startswith(
        "skipped: env argument path_control='G61' conflicts with path_control='G64' from "
        "policy 'cnc_lookahead'")


CONTROLLER = '''\
import numpy as np


class NoGains:
    """A user's controller: every CCC gain 0 (the action -1), like no_ccc."""

    tasks = ("ccc",)

    def __init__(self, level=-1.0):
        self.level = level

    def predict(self, obs, state=None, episode_start=None, deterministic=False):
        assert deterministic
        return np.full(np.shape(obs["gains"]), self.level), state
'''


def test_your_own_controller_is_scored_by_module_and_class(tmp_path, counted):
    (tmp_path / "bench_user_controllers.py").write_text(CONTROLLER)
    path = _bad(tmp_path, """\
        policies:
          no_ccc:
          mine: {policy: "bench_user_controllers:NoGains", params: {level: -1.0}}
        scenarios:
          000-circle:
            env: CCC-Circle-v0
            baseline: no_ccc
        """)
    try:
        run_suite(path, tmp_path / "run", progress=False)
    finally:
        sys.modules.pop("bench_user_controllers", None)
    no_ccc, mine = _rows(tmp_path / "run")
    assert mine["policy"] == "mine"
    assert counted == [("000-circle", "no_ccc"), ("000-circle", "mine")]
    assert {k: v for k, v in mine.items() if k not in ("policy", "note")} == {
        k: v for k, v in no_ccc.items() if k not in ("policy", "note")}


def test_a_missing_controller_class_is_refused(tmp_path):
    (tmp_path / "bench_user_empty.py").write_text("x = 1\n")
    mine = "  pid_ccc: {policy: 'bench_user_empty:Nope'}"
    path = _bad(tmp_path, SUITE.replace("  pid_ccc:", mine))
    try:
        with pytest.raises(ValueError, match=r"policies\.pid_ccc: module 'bench_user_empty' has "
                                             r"no class 'Nope'"):
            load_suite(path)
    finally:
        sys.modules.pop("bench_user_empty", None)


def test_policies_sharing_an_env_get_their_own_envs_results():
    env_id = "contour_gym/CCC-Circle-v0"
    venv = make_vector_env(env_id, make("no_ccc"), num_envs=2, record=True)
    try:
        for name in ("pid_ccc", "no_ccc"):
            out, trace = run_episodes(venv, make(name), seed=3, trace_member=1)
            alone = run_policy_batch(env_id, make(name), num_envs=2, seed=3)
            assert all(np.array_equal(out[k], alone[k]) for k in alone), name
            live = np.isfinite(trace.eps[0, :, 0])
            assert live.sum() == round(out["cycle_time"][1] / 1e-3) and trace.t[0] == 0.0
            assert np.abs(trace.eps[0, live]).max() == out["max_contour_error"][1]
    finally:
        venv.close()


def test_the_progress_line_without_tqdm_names_the_cell(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)  # not importable
    bar = Progress(total=3, done=1)
    bar.start("000-circle / pid_ccc")
    bar.advance()
    bar.close()
    assert capsys.readouterr().err.startswith("\r[1/3] 000-circle / pid_ccc\x1b[K\r[2/3] done")


def test_the_cli_bench_runs_the_tiny_suite(tmp_path, capsys):
    assert main(["bench", "--suite", "tiny", "--out", str(tmp_path / "tmp"), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("| scenario | policy | seeds | max CE (um) |")
    assert "4 cell(s) computed in " in out and str(tmp_path / "tmp") in out
    table = list(csv.reader(io.StringIO((tmp_path / "tmp" / "results.csv").read_text())))
    assert [row[:2] for row in table[1:]] == [list(cell) for cell in TINY_CELLS]


def test_the_cli_reports_a_bad_suite_without_a_traceback(tmp_path, capsys):
    assert main(["bench", "--suite", "nope", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("contour-gym: error: unknown suite 'nope'; shipped: ")
    assert "Traceback" not in err


def test_a_suite_takes_v1_ids_and_random_paths(tmp_path):
    path = _bad(tmp_path, """\
        policies:
          no_ccc:
          pid_ccc:
        scenarios:
          circle-v1:
            env: CCC-Circle-v1
            baseline: no_ccc
          random-paths:
            task: ccc
            plant: xy_dc_servo
            path: random
            env_kwargs: {path_options: {family: spline}}
            seeds: [5000, 5001]
            baseline: no_ccc
        """)
    suite = load_suite(path)
    circle, randoms = suite.scenarios
    assert circle.env_id == "contour_gym/CCC-Circle-v1"
    assert randoms.kwargs["path"] == "random" and tuple(randoms.seeds) == (5000, 5001)
    assert set(plan(suite).values()) == {""}
    with pytest.raises(ValueError, match=r"unknown path 'randomly'; accepted: 'random'"):
        load_suite(_bad(tmp_path, SUITE.replace("env: contour_gym/CCC-Circle-v0",
                                                "task: ccc\n    path: randomly")))


def test_a_pooled_env_keeps_no_record_after_a_cell(tmp_path):
    # policies sharing a scenario's env (the pool) ran one after another on its record, which
    # grew with members x ticks and stayed: a 256-seed suite of agents filled 24 GiB. The cell
    # keeps member 0's trace (a copy), the env none; traces are as a fresh env's, bit for bit
    suite = load_suite(_bad(tmp_path, SUITE.replace("baseline: no_ccc",
                                                    "baseline: no_ccc\n    seeds: [3, 4]")))
    scenario = suite.scenarios[0]
    pool, fresh = bench.EnvPool(), []
    cells = [bench.evaluate_cell(scenario, suite.policies[label], pool)
             for label in ("no_ccc", "pid_ccc", "no_ccc")]
    env = pool.any_env()
    assert env.unwrapped.task.loop.trace().x.shape[1] == 0
    for label in ("no_ccc", "pid_ccc"):
        fresh.append(bench.evaluate_cell(scenario, suite.policies[label], bench.EnvPool()))
    for got, want in zip(cells, [*fresh, fresh[0]], strict=True):
        assert got.trace.x.shape[0] == 1 and got.trace.x.base is None
        for name in ("t", "x", "eps", "u"):
            assert np.array_equal(getattr(got.trace, name), getattr(want.trace, name),
                                  equal_nan=True), name
        assert got.episodes == want.episodes
    pool.close()


def test_an_agent_s_row_does_not_depend_on_the_cpu_s_instruction_set(tmp_path):
    # an agent's float32 network under MKL: ppo_feedrate_corner on 004's corner gave 6.35 um
    # with AVX-512 kernels and 5.63 um with MKL held to AVX2 before importing `agents` asked
    # for MKL's reproducible mode (agents/__init__.py); a second CPU is emulated by holding
    # MKL to AVX2 (on a CPU without AVX-512 the two runs are alike either way)
    import os
    import subprocess
    import sys

    suite = tmp_path / "agent.yaml"
    suite.write_text("seeds: 1\npolicies:\n  ppo_feedrate_corner:\n  constant_feedrate:\n"
                     "scenarios:\n  004-corner:\n    env: contour_gym/Feedrate-Corner-v0\n"
                     "    baseline: constant_feedrate\n")
    tables = []
    for isa in (None, "AVX2"):
        env = {k: v for k, v in os.environ.items() if not k.startswith("MKL_")}
        env.update({"MKL_ENABLE_INSTRUCTIONS": isa} if isa else {})
        out = tmp_path / f"run-{isa}"
        done = subprocess.run([sys.executable, "-m", "agents.cli", "bench", "--suite", str(suite),
                               "--out", str(out), "--workers", "1", "--quiet"],
                              env=env, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        tables.append((out / "results.csv").read_text())
    assert "ppo_feedrate_corner" in tables[0] and tables[0] == tables[1]


@pytest.mark.parametrize(("first", "mode"), [("agents", "AVX2,STRICT"), ("torch", "")])
def test_importing_agents_sets_mkl_s_mode_unless_torch_is_loaded(first, mode):
    # MKL reads its mode once, when torch loads: after torch, `agents` leaves MKL's default
    # and says so to the worker processes (they inherit the variable and compute alike)
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "MKL_CBWR"}
    code = f"import {first}, agents, os; print(repr(os.environ['MKL_CBWR']))"
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                          timeout=300, check=True)
    assert done.stdout.strip() == repr(mode)
