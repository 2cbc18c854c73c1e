"""Tuning protocols (agents.tune) and ``contour-gym tune``: short budgets on 000's circle."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from agents.ccc_laws import FUZZY_PID_PARAMS
from agents.cli import main
from agents.optim import OPTIMIZERS
from agents.optim.pso import improved_coefficients, linear_coefficients, schedules
from agents.tune import (
    PENALTY_HARD_LIMITS,
    PROTOCOLS,
    PopulationObjective,
    combine,
    get_protocol,
    register_protocol,
    tune,
)
from agents.tune import objective as objective_module

CIRCLE = "000_circle"
UNSTABLE = [1e7, 1e5, 1e7, 1e9, 1e4]  # k_e, k_de, k_pf, k_if, k_df far beyond the box


@pytest.fixture(scope="module")
def circle() -> PopulationObjective:
    return PopulationObjective(CIRCLE)


def _random_search_points(n: int, seed: int) -> np.ndarray:
    b = get_protocol(CIRCLE).search_bounds
    return b[:, 0] + np.random.default_rng(seed).random((n, len(b))) * (b[:, 1] - b[:, 0])


def test_protocol_000_is_papers_budget_and_box() -> None:
    p = get_protocol("000")
    assert p.names == ("k_e", "k_de", "k_pf", "k_if", "k_df")
    assert (p.optimizer, p.population, p.iterations, p.fitness) == ("improved_pso", 50, 100, "cea")
    assert len(p.scenarios) == 3 and {"000_circle", "000_infinity", "000_trident"} <= set(PROTOCOLS)
    defaults = FUZZY_PID_PARAMS.defaults()
    for param in p.params:  # the law's defaults lie inside the box
        assert param.low <= defaults[param.name] <= param.high
    z = p.to_search(p.bounds.T)
    np.testing.assert_allclose(p.to_params(z), p.bounds.T)
    np.testing.assert_allclose(z, p.search_bounds.T)


def test_population_equals_single_member_evaluations(circle: PopulationObjective) -> None:
    z = _random_search_points(5, seed=1)
    together = circle(z)
    alone = np.array([circle(z[i : i + 1])[0] for i in range(len(z))])
    assert np.array_equal(together, alone)
    reversed_order = circle(z[::-1])[::-1]  # nor does the order of the others matter
    assert np.array_equal(together, reversed_order)
    assert np.all(np.isfinite(together)) and np.all(together < circle.penalty)


def test_the_defaults_give_the_reference_policy_mean_error(circle: PopulationObjective) -> None:
    # the objective's scenario is the env's: fuzzy_pid_ccc measured 1.45 um mean on the rig
    defaults = FUZZY_PID_PARAMS.defaults()
    x = [[defaults[n] for n in get_protocol(CIRCLE).names]]
    assert circle.fitness(x)[0] == pytest.approx(1.45e-6, abs=0.01e-6)


def test_an_unstable_candidate_gets_the_finite_penalty(circle: PopulationObjective) -> None:
    defaults = FUZZY_PID_PARAMS.defaults()
    x = np.array([UNSTABLE, [defaults[n] for n in get_protocol(CIRCLE).names]])
    per_case, failed = circle.evaluate(x)
    assert failed[:, 0].all() and not failed[:, 1].any()
    f = circle.fitness(x)
    assert f[0] == circle.penalty == pytest.approx(PENALTY_HARD_LIMITS * 100 * 7.59e-6, rel=1e-3)
    assert np.isfinite(f[0]) and f[1] < f[0] and np.isfinite(per_case).all()


def test_nan_and_failures_never_continue() -> None:
    per_case = np.array([[1e-6, np.nan, 2e-6, 1e-6], [1e-6, 1e-6, 1e-6, np.inf]])
    failed = np.array([[False, False, True, False], [False, False, False, False]])
    f = combine(per_case, failed, 5.0)
    assert f.tolist() == [1e-6, 5.0, 5.0, 5.0]


def test_a_tiny_run_writes_its_results(tmp_path) -> None:
    res = tune(CIRCLE, seed=3, population=6, iterations=4, out=tmp_path, progress=False)
    data = json.loads((tmp_path / "result.json").read_text())
    assert data["status"] == "complete" and data["seed"] == 3
    assert data["optimizer"] == "improved_pso" and data["protocol"] == CIRCLE
    assert list(data["params"]) == list(get_protocol(CIRCLE).names)
    history = np.array(data["history"])
    assert len(history) == 4 and np.all(np.diff(history) <= 0.0)
    assert data["fitness"] == history[-1] == res.fitness
    assert data["per_scenario"]["contour_gym/CCC-Circle-v0"] == res.fitness
    assert len(data["settings"]["schedules"]) == 4 and data["nfev"] == 30
    assert data["wall_time_s"] > 0 and data["settings"]["command"].startswith("contour-gym tune")
    for png in ("convergence.png", "schedules.png"):
        assert (tmp_path / png).read_bytes()[:4] == b"\x89PNG"
    again = tune(CIRCLE, seed=3, population=6, iterations=4, progress=False)
    assert again.params == res.params and again.history == res.history


def test_an_interrupted_run_keeps_the_history_so_far(tmp_path, monkeypatch) -> None:
    calls = {"n": 0}
    original = PopulationObjective.__call__

    def interrupting(self, z):
        calls["n"] += 1
        if calls["n"] == 4:  # generation 0, then 1 and 2 done
            raise KeyboardInterrupt
        return original(self, z)

    monkeypatch.setattr(PopulationObjective, "__call__", interrupting)
    with pytest.raises(KeyboardInterrupt):
        tune(CIRCLE, seed=0, population=4, iterations=10, out=tmp_path, progress=False)
    data = json.loads((tmp_path / "result.json").read_text())
    assert data["status"] == "interrupted" and len(data["history"]) == 2
    assert data["nfev"] == 12 and data["fitness"] == data["history"][-1]
    assert set(data["params"]) == set(get_protocol(CIRCLE).names)


def test_the_memo_keeps_every_candidate_in_order_up_to_its_size(monkeypatch) -> None:
    memo = objective_module.Memo(d=2, s=3)
    rng = np.random.default_rng(0)
    x, fit, failed = rng.random((150, 2)), rng.random((150, 3)), rng.random((150, 3)) < 0.5
    monkeypatch.setattr(objective_module, "MEMO_SIZE", 140)
    for row, f, bad in zip(x, fit, failed, strict=True):  # past its first room (64 rows)
        memo.add(row.tobytes(), row, f, bad)
    memo.add(x[3].tobytes(), x[3], fit[0], failed[0])  # a known candidate keeps its results
    kept_x, kept_fit, kept_failed = memo.arrays()
    assert len(memo) == 140 and x[139].tobytes() in memo and x[140].tobytes() not in memo
    assert np.array_equal(kept_x, x[:140]) and np.array_equal(kept_fit, fit[:140])
    assert np.array_equal(kept_failed, failed[:140])
    got_fit, got_failed = memo[x[3].tobytes()]
    assert np.array_equal(got_fit, fit[3]) and np.array_equal(got_failed, failed[3])


@pytest.mark.parametrize("name", sorted(OPTIMIZERS))
def test_every_optimizer_runs_a_protocol(name: str) -> None:
    res = tune(CIRCLE, name, seed=0, population=6, iterations=2, progress=False)
    assert res.optimizer == name and res.nfev == 18 and len(res.history) == 2
    assert np.isfinite(res.fitness) and res.history[-1] == res.fitness
    assert ("schedules" in res.settings) == (name in ("pso", "improved_pso"))


def test_unknown_names_list_the_accepted_ones() -> None:
    with pytest.raises(ValueError, match="unknown tuning protocol 'nope'; accepted: 000, "):
        get_protocol("nope")
    with pytest.raises(ValueError, match="unknown optimizer 'nope'; accepted: .*improved_pso"):
        tune(CIRCLE, "nope", progress=False)
    with pytest.raises(ValueError, match="unknown option.* bogus for 'pso'; accepted: w_start"):
        tune(CIRCLE, "pso", options={"bogus": 1.0}, progress=False)


def test_start_points_are_the_protocols_not_an_option(tmp_path) -> None:
    with pytest.raises(ValueError, match="x0 is not a tuning option.*start_at_reference"):
        tune(CIRCLE, "pso", options={"x0": [0.5, 0.5]}, out=tmp_path / "run", progress=False)
    assert not (tmp_path / "run").exists()  # refused before anything is written
    with pytest.raises(ValueError, match="accepted: (?!.*x0).*keep_population$"):
        tune(CIRCLE, "pso", options={"bogus": 1.0}, progress=False)


def test_the_schedules_are_the_swarms() -> None:
    s = schedules("improved_pso", 100)
    assert s.shape == (100, 3)
    assert s[0].tolist() == list(improved_coefficients(0.0))
    assert s[-1].tolist() == list(improved_coefficients(1.0))
    assert schedules("pso", 5, c1=1.5, v_max=0.1)[2].tolist() == list(
        linear_coefficients(0.5, c1=1.5))
    with pytest.raises(ValueError, match="unknown PSO variant 'abc'"):
        schedules("abc", 5)


def test_the_cli_runs_a_tiny_budget(tmp_path, capsys) -> None:
    out = tmp_path / "run"
    argv = ["tune", CIRCLE, "--optimizer", "pso", "--population", "4", "--iterations", "2",
            "--seed", "1", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "k_if = " in text and f"results written to {out}" in text
    data = json.loads((out / "result.json").read_text())
    assert data["optimizer"] == "pso" and len(data["history"]) == 2 and data["seed"] == 1
    assert data["settings"]["command"] == (
        f"contour-gym tune {CIRCLE} --optimizer pso --seed 1 --population 4 --iterations 2 "
        f"--out {out}")


@pytest.mark.parametrize(("argv", "message"), [
    (["tune", "nope"], "unknown tuning protocol 'nope'; accepted: 000"),
    (["tune", CIRCLE, "--optimizer", "nope"], "unknown optimizer 'nope'; accepted: abc, cma"),
])
def test_the_cli_names_the_accepted_ones(argv, message, capsys) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_the_shipped_factors_are_protocol_000s_and_the_policy_uses_them() -> None:
    from agents.ccc_policies import TUNED_000, tuned_factors_000
    from agents.policies import make

    data = json.loads(TUNED_000.read_text())
    assert data["command"] == "contour-gym tune 000 --seed 0"
    assert (data["protocol"], data["optimizer"], data["seed"]) == ("000", "improved_pso", 0)
    assert len(data["history"]) == 100 and data["history"][-1] == data["fitness"]
    factors = tuned_factors_000()
    assert make("pso_fuzzy_pid_ccc_000").factors == factors  # type: ignore[attr-defined]
    p = get_protocol("000")
    for param in p.params:
        assert param.low <= factors[param.name] <= param.high
    # the objective still gives the shipped fitness (the code and the data agree)
    f = PopulationObjective("000").fitness([[factors[n] for n in p.names]])[0]
    assert f == pytest.approx(data["fitness"], rel=1e-12)


def test_the_general_factors_are_protocol_000_generals_and_the_policy_uses_them() -> None:
    from agents.ccc_policies import TUNED_GENERAL, tuned_factors_general
    from agents.policies import make

    data = json.loads(TUNED_GENERAL.read_text())
    assert data["command"] == "contour-gym tune 000_general --seed 0"
    assert (data["protocol"], data["optimizer"], data["seed"]) == ("000_general", "improved_pso", 0)
    factors = tuned_factors_general()
    assert make("pso_fuzzy_pid_ccc").factors == factors  # type: ignore[attr-defined]
    p = get_protocol("000_general")
    assert len(p.scenarios) == 28 and p.relative and p.worst_case and p.chatter_bound == 2.0
    f = PopulationObjective("000_general").fitness([[factors[n] for n in p.names]])[0]
    assert f == pytest.approx(data["fitness"], rel=1e-12)


def test_the_tuned_policies_carry_their_factors_from_the_machine_they_were_tuned_on() -> None:
    import gymnasium as gym

    from agents.ccc_policies import PSOFuzzyPIDCCC, PSOFuzzyPIDCCC000

    for protocol, policy in (("000", PSOFuzzyPIDCCC000), ("000_general", PSOFuzzyPIDCCC)):
        p = get_protocol(protocol)
        plants = set()
        for name in p.scenarios:
            given = dict(p.scenario_kwargs.get(name) or {})
            plants.add(given.get("plant", gym.spec(given.get("id", name)).kwargs.get("plant")))
        assert plants == {policy.tuned_on}, protocol


def test_a_protocol_started_at_the_reference_never_returns_worse(tmp_path, capsys) -> None:
    general = get_protocol("000_general")
    two = general.scenarios[:2]
    kwargs = {name: general.scenario_kwargs[name] for name in two}
    plain = replace(general, name="000_general_two", scenarios=two, scenario_kwargs=kwargs,
                    start_at_reference=False)
    ref = general.reference_point()
    reference = PopulationObjective(plain).fitness([plain.reference_row()])[0]
    lost = tune(plain, seed=0, population=4, iterations=1, progress=False)
    assert lost.fitness > reference  # a short random search loses to the untuned law here
    register_protocol(replace(plain, name="test_started", start_at_reference=True))
    try:
        assert main(["tune", "test_started", "--population", "4", "--iterations", "1",
                     "--out", str(tmp_path), "--quiet"]) == 0
    finally:
        PROTOCOLS.unregister("test_started")
    assert "(the start point, the untuned law: no candidate beat it)" in capsys.readouterr().out
    data = json.loads((tmp_path / "result.json").read_text())
    assert data["fitness"] == pytest.approx(reference, rel=1e-9) and data["fitness"] <= lost.fitness
    assert data["params"] == ref  # the untuned law, bit for bit
    assert data["settings"]["start_at_reference"]
