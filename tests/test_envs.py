import pickle
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import ResetNeeded
from gymnasium.utils.env_checker import check_env

import contour_gym
from contour_gym.envs import CCCEnv, CCCVectorEnv, FeedrateEnv, FeedrateVectorEnv
from contour_gym.paths import from_gcode, parametric

ALL_IDS = contour_gym.ENV_IDS


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_gymnasium_check_env_without_warnings(env_id):
    env = gym.make(env_id).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, skip_render_check=True)


@pytest.mark.parametrize("env_id", ALL_IDS)
def test_sb3_check_env_without_warnings(env_id):
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = gym.make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3_check(env, warn=True)


def rollout(env, seed, steps=60, actions=None):
    rng = np.random.default_rng(123)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    rewards = []
    for k in range(steps):
        a = rng.uniform(-1, 1, env.action_space.shape) if actions is None else actions[k]
        obs, r, term, trunc, _ = env.step(a)
        out.append(obs)
        rewards.append(r)
        if term or trunc:
            break
    return out, rewards


def same_obs(a, b):
    return all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("cls", [CCCEnv, FeedrateEnv])
def test_same_seed_same_rollout_and_randomisation_differs_by_seed(cls):
    kw = dict(plant="xyz_pmlsm", randomize=True)
    o1, r1 = rollout(cls(**kw), 3)
    o2, r2 = rollout(cls(**kw), 3)
    o3, r3 = rollout(cls(**kw), 4)
    assert r1 == r2 and all(same_obs(a, b) for a, b in zip(o1, o2, strict=True))
    assert r1 != r3


def test_envs_pickle_and_resume_identically():
    env = CCCEnv(plant="xyz_pmlsm", randomize=True)
    env.reset(seed=1)
    for _ in range(5):
        env.step(np.zeros(3))
    clone = pickle.loads(pickle.dumps(env))
    a = np.full(3, 0.3)
    for _ in range(5):
        x = env.step(a)
        y = clone.step(a)
        assert x[1] == y[1] and same_obs(x[0], y[0])


@pytest.mark.parametrize(
    ("single", "vector", "kw"),
    [
        (CCCEnv, CCCVectorEnv, dict(plant="xyz_pmlsm", randomize=True, decision_ticks=50)),
        (
            FeedrateEnv,
            FeedrateVectorEnv,
            dict(plant="xy_servo_coulomb", path="corner", decision_ticks=40),
        ),
        (
            FeedrateEnv,
            FeedrateVectorEnv,
            dict(path="random", decision_ticks=40, curvature_windows=(0.0, 0.002, 0.01),
                 feedrate_range=(0.05, 2.0), feedrate_target=(0.05, 0.3, 1.2),
                 feedrate_limit=(0.05, 0.005, 0.02, 0.01)),
        ),
        (
            FeedrateEnv,
            FeedrateVectorEnv,
            dict(path="random", decision_ticks=40, feedrate_range=(0.05, 2.0),
                 feedrate_target=(0.05, 0.6, 1.2), feedrate_limit=(0.05, 0.005), limit_span=2.0),
        ),
    ],
)
def test_vector_env_equals_loop_of_single_envs_bit_for_bit(single, vector, kw):
    n, steps, seed = 3, 90, 11
    venv = vector(num_envs=n, max_episode_steps=40, **kw)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (steps, n, venv.single_action_space.shape[0]))
    vobs, _ = venv.reset(seed=seed)
    vrec = [(vobs, None, None, None)]
    for k in range(steps):
        o, r, te, tr, _ = venv.step(actions[k])
        vrec.append((o, r, te, tr))
    for i in range(n):
        env = single(max_episode_steps=40, **kw)
        obs, _ = env.reset(seed=seed + i)
        assert same_obs(obs, {k: v[i] for k, v in vrec[0][0].items()})
        done = False
        for k in range(steps):
            o, r, te, tr = vrec[k + 1]
            if done:  # next-step autoreset: the vector member reset instead of stepping
                obs, _ = env.reset()
                assert r[i] == 0.0 and not te[i] and not tr[i]
                done = False
            else:
                obs, rew, term, trunc, _ = env.step(actions[k, i])
                assert rew == r[i] and term == te[i] and trunc == tr[i]
                done = term or trunc
            assert same_obs(obs, {key: v[i] for key, v in o.items()}), (i, k)


def test_a_target_override_action_moves_the_override_toward_its_target():
    env = FeedrateEnv(path="circle", feedrate_range=(0.05, 2.0), decision_ticks=10,
                      feedrate_target=(0.05, 0.3, 1.2), max_feedrate_change=0.1)
    obs, _ = env.reset(seed=0)
    assert obs["feedrate"][0] == 1.0  # the scenario's override until the first decision
    override = None  # which takes its target at once: the axes are still at rest
    for a in [-0.5] + [0.0] * 9 + [1.0] * 10 + [0.5] * 8 + [-1.0] * 8 + [2.0, -0.25]:
        goal = 0.3 * (1.2 / 0.3) ** min(a, 1.0) if a >= 0 else 0.3 * (0.05 / 0.3) ** -a
        step = goal if override is None else float(np.clip(goal - override, -0.1, 0.1))
        override = step if override is None else override + step
        obs, *_ = env.step(np.array([a]))
        assert obs["feedrate"][0] == pytest.approx(override, abs=1e-6), a
    assert override == pytest.approx(0.3 * (0.05 / 0.3) ** 0.25)
    env.reset(seed=1)
    obs, *_ = env.step(np.array([1.0]))
    assert obs["feedrate"][0] == pytest.approx(1.2)  # a new episode starts at its target again
    with pytest.raises(ValueError, match=r"feedrate_target must be \(low, mid, high\)"):
        FeedrateEnv(feedrate_target=(0.1, 0.3, 2.5))


def _limit_prior(env: FeedrateEnv, limit: tuple[float, ...]) -> tuple[float, bool]:
    # the curvature feed limit's override at member 0's arc length, in plain numpy (0.05-0.6),
    # and whether the end's speed set it
    a_c, reach, v_end, end_reach = (*limit, 0.0, 0.0)[:4]
    path, s = env.task.loop.paths[0], float(env.task.loop.s[0])
    s0, feeds = np.asarray(path.table.s0), np.asarray(path.segment_feedrates)
    ahead = np.minimum(s + np.linspace(0.0, reach, 41), path.length)  # every 0.125 mm
    speed = np.sqrt(a_c / np.abs(np.asarray(path.curvature(ahead))).max())
    near_end = path.length - s < end_reach
    if near_end:
        speed = min(speed, v_end)
    feed = feeds[min(np.searchsorted(s0, s, side="right") - 1, feeds.size - 1)]
    return float(np.clip(speed / feed, 0.05, 0.6)), near_end


def _follow_the_limit(env: FeedrateEnv, limit: tuple[float, ...], actions: Any, goal: Any,
                      dovr: float) -> tuple[list[float], int, bool]:
    # step env (reset) with actions[k] until its end, checking that the override moves toward
    # goal(prior, action) by at most dovr a step (taken at once on the first); the priors seen,
    # the steps near the end and whether the episode terminated
    override, priors, near_end = None, [], 0
    for a in actions:
        prior, at_end = _limit_prior(env, limit)
        target = goal(prior, a)
        step = target if override is None else float(np.clip(target - override, -dovr, dovr))
        override = step if override is None else override + step
        obs, _, terminated, truncated, _ = env.step(np.array([a]))
        assert obs["feedrate"][0] == pytest.approx(override, rel=1e-5), (a, prior)
        priors.append(prior)
        near_end += at_end
        if terminated or truncated:
            return priors, near_end, terminated
    return priors, near_end, False


def test_a_feedrate_limit_sets_the_zero_actions_target_from_the_curvature_ahead():
    limit = (0.05, 0.005, 0.02, 0.01)  # a_c, reach, v_end, end_reach
    env = FeedrateEnv(path="random", feedrate_range=(0.05, 2.0), decision_ticks=10,
                      feedrate_target=(0.05, 0.6, 1.2), feedrate_limit=limit,
                      max_feedrate_change=0.1)
    env.reset(seed=7017)  # a rose, its tight curve on the way
    priors, near_end, terminated = _follow_the_limit(env, limit, np.zeros(20000),
                                                     lambda prior, a: prior, 0.1)
    assert terminated and near_end > 10  # the whole path, its last 10 mm included
    assert min(priors) < 0.15 < 0.25 < max(priors)  # slows for the rose's tight curve
    bad = r"feedrate_limit must be \(a_c, reach\) or \(a_c, reach, v_end, end_reach\) > 0"
    for kwargs, match in [({"feedrate_limit": (0.05, 0.005)}, "give feedrate_target"),
                          ({"feedrate_target": (0.2, 0.3, 1.2), "feedrate_limit": (0.05, 0.0)},
                           bad),
                          ({"feedrate_target": (0.2, 0.3, 1.2),
                            "feedrate_limit": (0.05, 0.005, 0.02)}, bad),
                          ({"feedrate_target": (0.2, 0.3, 1.2),
                            "feedrate_limit": (0.05, 0.005, -0.02, 0.01)}, bad)]:
        with pytest.raises(ValueError, match=match):
            FeedrateEnv(**kwargs)


def test_limit_span_scales_the_action_around_the_limit_by_the_same_factor_up_and_down():
    limit, span = (0.05, 0.005, 0.02, 0.01), 2.0
    env = FeedrateEnv(path="random", feedrate_range=(0.05, 2.0), decision_ticks=10,
                      feedrate_target=(0.05, 0.6, 1.2), feedrate_limit=limit,
                      limit_span=span, max_feedrate_change=0.1)
    env.reset(seed=7009)
    actions = np.random.default_rng(0).uniform(-1.5, 1.5, 20000)  # out-of-range ones clipped
    _, near_end, terminated = _follow_the_limit(
        env, limit, actions, lambda prior, a: float(np.clip(prior * span ** np.clip(a, -1, 1),
                                                            0.05, 1.2)), 0.1)
    assert terminated and near_end > 10
    for kwargs, match in [({"limit_span": 2.0}, "give feedrate_limit too"),
                          ({"limit_span": 1.0, "feedrate_limit": (0.05, 0.005)}, "> 1, got 1.0"),
                          ({"limit_span": True, "feedrate_limit": (0.05, 0.005)}, "got True"),
                          ({"limit_span": float("nan"), "feedrate_limit": (0.05, 0.005)},
                           "got nan")]:
        with pytest.raises(ValueError, match=match):
            FeedrateEnv(feedrate_target=(0.2, 0.3, 1.2), **kwargs)


def test_make_vec_uses_the_native_vector_env():
    venv = gym.make_vec("contour_gym/CCC-Circle-v0", num_envs=4)
    assert isinstance(venv.unwrapped, CCCVectorEnv)
    obs, _ = venv.reset(seed=0)
    obs, r, te, tr, info = venv.step(np.zeros((4, 3)))
    assert r.shape == (4,) and obs["contour_error"].shape == (4, 1)


GCODE_PART = """G21 G90 G17
G0 X0 Y0
G1 X20 Y0 F1200
G3 X30 Y10 I0 J10
G1 X30 Y20
G2 X20 Y30 R10
G1 X0 Y30
"""


@pytest.mark.parametrize("cls", [CCCEnv, FeedrateEnv])
@pytest.mark.parametrize(
    "path",
    [
        parametric(lambda t: np.column_stack([0.02 * np.cos(t), 0.01 * np.sin(2 * t)]), 0.0, np.pi),
        from_gcode(GCODE_PART),
    ],
)
def test_envs_run_user_parametric_path_and_gcode_part(cls, path):
    env = cls(plant="xy_servo_coulomb", path=path, decision_ticks=20)
    obs, _ = env.reset(seed=0)
    for _ in range(10_000):
        obs, r, term, trunc, info = env.step(np.zeros(env.action_space.shape))
        assert np.isfinite(r)
        if term:
            break
    assert term and not info["failure"]
    assert info["metrics"]["cycle_time"] > path.length / (2.0 * env.task.loop.nominal_feedrate)
    assert info["s"] == pytest.approx(path.length)


def test_bad_inputs():
    env = CCCEnv()
    with pytest.raises(ResetNeeded):
        env.step(np.zeros(3))
    env.reset(seed=0)
    for bad in (
        np.array([np.nan, 0, 0]),
        np.array([0.0, np.inf, 0.0]),
        np.zeros(2),
        np.zeros((1, 3)),
    ):
        with pytest.raises(ValueError):
            env.step(bad)
    obs, r, term, trunc, info = env.step(np.array([5.0, -7.0, 0.0]))  # clipped, documented
    assert np.array_equal(obs["gains"], np.array([1.0, -1.0, 0.0], dtype=np.float32))
    with pytest.raises(ValueError, match="accepted"):
        CCCEnv(no_such_option=1)
    with pytest.raises(ValueError, match="xy_dc_servo"):
        CCCEnv(plant="no_such_plant")
    with pytest.raises(ValueError, match="circle"):
        CCCEnv(path="no_such_path")
    with pytest.raises(ValueError, match="randomize"):
        CCCEnv(randomize={"masss": 0.1})


def test_stepping_after_termination_raises():
    env = CCCEnv(decision_ticks=500)
    env.reset(seed=0)
    term = False
    while not term:
        _, _, term, _, _ = env.step(np.zeros(3))
    with pytest.raises(ResetNeeded):
        env.step(np.zeros(3))


def test_failure_terminates_and_sets_the_return_to_the_failure_floor():
    env = CCCEnv(hard_limit=5e-6, tolerance=1e-6, failure_penalty=50.0)  # start transient ~10 um
    env.reset(seed=0)
    term, info, ret = False, {}, 0.0
    while not term:
        _, r, term, _, info = env.step(np.zeros(3))
        ret += r
    task = env.task
    floor = task.max_episode_steps * min(task.reward_range[0], 0.0) - 50.0
    assert info["failure"] and ret == pytest.approx(floor, rel=1e-12)


def test_gain_mapping_reaches_zero_and_round_trips_exactly():
    env = CCCEnv()
    a = np.array([-1.0, 0.0, 0.5])
    g = env.action_to_gains(a)
    np.testing.assert_allclose(env.gains_to_action(g), a, atol=1e-12)
    assert np.all(env.action_to_gains(-np.ones(3)) == 0.0)  # no CCC is an action
    np.testing.assert_allclose(env.action_to_gains(np.ones(3))[0], env.task.g_max, rtol=1e-12)
    # the preset's own gains (kd = 0) and no CCC at all round-trip to 1e-9
    for gains in (env.task.preset.ccc_gains.as_tuple(), (0.0, 0.0, 0.0)):
        back = env.action_to_gains(env.gains_to_action(gains))[0]
        np.testing.assert_allclose(back, gains, rtol=1e-9, atol=0.0)
    venv = CCCVectorEnv(num_envs=2)  # the vector env maps alike
    np.testing.assert_array_equal(venv.gains_to_action(g), env.gains_to_action(g))
    np.testing.assert_array_equal(venv.action_to_gains(a), env.action_to_gains(a))
    # log-like: equal action steps multiply the gain by about the same factor high up
    hi = env.action_to_gains(np.array([[0.5, 0.5, 0.5], [0.75, 0.75, 0.75], [1.0, 1.0, 1.0]]))
    r1, r2 = hi[1, 0, 0] / hi[0, 0, 0], hi[2, 0, 0] / hi[1, 0, 0]
    assert r1 == pytest.approx(r2, rel=0.05) and r1 > 1.5


def test_rgb_array_render_shows_the_contour():
    env = CCCEnv(render_mode="rgb_array", decision_ticks=100)
    env.reset(seed=0)
    for _ in range(5):
        env.step(np.zeros(3))
    img = env.render()
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
    assert img.std() > 5  # not a blank canvas


def test_a_recording_env_keeps_only_the_episodes_under_way():
    # an env resets its members one by one, never the loop's clock: the record of every
    # episode since the env was made grew for ever, and render drew them all on the current
    # path. Now rows before every member's last reset are dropped, and render draws the
    # member's own episode; a member sitting out its auto-reset call is NaN, not zeros
    env = CCCEnv(render_mode="rgb_array", decision_ticks=100)
    loop = env.unwrapped.task.loop
    lengths = []
    for seed in (0, 1, 2):
        env.reset(seed=seed)
        done, steps = False, 0
        while not done:
            _, _, term, trunc, _ = env.step(np.zeros(3))
            done, steps = term or trunc, steps + 1
        episode = loop.episode_trace(0)
        assert loop.trace().x.shape[1] == episode.x.shape[1] == steps * 100
        assert episode.t[0] == 0.0 and np.isfinite(episode.x[0, 0]).all()
        lengths.append(steps)
    assert env.render().std() > 5
    venv = CCCVectorEnv(num_envs=2, decision_ticks=100, render_mode="rgb_array")
    venv.reset(seed=0)
    vloop = venv.task.loop
    most = 0
    for _ in range(3 * max(lengths)):  # every member through about three episodes
        venv.step(np.zeros((2, 3)))
        most = max(most, vloop.trace().x.shape[1])
    assert most <= 2 * (max(lengths) + 1) * 100 and vloop.trace_start > 0
    first = vloop.episode_trace(0)
    paused = ~np.isfinite(first.x[0, :, 0])
    assert paused[:100].all() and np.isfinite(first.x[0, 100:, 0]).any()  # its auto-reset call


def test_vector_env_survives_every_member_resetting_at_once():
    venv = CCCVectorEnv(num_envs=3, decision_ticks=1000)  # same path, same end for all
    venv.reset(seed=0)
    ended = np.zeros(3, dtype=bool)
    for _ in range(10):
        _, r, te, tr, _ = venv.step(np.zeros((3, 3)))
        if ended.all():
            assert np.all(r == 0.0) and not te.any()
            break
        ended = te | tr
    else:
        pytest.fail("episodes never ended")


def _run_rejecting(make, action, reject: bool, steps: int = 15):
    # rewards and observations of `steps` decisions; with reject, a NaN action before each
    env = make()
    env.reset(seed=5)
    bad = np.full_like(action, np.nan)
    out = []
    for _ in range(steps):
        if reject:
            with pytest.raises(ValueError, match="finite"):
                env.step(bad)
        obs, r, *_ = env.step(action)
        out.append((np.asarray(r).tolist(), {k: v.tolist() for k, v in obs.items()}))
    return out


@pytest.mark.parametrize("vector", [False, True])
def test_a_rejected_action_leaves_no_trace(vector: bool):
    # the noise a rejected call read ahead (a buffer refill) is the stream's next numbers all
    # the same: the run equals one that never saw the bad action, bit for bit
    if vector:
        make, action = (lambda: CCCVectorEnv(num_envs=2, decision_ticks=100)), np.full((2, 3), 0.2)
    else:
        make, action = (lambda: CCCEnv(decision_ticks=100)), np.full(3, 0.2)
    assert _run_rejecting(make, action, True) == _run_rejecting(make, action, False)
