"""Reference policies: the registry, batch-first actions, the CNC's own planning, run_policy."""

import gymnasium as gym
import numpy as np
import pytest

import contour_gym  # noqa: F401  (registers the ids)
from agents.evaluate import run_policy, run_policy_batch
from agents.policies import (
    POLICIES,
    CNCLookahead,
    ConstantPolicy,
    Policy,
    make_policy,
    register_policy,
)
from contour_gym.motion import DEFAULT_TOLERANCE
from contour_gym.presets import get_preset

CORNER = "contour_gym/Feedrate-Corner-v0"


def test_the_registry_makes_fresh_policies_and_names_what_it_rejects():
    assert {"constant", "cnc_lookahead"} <= set(POLICIES.names())
    a, b = make_policy("cnc_lookahead"), make_policy("cnc_lookahead")
    assert isinstance(a, CNCLookahead) and a is not b
    assert a.env_kwargs == {"path_control": "G64", "path_tolerance": DEFAULT_TOLERANCE,
                            "feedrate_override": 1.0}
    assert make_policy("cnc_lookahead", mode="G61").env_kwargs == {
        "path_control": "G61", "feedrate_override": 1.0}
    with pytest.raises(ValueError, match="'no_such_policy'.*cnc_lookahead"):
        make_policy("no_such_policy")
    with pytest.raises(ValueError, match=r"\['tol'\].*accepted: tolerance, mode"):
        make_policy("cnc_lookahead", tol=1e-5)
    with pytest.raises(ValueError, match="-1e-05"):
        make_policy("cnc_lookahead", tolerance=-1e-5)
    with pytest.raises(ValueError, match="'G99'"):
        make_policy("cnc_lookahead", mode="G99")
    with pytest.raises(ValueError, match="tolerance=5e-05 with mode='G61'"):
        make_policy("cnc_lookahead", tolerance=5e-5, mode="G61")
    with pytest.raises(ValueError, match="1.5"):
        make_policy("constant", action=1.5)
    with pytest.raises(ValueError, match="not both"):
        make_policy("constant", action=0.0, gains=(1.0, 2.0, 0.0))


def test_a_policy_registered_from_outside_is_made_by_name():
    class Hold(Policy):
        name = "hold_test"

        def act(self, obs):
            return np.zeros((len(obs["feedrate"]), 1))

    register_policy("hold_test", Hold)
    try:
        assert isinstance(make_policy("hold_test"), Hold)
        with pytest.raises(ValueError, match="already registered"):
            register_policy("hold_test", Hold)
    finally:
        POLICIES.unregister("hold_test")


@pytest.mark.parametrize("batch", [1, 3])
@pytest.mark.parametrize("env_id", ["contour_gym/Feedrate-v0", "contour_gym/CCC-v0"])
def test_constant_gives_batch_first_actions_of_the_env_action_shape(env_id, batch):
    venv = gym.make_vec(env_id, num_envs=batch)
    obs, _ = venv.reset(seed=0)
    policy = make_policy("constant", action=0.25)
    policy.reset(venv)
    actions = policy.act(obs)
    assert actions.shape == (batch, *venv.single_action_space.shape)
    assert np.all(actions == 0.25)
    assert venv.action_space.contains(actions.astype(np.float32))
    rows = np.linspace(-1, 1, batch)[:, None] * np.ones(venv.single_action_space.shape)
    np.testing.assert_array_equal(make_policy("constant", action=rows).act(obs), rows)
    venv.close()


def test_constant_gains_map_through_the_ccc_env_action_map():
    gains = get_preset("xy_dc_servo").ccc_gains.as_tuple()
    venv = gym.make_vec("contour_gym/CCC-v0", num_envs=2)
    obs, _ = venv.reset(seed=0)
    policy = ConstantPolicy(gains=gains)
    with pytest.raises(ValueError, match="reset"):
        policy.act(obs)
    policy.reset(venv)
    actions = policy.act(obs)
    task = venv.unwrapped.task
    np.testing.assert_allclose(task.action_to_gains(actions)[:, 0], [gains, gains], rtol=1e-12)
    with pytest.raises(ValueError, match="beyond the env's range"):
        ConstantPolicy(gains=np.asarray(gains) * 1e3).reset(venv)
    feed = gym.make_vec("contour_gym/Feedrate-v0", num_envs=1)
    with pytest.raises(ValueError, match="CCC env"):
        policy.reset(feed)
    with pytest.raises(ValueError, match="feedrate env"):
        make_policy("cnc_lookahead").act(obs)
    venv.close()
    feed.close()


def test_cnc_lookahead_exact_stop_is_slower_than_blending_on_the_corner():
    g61 = run_policy(CORNER, make_policy("cnc_lookahead", mode="G61"))
    g64 = run_policy(CORNER, make_policy("cnc_lookahead", tolerance=5e-5))
    assert g61["finished"] and g64["finished"]
    assert g61["cycle_time"] > g64["cycle_time"]
    # the exact stop keeps the corner within the tolerance; blending at 0.05 mm does not
    assert g61["max_contour_error"] <= g61["tolerance"] < g64["max_contour_error"]


def test_a_conflicting_explicit_env_argument_raises_and_an_agreeing_one_does_not():
    policy = make_policy("cnc_lookahead", mode="G61")
    with pytest.raises(ValueError, match="path_control='G64'.*cnc_lookahead"):
        run_policy(CORNER, policy, path_control="G64")
    with pytest.raises(ValueError, match="feedrate_override"):
        run_policy({"id": CORNER, "feedrate_override": 0.5}, policy)
    with pytest.raises(ValueError, match="'id'"):
        run_policy({"path_control": "G61"}, policy)
    assert run_policy(CORNER, policy, path_control="G61", feedrate_override=1)["finished"]


def test_run_policy_is_deterministic_and_members_equal_single_runs():
    policy = make_policy("constant", action=0.5)
    first, second = run_policy(CORNER, policy, seed=3), run_policy(CORNER, policy, seed=3)
    assert first == second
    assert {"cycle_time", "max_contour_error", "finished", "return", "failed"} <= set(first)
    batch = run_policy_batch(CORNER, policy, num_envs=2, seed=2)
    assert {k: v[1].item() for k, v in batch.items()} == first


@pytest.mark.parametrize("make_env", [
    lambda: gym.make("contour_gym/Feedrate-Corner-v0"),
    lambda: gym.make_vec("contour_gym/Feedrate-Corner-v0", num_envs=2),
], ids=["single", "vector"])
def test_evaluate_takes_an_env_instance_as_sb3_does(make_env):
    """An env the user made gives what the id gives: episode i seeded seed + i, bit for bit
    (three episodes: a single env one by one, a vector env of two in two rounds)."""
    from agents.evaluate import evaluate

    by_id = evaluate("constant_feedrate", "contour_gym/Feedrate-Corner-v0", n_episodes=3, seed=4)
    env = make_env()
    mine = evaluate("constant_feedrate", env, n_episodes=3, seed=4)
    assert mine["episodes"] == by_id["episodes"]
    with pytest.raises(ValueError, match="needs the env built with ccc_law='fuzzy_pid'"):
        evaluate("fuzzy_pid_ccc", gym.make("contour_gym/CCC-Circle-v0"))
    env.close()
