"""Scenarios as the papers ran them (issue 14): calibration bands, time laws, injection points,
tolerances that fit the machine."""

import math
import pickle

import numpy as np
import pytest

import contour_gym  # noqa: F401  (registers the ids)
from contour_gym.api import make_scenario, simulate
from contour_gym.envs.config import EnvConfig
from contour_gym.envs.registration import SCENARIOS, scenario_table
from contour_gym.metrics import member_metrics
from contour_gym.paths import TimeLaw, circle, line, load
from contour_gym.plant._kernel import ST
from contour_gym.presets import TOLERANCE_RULE, get_preset


def within(value, target, rel):
    return abs(value / target - 1.0) <= rel


# item 1: the papers' baseline rows ---------------------------------------------------------


def test_000_circle_without_ccc_is_within_15_percent_of_000s_simulation():
    m = simulate("xy_dc_servo", ideal=True)
    assert m["finished"] == 1.0
    assert within(m["max_contour_error"], 49e-6, 0.15), m["max_contour_error"]


@pytest.mark.parametrize(
    ("scenario", "peak", "cycle"),
    [("Feedrate-Circle-v0", 5.00e-6, 2.57), ("Feedrate-Corner-v0", 4.476e-6, 1.465)],
)
def test_004_constant_feedrate_rows_hold(scenario, peak, cycle):
    kwargs = dict(SCENARIOS[scenario][1], ideal=True)
    loop = EnvConfig.from_kwargs(kwargs).scenario().loop()
    loop.reset(0)
    m = member_metrics(loop.run(), 0)
    assert within(m["max_contour_error"], peak, 0.20), m["max_contour_error"]
    assert within(m["cycle_time"], cycle, 0.05), m["cycle_time"]


def test_004_tolerances_are_its_error_bounds():
    rows = {r["id"]: r for r in scenario_table()}
    assert rows["contour_gym/Feedrate-Circle-v0"]["tolerance"] == 5.0e-6
    assert rows["contour_gym/Feedrate-Corner-v0"]["tolerance"] == 4.5e-6


# item 2: time laws and windows ---------------------------------------------------------------


def test_three_leaf_runs_theta_2_pi_f_t_and_its_speed_varies_threefold():
    path = load("three_leaf")
    law = path.time_law
    assert law is not None and law.duration == pytest.approx(0.5)
    # the reference of the loop: theta = 2 pi f t, point by point
    loop = make_scenario("xyy_gantry", path, ideal=True).loop(record=True)
    loop.reset(0)
    loop.run()
    tr = loop.trace()
    k = np.arange(1, 450, 37)
    theta = 2.0 * math.pi * 1.0 * (tr.t[k] + loop.stage.ts)  # record k holds tick k's end
    rose = 0.025 * np.cos(3.0 * theta)[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])
    r = tr.r[0, k][:, [0, 1]] - np.array([0.0, 0.07])  # x, y1 minus the y1 offset
    np.testing.assert_allclose(r, rose, atol=1e-9)
    v = tr.v[0, 10:490]
    assert v.max() / v.min() > 2.0
    assert v.max() / v.min() == pytest.approx(3.0, rel=0.01)


def test_003_windows_are_10_seconds():
    for name in ("CCC-XYYGantry-Circle-v0", "CCC-XYYGantry-ThreeLeaf-v0"):
        scenario = EnvConfig.from_kwargs(dict(SCENARIOS[name][1])).scenario()
        loop = scenario.loop()
        duration = loop.planned_time() - loop.opts.settle_time
        assert duration == pytest.approx(10.0, rel=1e-3), (name, duration)


def test_time_laws_repeat_scale_and_check_their_path():
    law = TimeLaw.from_speed(lambda t: 0.1 + 0.0 * t, 1.0, dt=0.01)
    assert law.length == pytest.approx(0.1, rel=1e-12)
    twice = law.repeat(2)
    assert twice.duration == pytest.approx(2.0) and twice.length == pytest.approx(0.2)
    ring = circle(0.1 / (2.0 * math.pi))
    timed = ring.with_time_law(law.scaled_to(ring.length))
    assert pickle.loads(pickle.dumps(timed)).time_law.length == pytest.approx(ring.length)
    assert timed.repeat(3).time_law.duration == pytest.approx(3.0)
    with pytest.raises(ValueError, match="time law ends at"):
        ring.with_time_law(law.scaled_to(2.0 * ring.length))
    with pytest.raises(ValueError, match="open"):
        line((0.0, 0.0), (0.1, 0.0)).repeat(2)
    with pytest.raises(ValueError, match="laps"):
        ring.repeat(0)
    with pytest.raises(ValueError, match="not decrease"):
        TimeLaw(0.1, np.array([0.0, 0.2, 0.1]), np.ones(3))


def test_a_feedrate_on_a_time_law_path_scales_its_time():
    path = load("three_leaf")
    sc = make_scenario("xyy_gantry", path, feedrate=0.5 * path.time_law.mean_speed())
    assert sc.feed_override == pytest.approx(0.5)
    assert sc.loop().planned_time() - 1.0 == pytest.approx(1.0, rel=1e-6)


# item 3: where the CCC acts --------------------------------------------------------------------


def first_tick_commands(injection, ccc, offset):
    """u of tick 0 on 002's machine (ideal) on a line along x, with axis z displaced."""
    sc = make_scenario(
        "lugre_linear_motor", line((0.0, 0.0), (0.05, 0.0)), ideal=True,
        estimator="ground_truth", ccc_injection=injection,
    )
    loop = sc.loop(ccc_gains=ccc, record=True)
    loop.reset(0)
    loop.ax_s[0, 1, ST.x] += offset
    loop.step(1)
    return loop.trace().u[0, 0]


def test_the_two_injection_points_differ_and_match_a_hand_computed_first_tick():
    kp_c, d = 2.0, 10e-6
    gains = get_preset("lugre_linear_motor").axis_gains[1]
    none = first_tick_commands("control", None, d)
    control = first_tick_commands("control", (kp_c, 0.0, 0.0), d)
    reference = first_tick_commands("reference", (kp_c, 0.0, 0.0), d)
    # the foot is d below the tool: the CCC's correction is kp_c (q - p) = (0, -kp_c d)
    # control: added to the axis command; reference: added to the commanded position, which the
    # axis PID turns into (kp + ki Ts) times it on the first tick (no derivative yet)
    ts = get_preset("lugre_linear_motor").stage.ts
    np.testing.assert_allclose(control - none, [0.0, -kp_c * d], atol=1e-15)
    np.testing.assert_allclose(
        reference - none, [0.0, -(gains.kp + gains.ki * ts) * kp_c * d], rtol=1e-9, atol=1e-15
    )
    assert abs((reference - none)[1]) > 100 * abs((control - none)[1])


def test_every_preset_defaults_to_its_papers_injection():
    expected = {"xy_dc_servo": "control", "xyz_pmlsm": "control", "xyy_gantry": "control",
                "lugre_linear_motor": "reference"}
    for name, injection in expected.items():
        assert make_scenario(name).options["ccc_injection"] == injection


# item 4: scenario defaults that match the machine ----------------------------------------------


def test_each_id_runs_its_papers_estimator():
    paper_estimator = {"000": {"exact", "two_circle"}, "001": {"tangent"}, "002": {"frenet"},
                       "003": {"angle"}, "004": {"window"}}
    for row in scenario_table():
        paper = get_preset(row["plant"]).paper
        assert row["estimator"] in paper_estimator[paper], row


@pytest.mark.slow
@pytest.mark.parametrize("name", ["xy_dc_servo", "xyz_pmlsm", "lugre_linear_motor", "xyy_gantry"])
def test_tolerance_rule_holds_on_the_measured_baseline(name):
    preset = get_preset(name)
    m = simulate(name, ideal=True)
    assert preset.tolerance == pytest.approx(TOLERANCE_RULE * m["max_contour_error"], rel=0.01)


CCC_IDS = [name for name, (task, _) in SCENARIOS.items() if task == "CCC"]


@pytest.mark.slow
@pytest.mark.parametrize("name", CCC_IDS)
def test_preset_pid_ccc_mean_error_is_within_a_decade_of_the_tolerance(name):
    config = EnvConfig.from_kwargs(dict(SCENARIOS[name][1]))
    scenario = config.scenario()
    loop = scenario.loop(ccc_gains=scenario.preset.ccc_gains)
    loop.reset(0)
    m = member_metrics(loop.run(), 0)
    tolerance = config.tolerance_for(scenario.preset)
    assert 0.1 * tolerance <= m["mean_contour_error"] <= 10.0 * tolerance, (m, tolerance)
