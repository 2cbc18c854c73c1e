"""Generalisation: G-code parts and per-path summaries in suites, the peak reward, tuning on
random paths, the random-path defaults of the CCC env and the generalization suite."""

from __future__ import annotations

import dataclasses
import math
import textwrap

import gymnasium as gym
import numpy as np
import pytest

import contour_gym  # noqa: F401  (registers the ids)
from agents.bench import Cell, run_suite
from agents.generalization import summary_rows
from agents.suites import load_suite
from agents.tune import PopulationObjective, Protocol, get_protocol
from contour_gym.paths import GcodePath
from contour_gym.presets import get_preset

SQUARE = """\
G21 G90 G17
G0 X0 Y0
G1 X10 F600
G1 Y10
G1 X0
G1 Y0
M30
"""


def _suite(tmp_path, text):
    path = tmp_path / "suite.yaml"
    path.write_text(textwrap.dedent(text))
    return path


def test_a_suite_runs_a_gcode_part_named_by_its_file(tmp_path):
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "square.nc").write_text(SQUARE)
    suite = load_suite(_suite(tmp_path, """\
        policies:
          no_ccc:
          pid_ccc:
        scenarios:
          000-square:
            env: CCC-v1
            gcode: parts/square.nc
            baseline: no_ccc
        """))
    part = suite.scenarios[0].kwargs["path"]
    assert isinstance(part, GcodePath) and part.name == "square"
    result = run_suite(suite, tmp_path / "run", progress=False)
    assert [r["policy"] for r in result.rows] == ["no_ccc", "pid_ccc"]
    assert all(r["failures"] == 0 and r["max_contour_error_um"] > 0 for r in result.rows)
    # the part's text is the suite's identity: an edited part is another suite
    (tmp_path / "parts" / "square.nc").write_text(SQUARE.replace("X10", "X12"))
    assert load_suite(tmp_path / "suite.yaml").digest != suite.digest


@pytest.mark.parametrize(("gcode", "text", "message"), [
    ("parts/none.nc", None, r"scenarios\.000-part\.gcode: .*none\.nc: No such file"),
    ("bad.nc", "G1 X1 F100\nG1 X2 Q7\n", r"scenarios\.000-part\.gcode: .*bad\.nc: line 2: "),
])
def test_a_bad_part_is_named_with_its_file_and_line(tmp_path, gcode, text, message):
    if text is not None:
        (tmp_path / gcode).write_text(text)
    with pytest.raises(ValueError, match=message):
        load_suite(_suite(tmp_path, f"""\
            policies:
              no_ccc:
            scenarios:
              000-part:
                env: CCC-v1
                gcode: {gcode}
                baseline: no_ccc
            """))


def test_a_part_and_a_path_together_are_refused(tmp_path):
    (tmp_path / "square.nc").write_text(SQUARE)
    with pytest.raises(ValueError, match=r"gcode: give either 'gcode' or 'path'"):
        load_suite(_suite(tmp_path, """\
            policies:
              no_ccc:
            scenarios:
              000-part:
                env: CCC-v1
                path: circle
                gcode: square.nc
                baseline: no_ccc
            """))


SUMMARY_SUITE = """\
    summary: paths
    policies:
      no_ccc:
      pid_ccc:
      slow: {policy: constant_feedrate, params: {override: 0.5}}
      fast: {policy: constant_feedrate, params: {override: 1.0}}
    scenarios:
      000-a:
        env: CCC-v1
        seeds: [1, 2]
        baseline: no_ccc
        policies: [no_ccc, pid_ccc]
      000-b:
        env: CCC-Circle-v1
        baseline: no_ccc
        policies: [no_ccc, pid_ccc]
      004f-a:
        env: Feedrate-v1
        seeds: [1, 2]
        baseline: fast
        policies: [slow, fast]
    """


def _cell(scenario, policy, rows):
    eps = [{"seed": s, "max_contour_error": ce * 1e-6, "cycle_time": t, "tolerance": 5e-6,
            "failed": False, "finished": True} for s, ce, t in rows]
    return Cell(scenario, policy, eps)


def test_the_path_summary_takes_every_scenario_and_seed_of_a_machine_as_a_path(tmp_path):
    suite = load_suite(_suite(tmp_path, SUMMARY_SUITE))
    cells = {(c.scenario, c.policy): c for c in (
        _cell("000-a", "no_ccc", [(1, 10.0, 1.0), (2, 20.0, 1.0)]),
        _cell("000-a", "pid_ccc", [(1, 4.0, 1.0), (2, 30.0, 1.0)]),
        _cell("000-b", "no_ccc", [(0, 8.0, 1.0)]),
        _cell("000-b", "pid_ccc", [(0, 2.0, 1.0)]),
        _cell("004f-a", "slow", [(1, 3.0, 4.0), (2, 4.0, 5.0)]),
        _cell("004f-a", "fast", [(1, 4.5, 2.0), (2, 9.0, 2.5)]),
    )}
    rows = {(r["group"], r["policy"]): r for r in summary_rows(suite, cells)}
    pid = rows[("000", "pid_ccc")]
    assert pid["paths"] == 3
    assert (pid["median_max_ce_um"], pid["worst_max_ce_um"]) == pytest.approx((4.0, 30.0))
    assert pid["worse_than_baseline"] == 1 and rows[("000", "no_ccc")]["worse_than_baseline"] == 0
    assert pid["within_tolerance"] == 2  # 4 and 2 um against 5 um
    # the per-path oracle: the fastest constant override within the tolerance on each path
    best = rows[("004f", "best constant_feedrate")]
    assert best["paths"] == 2 and best["within_tolerance"] == 2
    assert best["median_cycle_time_s"] == pytest.approx(np.median([2.0, 5.0]))


def test_a_failed_episode_counts_worse_than_a_baseline_that_finished(tmp_path):
    # the PID CCC fails path 2 (not in position after the end) at a peak below no CCC's:
    # worse all the same; where both fail, the peaks decide
    suite = load_suite(_suite(tmp_path, SUMMARY_SUITE))
    cells = {(c.scenario, c.policy): c for c in (
        _cell("000-a", "no_ccc", [(1, 10.0, 1.0), (2, 20.0, 1.0)]),
        _cell("000-a", "pid_ccc", [(1, 4.0, 1.0), (2, 3.0, math.inf)]),
        _cell("000-b", "no_ccc", [(0, 8.0, math.inf)]),
        _cell("000-b", "pid_ccc", [(0, 9.0, math.inf)]),
    )}
    cells[("000-a", "pid_ccc")].episodes[1].update(failed=True, finished=False)
    for cell in (cells[("000-b", "no_ccc")], cells[("000-b", "pid_ccc")]):
        cell.episodes[0].update(failed=True, finished=False)
    rows = {(r["group"], r["policy"]): r for r in summary_rows(suite, cells)}
    assert rows[("000", "pid_ccc")]["worse_than_baseline"] == 2  # path 2's failure, 000-b's peak
    assert rows[("000", "pid_ccc")]["within_tolerance"] == 1
    assert (rows[("000", "pid_ccc")]["failed"], rows[("000", "no_ccc")]["failed"]) == (2, 1)


def test_the_record_component_sums_to_the_episodes_max_contour_error():
    env = gym.make("contour_gym/CCC-v1", path="random", reward_weights={"record": 30.0})
    env.reset(seed=3)
    total, done = 0.0, False
    while not done:
        _, _, te, tr, info = env.step(np.zeros(env.action_space.shape))
        total += info["reward_components"]["record"]
        done = te or tr
    tol = get_preset("xy_dc_servo").tolerance
    assert total * tol == pytest.approx(info["metrics"]["max_contour_error"], rel=1e-9)


def test_random_paths_run_under_look_ahead_at_the_machines_part_acceleration():
    env = gym.make("contour_gym/CCC-v1", path="random")
    scenario = env.unwrapped.task.scenario
    preset = get_preset("xy_dc_servo")
    assert math.isinf(preset.accel) and scenario.preset.accel == preset.part_accel == 0.2
    assert scenario.options["path_control"] == "G64"
    assert scenario.options["path_tolerance"] == pytest.approx(0.5 * preset.tolerance)
    # what the env is given wins; a library path keeps the paper's time-parameterised reference
    given = gym.make("contour_gym/CCC-v1", path="random", path_control="G61").unwrapped
    assert given.task.scenario.options["path_control"] == "G61"
    circle = gym.make("contour_gym/CCC-Circle-v1").unwrapped.task.scenario
    assert math.isinf(circle.preset.accel) and circle.options["path_control"] is None


def _protocol(**kw):
    base = get_protocol("000_general")
    names = base.scenarios[:2]
    kwargs = {n: base.scenario_kwargs[n] for n in names}
    return dataclasses.replace(base, name="t", scenarios=names, scenario_kwargs=kwargs, **kw)


def test_tuning_on_random_paths_draws_each_scenarios_path_from_its_seed():
    a, b = PopulationObjective(_protocol()), PopulationObjective(_protocol())
    assert [c.scenario.path.length for c in a.cases] == [c.scenario.path.length for c in b.cases]
    assert a.cases[0].scenario.path.length != a.cases[1].scenario.path.length
    x = np.array([[float(p.low * 2 if p.log else p.high / 2) for p in a.protocol.params]])
    assert np.array_equal(a.fitness(x), b.fitness(x))
    with pytest.raises(ValueError, match=r"give its int path_seed"):
        bad = {n: {k: v for k, v in kw.items() if k != "path_seed"}
               for n, kw in _protocol().scenario_kwargs.items()}
        PopulationObjective(dataclasses.replace(_protocol(), scenario_kwargs=bad))


def test_the_general_tuning_paths_are_four_of_each_family_and_the_suite_runs_them():
    from agents.tune.papers import GENERAL_FAMILY_SEEDS_000, GENERAL_SEEDS_000
    from contour_gym.paths import PATH_FAMILIES

    assert set(GENERAL_FAMILY_SEEDS_000) == set(PATH_FAMILIES)
    cases = PopulationObjective(get_protocol("000_general")).cases
    drawn = {c.name: c.scenario.path.name for c in cases}
    for family, seeds in GENERAL_FAMILY_SEEDS_000.items():
        assert len(seeds) == 4
        assert all(drawn[f"000-random-{s}"] == f"random_{family}" for s in seeds), family
    tuned = load_suite("generalization").scenario("000tuned-random")
    assert tuned.seeds == GENERAL_SEEDS_000  # the suite's seen group: these paths
    env = gym.make("contour_gym/CCC-v1", plant="xy_dc_servo", path="random")
    for case in cases[:3]:  # each seed's path is the one env.reset(seed=...) runs
        env.reset(seed=int(case.name.rsplit("-", 1)[1]))
        assert env.unwrapped.task.loop.paths[0] is case.scenario.path


def test_the_chattering_bound_fails_what_chatters_more_than_the_untuned_law():
    objective = PopulationObjective(_protocol(chatter_bound=1.0))
    names = objective.protocol.names
    ref = objective.protocol.reference or {}
    from contour_gym.ccc import CCC_LAWS

    point = {**CCC_LAWS.get("fuzzy_pid").params.defaults(), **ref}
    untuned = np.array([[float(point[n]) for n in names]])
    _, failed = objective.evaluate(untuned)
    assert not failed.any()  # exactly at its own chattering: within the bound
    hot = untuned.copy()
    hot[0, names.index("k_pf")] = objective.protocol.params[names.index("k_pf")].high
    hot[0, names.index("k_de")] = objective.protocol.params[names.index("k_de")].high
    plain = PopulationObjective(_protocol())
    per_case, plain_failed = plain.evaluate(hot)
    _, bounded_failed = objective.evaluate(hot)
    chatter = [m["chattering"][0] for m in plain.metrics(hot)]
    caps = [c.chatter_cap for c in objective.cases]
    assert list(bounded_failed[:, 0]) == [
        bool(f) or ch > cap for f, ch, cap in zip(plain_failed[:, 0], chatter, caps, strict=True)]
    with pytest.raises(ValueError, match="chatter_bound must be > 0"):
        Protocol("x", objective.protocol.params, ("contour_gym/CCC-Circle-v0",), chatter_bound=0.0)


def test_the_generalization_suite_runs_on_a_short_budget(tmp_path):
    suite = load_suite("generalization")
    names = {sc.name for sc in suite.scenarios}
    assert {"000-random", "002-random", "004-random", "004f-random"} <= names
    groups = {"000", "002", "004", "004f"}  # the unseen paths' groups
    unseen = [sc for sc in suite.scenarios if sc.name.split("-")[0] in groups]
    assert all(min(sc.seeds) >= 7000 for sc in unseen if sc.name.endswith("-random"))
    keep = {"000-random": ("no_ccc", "pid_ccc", "ppo_000_ccc_general"),
            "004f-random": ("constant_feedrate_0.5", "constant_feedrate_1.0",
                            "ppo_004_feedrate_general")}
    short = dataclasses.replace(suite, scenarios=tuple(
        dataclasses.replace(sc, seeds=sc.seeds[:1], policies=keep[sc.name])
        for sc in suite.scenarios if sc.name in keep))
    result = run_suite(short, tmp_path / "run", progress=False)
    assert len(result.rows) == 6 and all(r["seeds"] == 1 for r in result.rows)
    assert "## Per path, by machine" in result.markdown
    assert "| 004f | feedrate | best constant_feedrate | 1 |" in result.markdown


def test_the_seen_groups_are_the_paths_the_shipped_agents_trained_on():
    from agents.rl.config import load_config
    from agents.rl.train_shipped import load_shipped

    shipped = load_shipped()
    suite = load_suite("generalization")
    seen = [sc for sc in suite.scenarios if sc.name.split("-")[0].endswith("seen")]
    assert len(seen) == 4
    for sc in seen:
        agents = [label for label in sc.policies if label in shipped]
        assert agents, sc.name
        for label in agents:
            entry = shipped[label]
            first = entry.get("seed", 0)
            members = load_config(entry["algo"], entry["env_id"]).n_envs
            assert set(sc.seeds) <= set(range(first, first + members)), (sc.name, label)
            assert sc.kwargs.get("randomize") is entry["env_kwargs"].get("randomize"), sc.name
            assert sc.kwargs.get("estimator") == entry["env_kwargs"].get("estimator"), sc.name


def test_every_scenario_runs_a_shipped_agent_with_the_estimator_it_trained_with():
    from agents.rl.train_shipped import load_shipped

    shipped = load_shipped()
    suite = load_suite("generalization")
    checked = set()
    for sc in suite.scenarios:
        for label in sc.policies:  # an agent, or a wrapper of one (corner_guard, capped_feedrate)
            agent = label if label in shipped else suite.policies[label].params.get("agent")
            if agent not in shipped:
                continue
            assert sc.kwargs.get("estimator") == shipped[agent]["env_kwargs"].get("estimator"), (
                sc.name, label)
            checked.add(label)
    assert {"ppo_000_ccc_general", "ppo_000_ccc_general_guarded", "ppo_002_ccc_general",
            "ppo_004_ccc_general", "ppo_004_feedrate_general",
            "ppo_004_feedrate_general_capped"} <= checked
