"""Tuning protocol 003 (paper 003's ACC2PID on the X-Y-Y gantry) and its policies: short budgets."""

from __future__ import annotations

import numpy as np
import pytest

from agents.ccc_policies import hand_tuned_003, tuned_params_003
from agents.evaluate import run_policy, run_policy_batch
from agents.policies import make_policy
from agents.tune import (
    ACC2PID_NAMES,
    PopulationObjective,
    acc2pid_rows,
    get_protocol,
    tune,
)
from contour_gym.loop import ServoLoop

CIRCLE_003 = "003_circle"
GANTRY = ("contour_gym/CCC-XYYGantry-Circle-v0", "contour_gym/CCC-XYYGantry-ThreeLeaf-v0")


@pytest.fixture(scope="module")
def circle() -> PopulationObjective:
    return PopulationObjective(CIRCLE_003)


def _hand() -> np.ndarray:
    return np.array([hand_tuned_003()[n] for n in ACC2PID_NAMES])


def test_protocol_003_is_papers_budget_and_box() -> None:
    p = get_protocol("003")
    assert p.names == ACC2PID_NAMES and len(p.names) == 19
    assert (p.optimizer, p.population, p.iterations, p.fitness) == ("improved_abc", 40, 200, "eq38")
    assert p.scenarios == GANTRY and p.setter == "acc2pid"
    hand = _hand()
    assert np.all((p.bounds[:, 0] <= hand) & (hand <= p.bounds[:, 1]))
    # the printed bounds in the preset's reading: Kp_x per 50 um count, K_c per mm
    np.testing.assert_allclose(p.bounds[0], [0.001 / 50e-6, 0.61 / 50e-6])
    np.testing.assert_allclose(p.bounds[15], [10.0, 310.0])


def test_acc2pid_rows_layout() -> None:
    rows, weights = acc2pid_rows(_hand()[None])
    assert rows.shape[:2] == (1, 3) and weights.shape == (1, 2, 3)
    np.testing.assert_allclose(weights[0], [[89.5, 1.0, 0.0], [48.8, 1.0, 0.0]])
    with pytest.raises(ValueError, match=r"shape \(n, 19\)"):
        acc2pid_rows(np.ones((2, 18)))


def test_set_ccc_weights_validates() -> None:
    loop = PopulationObjective(CIRCLE_003)._loops_for(2)[0]
    assert isinstance(loop, ServoLoop)
    loop.set_ccc_weights(np.arange(12.0).reshape(2, 2, 3))
    assert loop.ccc_w[1, 1, 2] == 11.0
    with pytest.raises(ValueError, match="do not broadcast"):
        loop.set_ccc_weights(np.ones((3, 2, 3)))
    with pytest.raises(ValueError, match="ccc_weights"):
        loop.set_ccc_weights([np.nan, 1.0, 1.0])


def test_population_equals_single_member_runs(circle: PopulationObjective) -> None:
    b = get_protocol(CIRCLE_003).search_bounds
    z = b[:, 0] + np.random.default_rng(3).random((4, len(b))) * (b[:, 1] - b[:, 0])
    z = np.vstack([z, get_protocol(CIRCLE_003).to_search(_hand()[None])])
    together = circle(z)
    alone = np.array([circle(z[i : i + 1])[0] for i in range(len(z))])
    assert np.array_equal(together, alone)
    assert np.array_equal(together, circle(z[::-1])[::-1])
    assert np.all(np.isfinite(together)) and np.all(together <= circle.penalty)


def test_hand_tuned_point_is_finite_and_equals_the_env_run(circle: PopulationObjective) -> None:
    f = circle.fitness(_hand()[None])
    assert np.isfinite(f[0]) and f[0] < circle.penalty
    m = circle.metrics(_hand()[None])[0]
    # eq. 38: three RMS tracking errors plus two RMS contour errors
    expected = m["rms_tracking_error"].sum(1) + m["rms_contour_error_per_contour"].sum(1)
    np.testing.assert_allclose(f, expected)
    # the hand-tuned ACC2PID is the preset's own setting: the env's pid_ccc, one lap
    env = run_policy(GANTRY[0], make_policy("acc2pid"), laps=1)
    np.testing.assert_allclose(env["p_eps"], m["p_eps"][0])


def test_unstable_candidate_gets_the_penalty(circle: PopulationObjective) -> None:
    x = _hand()
    x[10] = 0.016 / 10e-6  # Kp_y2 at the top of the box: y2 unstable
    assert circle.fitness(x[None])[0] == circle.penalty


def test_short_tune_runs(tmp_path: object) -> None:
    res = tune(CIRCLE_003, population=8, iterations=1, progress=False)
    assert set(res.params) == set(ACC2PID_NAMES) and len(res.history) == 1
    assert res.nfev == 16 and np.isfinite(res.fitness)


@pytest.mark.parametrize("env_id", GANTRY)
@pytest.mark.parametrize("name", ["acc2pid", "iabc_acc2pid"])
def test_policies_run_to_the_end(env_id: str, name: str) -> None:
    m = run_policy(env_id, make_policy(name))
    assert m["finished"] and not m["failed"] and np.isfinite(m["p_eps"])


def test_policy_batch_equals_single() -> None:
    policy = make_policy("iabc_acc2pid")
    batch = run_policy_batch(GANTRY[1], policy, num_envs=2, seed=0)
    single = run_policy(GANTRY[1], make_policy("iabc_acc2pid"), seed=1)
    assert batch["p_eps"][1] == single["p_eps"] and batch["p_e"][1] == single["p_e"]


def test_shipped_parameters_lie_in_the_box() -> None:
    p = get_protocol("003")
    x = np.array([tuned_params_003()[n] for n in ACC2PID_NAMES])
    assert np.all((p.bounds[:, 0] <= x) & (x <= p.bounds[:, 1]))
    with pytest.raises(ValueError, match="unknown ACC2PID parameter"):
        make_policy("acc2pid", params={"kp_z": 1.0})


def test_threads_change_no_result() -> None:
    """The population on 1 or 2 threads (slices of it, both scenarios): the same fitness."""
    p = get_protocol("003")
    rng = np.random.default_rng(3)
    z = p.to_search(_hand()[None]) + rng.normal(0.0, 0.3, (6, len(p.names)))
    one = PopulationObjective("003", workers=1)(z)
    two = PopulationObjective("003", workers=2)(z)
    np.testing.assert_array_equal(one, two)
    assert np.any(one < PopulationObjective("003", workers=1).penalty)  # not all failed
    with pytest.raises(ValueError, match="workers"):
        PopulationObjective("003", workers=0)


def test_a_candidate_met_before_is_not_simulated_again() -> None:
    """Repeats (within a batch and across calls) run once and get the simulated result."""
    p = get_protocol(CIRCLE_003)
    rng = np.random.default_rng(5)
    x = p.to_params(p.to_search(_hand()[None]) + rng.normal(0.0, 0.2, (3, len(p.names))))
    objective = PopulationObjective(CIRCLE_003, workers=1)
    simulated: list[np.ndarray] = []
    run = objective._run

    def counting(case, loop, rows):  # type: ignore[no-untyped-def]
        simulated.append(rows.copy())
        return run(case, loop, rows)

    objective._run = counting  # type: ignore[method-assign]
    fit, failed = objective.evaluate(x[[0, 1, 0, 2, 1]])
    assert sum(len(r) for r in simulated) == 3  # each distinct candidate once
    fresh = PopulationObjective(CIRCLE_003, workers=1).evaluate(x)
    np.testing.assert_array_equal(fit, fresh[0][:, [0, 1, 0, 2, 1]])
    np.testing.assert_array_equal(failed, fresh[1][:, [0, 1, 0, 2, 1]])
    simulated.clear()
    again = objective.evaluate(x[[2, 0]])
    assert simulated == []  # all met before
    np.testing.assert_array_equal(again[0], fresh[0][:, [2, 0]])
    moved = x[:1].copy()
    moved[0, 0] = np.nextafter(moved[0, 0], np.inf)  # one ulp away: a new candidate
    objective.evaluate(moved)
    assert len(simulated) == 1


def test_work_units_cover_every_candidate_once_with_balanced_predicted_work() -> None:
    """A bee one parameter from a candidate met before is predicted to cost what it cost."""
    p = get_protocol(CIRCLE_003)
    rng = np.random.default_rng(7)
    z = p.to_search(_hand()[None]) + rng.normal(0.0, 0.5, (6, len(p.names)))
    objective = PopulationObjective(CIRCLE_003, workers=2)
    objective.evaluate(p.to_params(z))
    ticks = objective._recent_ticks[:6, 0].copy()
    bees = p.to_params(z)
    bees[:, 3] = p.to_params(z[::-1])[:, 3]  # each differs from a food source in one parameter
    units = objective._units(bees)
    rows = np.sort(np.concatenate([r for _, _, r in units]))
    np.testing.assert_array_equal(rows, np.arange(6))  # one scenario: each row once
    work = sorted(ticks[r].sum() for _, _, r in units)
    assert work[-1] - work[0] <= ticks.max()  # greedy: apart by at most one candidate's work
    assert units[0][2].size and ticks[units[0][2]].sum() == work[-1]  # dearest first


def test_run_stops_a_member_past_the_limit_on_that_tick() -> None:
    """stop_above: the member fails (reason 3) on the first tick its max error passes it."""
    from contour_gym.loop.state import MEM_COL, REASON_OVER_LIMIT

    objective = PopulationObjective(CIRCLE_003, workers=1)
    loop = objective._loops_for(2)[0]
    free = PopulationObjective(CIRCLE_003, workers=1)._loops_for(2)[0]
    limit = 50e-6
    for lp in (loop, free):
        lp.reset([0, 0])
    stopped = loop.run(stop_above=limit)
    full = free.run()
    assert np.all(full["max_contour_error"] > limit)  # the hand-tuned point passes 50 um
    assert np.all(loop.failure_reason == REASON_OVER_LIMIT) and not loop.done.any()
    assert np.all(stopped["max_contour_error"] > limit)
    # it stopped on the tick: its max is the first error past the limit, below the full run's
    assert np.all(stopped["max_contour_error"] < full["max_contour_error"])
    assert np.all(loop.mem[:, MEM_COL.end] < free.mem[:, MEM_COL.end])
    # the next run without a limit runs to the end again
    loop.reset([0, 0])
    again = loop.run()
    np.testing.assert_array_equal(again["max_contour_error"], full["max_contour_error"])
    with pytest.raises(ValueError, match="stop_above"):
        loop.run(stop_above=float("nan"))
