"""004's fuzzy feedrate controller and the held override as policies; evaluate; make/available."""

import gymnasium as gym
import numpy as np
import pytest

import contour_gym  # noqa: F401  (registers the ids)
from agents.evaluate import evaluate, run_policy
from agents.feedrate_policies import DF_UNITS, ConstantFeedrate, FuzzyFeedrate
from agents.fuzzy import FEEDRATE_GAIN_004, fuzzy_feedrate_004
from agents.fuzzy import evaluate as fuzzy_evaluate
from agents.policies import POLICIES, available, make, make_policy

CIRCLE = "contour_gym/Feedrate-Circle-v0"
CORNER = "contour_gym/Feedrate-Corner-v0"


def batch_obs(e, de, n_contours=1):
    """A batched feedrate-env observation with the given errors (in tolerances)."""
    b = len(e)
    return {
        "contour_error": np.asarray(e, np.float32).reshape(b, n_contours),
        "contour_error_change": np.asarray(de, np.float32).reshape(b, n_contours),
        "feedrate": np.ones((b, 2), np.float32),
    }


@pytest.fixture(scope="module")
def feed_env():
    env = gym.make("contour_gym/Feedrate-v0", decision_ticks=5, max_feedrate_change=0.2)
    yield env
    env.close()


def test_available_lists_the_reference_policies_sorted_and_make_builds_them():
    names = available()
    assert names == sorted(names)
    assert {"constant", "cnc_lookahead", "fuzzy_feedrate", "constant_feedrate"} <= set(names)
    fuzzy = make("fuzzy_feedrate")
    assert isinstance(fuzzy, FuzzyFeedrate) and fuzzy.gain == FEEDRATE_GAIN_004
    assert isinstance(make_policy("constant_feedrate", override=0.5), ConstantFeedrate)
    assert make("constant_feedrate", override=0.5).env_kwargs == {"feedrate_override": 0.5}
    assert POLICIES.get("fuzzy_feedrate").params() == ("gain", "e_gain", "de_gain", "unit")


@pytest.mark.parametrize(
    ("params", "match"),
    [({"gain": 0.0}, "gain"), ({"e_gain": 0.0}, "e_gain"), ({"de_gain": np.nan}, "de_gain"),
     ({"unit": "mm"}, "'mm'"), ({"gane": 1.0}, "gane")],
)
def test_fuzzy_feedrate_names_a_bad_parameter(params, match):
    with pytest.raises(ValueError, match=match):
        make("fuzzy_feedrate", **params)


def test_make_with_an_env_checks_the_fit_before_stepping(feed_env):
    ccc = gym.make("contour_gym/CCC-v0")
    with pytest.raises(ValueError, match="feedrate env"):
        make("fuzzy_feedrate", env=ccc)
    with pytest.raises(ValueError, match="feedrate env"):
        make("constant_feedrate", env=ccc)
    ccc.close()
    with pytest.raises(ValueError, match=r"2\.5.*feedrate_range"):
        make("constant_feedrate", env=feed_env, override=2.5)
    with pytest.raises(ValueError, match="reset"):
        make("fuzzy_feedrate").act(batch_obs([0.0], [0.0]))
    policy = make("fuzzy_feedrate", env=feed_env)
    with pytest.raises(ValueError, match="feedrate env"):
        policy.act({"gains": np.zeros((1, 3))})
    with pytest.raises(ValueError, match="batched"):
        policy.act({k: v[0] for k, v in batch_obs([0.0], [0.0]).items()})


def test_fuzzy_feedrate_is_004s_rule_base_times_its_gain_in_the_chosen_unit(feed_env):
    # env: F_nom of Feedrate-v0, 5 ticks per decision, max_feedrate_change 0.2
    task = feed_env.unwrapped.task
    rng = np.random.default_rng(0)
    e, de = rng.uniform(-1.5, 1.5, 64), rng.uniform(-1.5, 1.5, 64)
    d_f = fuzzy_evaluate(fuzzy_feedrate_004(), np.stack([e, de], 1).astype(np.float32))[:, 0]
    for unit, per_unit in DF_UNITS.items():
        policy = make("fuzzy_feedrate", env=feed_env, unit=unit, gain=0.2)
        scale = 0.2 * per_unit(task.loop.nominal_feedrate, 5) / 0.2
        expected = np.clip(scale * d_f, -1.0, 1.0)[:, None]
        np.testing.assert_allclose(policy.act(batch_obs(e, de)), expected, rtol=1e-12, atol=1e-15)
    # per tick = decision_ticks x per decision; the two mm/s readings scale with 1 / F_nom
    ticks = make("fuzzy_feedrate", env=feed_env, unit="mm_per_s_per_tick", gain=0.01)
    decision = make("fuzzy_feedrate", env=feed_env, unit="mm_per_s_per_decision", gain=0.01)
    obs = batch_obs(e, de)
    np.testing.assert_allclose(ticks.act(obs), 5 * decision.act(obs), rtol=1e-12)


def test_fuzzy_feedrate_ignores_the_error_sign_convention_and_picks_the_worst_contour(feed_env):
    policy = make("fuzzy_feedrate", env=feed_env)
    rng = np.random.default_rng(1)
    e, de = rng.uniform(-1, 1, 32), rng.uniform(-1, 1, 32)
    np.testing.assert_allclose(policy.act(batch_obs(e, de)), policy.act(batch_obs(-e, -de)),
                               atol=1e-12)
    small = e * rng.uniform(-0.9, 0.9, 32)  # |small| < |e|: e drives
    two = batch_obs(np.stack([small, e], 1), np.stack([de, de], 1), n_contours=2)
    np.testing.assert_array_equal(policy.act(two), policy.act(batch_obs(e, de)))
    # large inputs are clipped to the universes: one tolerance
    np.testing.assert_array_equal(policy.act(batch_obs([7.0, -3.0], [-9.0, 4.0])),
                                  policy.act(batch_obs([1.0, -1.0], [-1.0, 1.0])))


def test_predict_on_a_batch_equals_predict_member_by_member_bit_for_bit():
    venv = gym.make_vec(CIRCLE, num_envs=3, randomize=True)
    policy = make("fuzzy_feedrate", env=venv)
    obs, _ = venv.reset(seed=4)
    start = np.ones(3, dtype=bool)
    for _ in range(30):
        actions, state = policy.predict(obs, None, start)
        assert state is None and actions.shape == (3, 1)
        assert np.all(np.abs(actions) <= 1.0)
        for i in range(3):
            member = {k: v[i : i + 1] for k, v in obs.items()}
            one, _ = policy.predict(member, None, start[i : i + 1])
            np.testing.assert_array_equal(one, actions[i : i + 1])
        obs, _, terminated, truncated, _ = venv.step(actions)
        start = terminated | truncated
    assert len({a.tobytes() for a in actions}) == 3  # the members differ
    venv.close()


def test_a_single_env_episode_equals_the_first_vector_member():
    policy = make("fuzzy_feedrate")
    single = run_policy(CORNER, policy, seed=5)
    batch = evaluate(policy, CORNER, n_episodes=2, seed=5)
    assert batch["episodes"][0] == single
    assert single["finished"] and not single["failed"]


def test_constant_feedrate_holds_the_override_as_constant_does():
    held = run_policy(CORNER, make("constant_feedrate", override=0.8))
    assert held == run_policy(CORNER, make("constant"), feedrate_override=0.8)
    assert held["cycle_time"] > run_policy(CORNER, make("constant_feedrate"))["cycle_time"]


def test_a_constant_override_below_the_default_floor_builds_its_env_with_its_range():
    slow = make("constant_feedrate", override=0.05, feedrate_range=(0.05, 2.0))
    assert slow.env_kwargs == {"feedrate_override": 0.05, "feedrate_range": (0.05, 2.0)}
    held = run_policy(CORNER, slow)
    assert held == run_policy(CORNER, make("constant"), feedrate_override=0.05,
                              feedrate_range=(0.05, 2.0))
    assert held["cycle_time"] > run_policy(CORNER, make("constant_feedrate", override=0.2))[
        "cycle_time"]
    with pytest.raises(ValueError, match="outside the env's feedrate_range"):
        run_policy(CORNER, make("constant_feedrate", override=0.05))  # the default floor, 0.2
    with pytest.raises(ValueError, match=r"override 0.05 is outside feedrate_range \(0.1, 2.0\)"):
        make("constant_feedrate", override=0.05, feedrate_range=(0.1, 2.0))


def test_the_curvature_feed_limit_slows_for_curves_only_and_names_bad_values():
    limit = make("curvature_feed_limit")
    assert limit.env_kwargs == {"feedrate_range": (0.05, 2.0),
                                "feedrate_target": (0.05, 0.6, 2.0),
                                "feedrate_limit": (0.05, 0.005, 0.02, 0.01)}
    assert make("curvature_feed_limit", end_speed=None).env_kwargs["feedrate_limit"] == (
        0.05, 0.005)
    assert run_policy(CIRCLE, limit) == run_policy(CIRCLE, make("constant"), **limit.env_kwargs)
    # the circle (r = 20 mm at 53 mm/s programmed): sqrt(0.05 x 0.02) / 0.053 = 0.597 all the
    # way, just under the cap 0.6
    circle = run_policy(CIRCLE, limit)["cycle_time"]
    held = [run_policy(CIRCLE, make("constant_feedrate", override=o))["cycle_time"]
            for o in (0.6, 0.5)]
    assert held[0] < circle < held[1]
    for kwargs, match in [({"accel": 0.0}, "accel"), ({"reach": -1.0}, "reach"),
                          ({"cap": 0.04}, r"cap must lie in \(floor, 2\)"),
                          ({"end_speed": 0.0}, "end_speed"), ({"end_reach": -0.01}, "end_reach")
                          ]:
        with pytest.raises(ValueError, match=match):
            make("curvature_feed_limit", **kwargs)


def test_evaluate_averages_the_episodes_and_takes_a_policy_name():
    out = evaluate("constant_feedrate", {"id": CORNER, "randomize": True}, n_episodes=3, seed=1)
    episodes = out["episodes"]
    assert len(episodes) == 3 and episodes[2] == run_policy(
        {"id": CORNER, "randomize": True}, make("constant_feedrate"), seed=3)
    for key in ("max_contour_error", "cycle_time", "finished", "return", "steps"):
        assert isinstance(out[key], float)
        assert out[key] == pytest.approx(np.mean([float(e[key]) for e in episodes]), rel=1e-12)
    assert len({e["max_contour_error"] for e in episodes}) == 3
    with pytest.raises(ValueError, match="n_episodes"):
        evaluate("constant_feedrate", CORNER, n_episodes=0)
    with pytest.raises(ValueError, match="no_such"):
        evaluate("no_such", CORNER)


def test_fuzzy_feedrate_shortens_the_cycle_of_both_feedrate_ids():
    for env_id in (CIRCLE, CORNER):
        fuzzy = evaluate("fuzzy_feedrate", env_id)
        constant = evaluate("constant_feedrate", env_id)
        assert fuzzy["finished"] == 1.0
        assert fuzzy["cycle_time"] < constant["cycle_time"]


# a small 2-D part with two F words (mm, mm/min) and a free S curve: a user's own paths
PART = """G21 G90 G17
G1 X10 Y0 F600
G3 X20 Y10 R10 F900
G1 Y20
M2
"""


@pytest.mark.parametrize("where", ["parametric", "gcode"])
@pytest.mark.parametrize("name", ["fuzzy_feedrate", "constant_feedrate"])
def test_each_feedrate_policy_runs_a_user_path_to_the_end(name, where):
    from contour_gym.paths import from_gcode, parametric

    if where == "gcode":
        path = from_gcode(PART)
    else:
        path = parametric(lambda t: np.stack([0.02 * t, 0.0025 * np.sin(2 * np.pi * t)], 1),
                          0.0, 1.0)
    m = run_policy({"id": "contour_gym/Feedrate-v0", "path": path}, make_policy(name))
    assert m["finished"] and not m["failed"] and not m["truncated"]
    assert np.isfinite(m["max_contour_error"]) and m["cycle_time"] > 0.0
