"""The tasks pose the real problem: a rig, an interior optimum, failure never pays, paths and
parts run to their end, arrival ends a contour, G-code feedrates are honoured (issue 9)."""

import dataclasses
import warnings

import gymnasium as gym
import numpy as np
import pytest

import contour_gym  # noqa: F401  (registers the ids)
from contour_gym.api import make_scenario, simulate
from contour_gym.ccc import CCCGains
from contour_gym.envs import CCCEnv
from contour_gym.metrics import metrics_from_sums, sums_from_trace
from contour_gym.paths import from_gcode, parametric
from contour_gym.presets import get_preset
from contour_gym.servo import PIDGains

ACTIONS = (-1.0, -0.5, 0.0, 0.5, 1.0)


def constant_action_sweep(env_id, **kwargs):
    """Return of one episode per constant action (one vector-env member each), seed 0."""
    n = len(ACTIONS)
    venv = gym.make_vec(env_id, num_envs=n, **kwargs)
    task = venv.unwrapped.task
    actions = np.repeat(np.asarray(ACTIONS)[:, None], task.n_actions, axis=1)
    venv.reset(seed=0)
    ret, failed, live = np.zeros(n), np.zeros(n, bool), np.ones(n, bool)
    while live.any():
        _, r, te, tr, info = venv.step(actions)
        ret[live] += r[live]
        failed |= live & info["failure"]
        live &= ~(te | tr)
    return ret, failed, task


@pytest.mark.slow
@pytest.mark.parametrize(
    "env_id", ["contour_gym/CCC-Circle-v0", "contour_gym/CCC-XYYGantry-Circle-v0"]
)
def test_best_constant_action_is_interior_and_max_gains_are_worse(env_id):
    ret, failed, task = constant_action_sweep(env_id)
    best = int(np.argmax(ret))
    assert 0 < best < len(ACTIONS) - 1, ret  # neither no CCC nor the largest gains
    assert ret[-1] <= ret[best] - 0.25 * abs(ret[best]), ret
    # failure never pays: every failed episode below every completed one
    floor = task.max_episode_steps * min(task.reward_range[0], 0.0) - task.config.failure_penalty
    assert np.all(ret[failed] == pytest.approx(floor, rel=1e-9))
    if failed.any() and (~failed).any():
        assert ret[failed].max() < ret[~failed].min()


def test_a_failed_episode_returns_less_than_a_completed_one():
    # the same env: one member keeps the preset gains, the other takes absurd gains
    env_ok, env_bad = CCCEnv(decision_ticks=20), CCCEnv(decision_ticks=20, gain_range=3000.0)
    returns = []
    for env, action in ((env_ok, None), (env_bad, np.ones(3))):
        env.reset(seed=0)
        a = env.gains_to_action(env.task.g0) if action is None else action
        total, done, info = 0.0, False, {}
        while not done:
            _, r, te, tr, info = env.step(a)
            total, done = total + r, te or tr
        returns.append((total, info["failure"], info["metrics"]["finished"]))
    (ok, ok_failed, ok_finished), (bad, bad_failed, _) = returns
    assert ok_finished and not ok_failed and bad_failed
    assert bad < ok


def test_the_feedrate_task_pays_for_time_and_for_error():
    # Feedrate-Circle (004's circle at its 5 um bound): the nominal feedrate beats both the
    # slowest (time costs) and the fastest (the error breaks the tolerance)
    ret, failed, _ = constant_action_sweep("contour_gym/Feedrate-Circle-v0")
    slowest, nominal, fastest = ret[0], ret[2], ret[-1]
    assert nominal > slowest and nominal > fastest, ret
    assert not failed[[0, 2]].any()


def user_path_183mm():
    # a 2:1 Lissajous-like curve, 183 mm long
    path = parametric(
        lambda t: np.column_stack([0.06 * np.sin(t), 0.03 * np.sin(2.0 * t)]), 0.0, np.pi
    )
    assert path.length == pytest.approx(0.183, abs=0.002)
    return path


PART = """%
O1001 (TWO CUTS)
G21 G90 G17 G94
G0 X0 Y0
G1 X30 F600
G1 Y20 F1200
G0 X40 Y20
G1 X40 Y0 F900
M30
%
"""


@pytest.mark.parametrize("env_id", ["contour_gym/CCC-v0", "contour_gym/Feedrate-v0"])
@pytest.mark.parametrize("which", ["user_path", "gcode_part"])
def test_user_paths_and_parts_run_to_their_end_on_both_generic_ids(env_id, which):
    path = user_path_183mm() if which == "user_path" else from_gcode(PART)
    env = gym.make(env_id, path=path, decision_ticks=50)
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape)
    steps, done = 0, False
    while not done:
        _, r, te, tr, info = env.step(action)
        steps, done = steps + 1, te or tr
    assert te and not tr, "the episode must end at the path's end, not at a step limit"
    assert info["metrics"]["finished"] and not info["failure"]
    assert steps < env.unwrapped.max_episode_steps
    assert info["s"] == pytest.approx(env.unwrapped.task.path.length)


def test_truncation_carries_the_metrics_with_finished_false():
    env = gym.make("contour_gym/CCC-Circle-v0", step_limit=5)
    env.reset(seed=0)
    for _ in range(5):
        _, _, te, tr, info = env.step(np.zeros(3))
    assert tr and not te
    metrics = info["metrics"]
    assert metrics["finished"] is False and np.isfinite(metrics["max_contour_error"])
    assert metrics["cycle_time"] == np.inf


# the numbers of `contour-gym simulate` before the rig and the arrival (commit 4b90d49)
BEFORE = {  # max, mean, rms contour error, m; the reference ended at tick 1999
    "no CCC": (1.7879934463444564e-05, 1.206749817320836e-05, 1.2190825926971218e-05),
    "PID CCC": (9.956296650033333e-06, 3.103017679700227e-07, 1.4569998095843518e-06),
}


@pytest.mark.parametrize("label", BEFORE)
def test_ideal_reproduces_the_old_simulate_numbers_up_to_the_arrival(label):
    # the machine as it was then: Kv = 30 /s (calibration to 000 later chose 21 /s), the
    # ground-truth error fed to the CCC
    preset = get_preset("xy_dc_servo")
    axis = tuple(PIDGains(kp=30.0 * a.damping / a.force_constant) for a in preset.stage.axes)
    kp = axis[0].kp
    then = dataclasses.replace(preset, axis_gains=axis, ccc_gains=CCCGains(kp=kp, ki=20.0 * kp))
    sc = make_scenario(then, ideal=True, estimator="ground_truth")
    gains = None if label == "no CCC" else sc.preset.ccc_gains.as_tuple()
    loop = sc.loop(ccc_gains=gains, record=True)
    loop.reset(0)
    loop.run()
    tr = loop.trace()
    upto = slice(0, int(loop.ip_s[0, 3]) + 1)  # ticks until the reference reached the end
    m = metrics_from_sums(sums_from_trace(tr.eps[:, upto], tr.r[:, upto] - tr.x[:, upto],
                                          tr.u[:, upto]), 0.0)
    got = (m["max_contour_error"][0], m["mean_contour_error"][0], m["rms_contour_error"][0])
    np.testing.assert_allclose(got, BEFORE[label], rtol=1e-9)
    assert loop.ip_s[0, 3] == 1999
    # the arrival adds the ticks the axes need to get in position at the end
    assert 0.0 < loop.cycle_time[0] - 1.999 < 0.5


def test_a_huge_feedrate_does_not_report_a_small_error():
    nominal = simulate()
    with pytest.warns(UserWarning, match="machine limit"):
        huge = simulate(feedrate=1000.0)
    assert huge["failed"] or huge["max_contour_error"] > 2.0 * nominal["max_contour_error"]
    assert huge["cycle_time"] > 1.0  # the machine really went round (capped at 50 mm/s)


def test_the_machine_limit_itself_does_not_warn():
    # an F word at the largest feed, read back in another unit, may land an ulp above it
    top = make_scenario("xy_servo_coulomb").preset.max_feedrate
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        make_scenario("xy_servo_coulomb", feedrate=float(np.nextafter(top, 1.0)))


def test_gcode_part_runs_each_block_at_its_own_feedrate():
    part = from_gcode(PART)
    sc = make_scenario("xy_servo_coulomb", part, ideal=True)
    assert sc.feedrate == pytest.approx(0.02)  # the highest cutting F is the nominal
    loop = sc.loop(record=True)
    loop.reset(0)
    loop.run()
    tr = loop.trace()
    s, v = tr.s[0], tr.v[0]
    seg = np.searchsorted(part.table.s0, s, side="right") - 1
    # segments (the zero-length G0 X0 Y0 adds none): F600, F1200, the G0, F900 mm/min
    for segment, feed in ((0, 0.01), (1, 0.02), (3, 0.015)):
        speeds = v[(seg == segment) & np.isfinite(v)]
        assert speeds.max() == pytest.approx(feed, rel=1e-9), segment
    rapid = v[(seg == 2) & np.isfinite(v)]
    assert rapid.max() > 0.02  # the G0 runs at the machine's rapid rate
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        slow = simulate(plant="xy_servo_coulomb", path=part, feedrate_override=0.5, ideal=True)
    full = simulate(plant="xy_servo_coulomb", path=part, ideal=True)
    assert slow["cycle_time"] > 1.3 * full["cycle_time"]  # the rapid is not overridden


@pytest.fixture
def kp_task():
    from _kp_task import KP_ONLY

    from contour_gym.tasks import TASKS, register_task

    register_task(KP_ONLY, replace=True)
    yield KP_ONLY
    TASKS.unregister(KP_ONLY.name)


def test_a_third_task_is_one_module_and_a_registration(kp_task):
    """A user's task (tests/_kp_task.py) runs like a built-in one: its action sets kp alone,
    which is the CCC task with ki and kd at action -1 (exactly 0), bit for bit."""
    from _kp_task import KpEnv, kp_actions

    env, ccc = KpEnv(plant="xy_dc_servo", path="circle"), CCCEnv(plant="xy_dc_servo", path="circle")
    assert env.action_space.shape == (1,)
    assert env.observation_space["kp"].shape == (1,) and "gains" not in env.observation_space
    obs, _ = env.reset(seed=3)
    assert obs["kp"].tolist() == [-1.0]
    ccc.reset(seed=3)
    for a in (0.2, 0.5, -0.3):
        obs, r, te, tr, info = env.step(np.array([a], dtype=np.float32))
        obs_c, r_c, te_c, tr_c, info_c = ccc.step(kp_actions(a, 1))
        assert r == r_c and (te, tr) == (te_c, tr_c)
        np.testing.assert_array_equal(info["contour_error"], info_c["contour_error"])
        np.testing.assert_array_equal(obs["contour_error"], obs_c["contour_error"])
        assert obs["kp"].tolist() == [np.float32(a)]
    env.close()
    ccc.close()


def test_unknown_task_is_named():
    from contour_gym.envs.config import EnvConfig
    from contour_gym.envs.core import ContourTask

    with pytest.raises(ValueError, match="unknown task 'gain_schedule'; accepted: ccc, feedrate"):
        ContourTask(EnvConfig.from_kwargs({}), 1, "gain_schedule")
