"""RL algorithms by name (agents.rl.algorithms): SB3's, sb3-contrib's, and a user's."""

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents.rl.algorithms import ALGORITHMS, Algorithm, register_algorithm  # noqa: E402
from agents.rl.config import algo_class, default_config_file  # noqa: E402
from agents.rl.saved import SB3Policy  # noqa: E402


def test_sb3_and_contrib_algorithms_are_usable_by_name():
    import stable_baselines3

    assert algo_class("ppo") is stable_baselines3.PPO and algo_class("sac") is stable_baselines3.SAC
    contrib = pytest.importorskip("sb3_contrib")
    assert algo_class("tqc") is contrib.TQC and algo_class("ppo_lstm") is contrib.RecurrentPPO
    assert ALGORITHMS.get("ppo_lstm").recurrent and ALGORITHMS.get("tqc").off_policy
    with pytest.raises(ValueError, match="unknown RL algorithm 'dqn2'; accepted: a2c, "):
        algo_class("dqn2")


def test_a_registered_algorithm_trains_by_name_and_a_missing_package_says_how_to_install():
    import stable_baselines3

    register_algorithm(Algorithm("my_a2c", "stable_baselines3", "A2C", off_policy=False))
    register_algorithm(Algorithm("absent", "no_such_rl_package", "X", off_policy=False,
                                 install="pip install no-such-rl-package"))
    try:
        assert algo_class("my_a2c") is stable_baselines3.A2C
        with pytest.raises(ValueError, match="pip install no-such-rl-package"):
            algo_class("absent")
        with pytest.raises(ValueError, match="no shipped config for algo 'my_a2c'"):
            default_config_file("my_a2c")
    finally:
        ALGORITHMS.unregister("my_a2c")
        ALGORITHMS.unregister("absent")


def _small_lstm(num_envs):
    """A vector env of 000's circle and an untrained RecurrentPPO (8 LSTM units) for it."""
    import gymnasium as gym

    contrib = pytest.importorskip("sb3_contrib")
    env = gym.make_vec("contour_gym/CCC-Circle-v0", num_envs=num_envs, decision_ticks=100)
    flat = gym.wrappers.FlattenObservation(gym.make("contour_gym/CCC-Circle-v0"))
    model = contrib.RecurrentPPO("MlpLstmPolicy", flat, n_steps=8, batch_size=16, seed=0,
                                 policy_kwargs={"lstm_hidden_size": 8}, device="cpu")
    return env, model


def test_a_recurrent_agent_carries_its_state_through_an_episode():
    """sb3-contrib's RecurrentPPO as a batch-first policy: the state is kept between act calls
    and started afresh at reset (same actions again)."""
    env, model = _small_lstm(2)
    policy = SB3Policy(model, recurrent=True)

    def run():
        policy.reset(env)
        obs, _ = env.reset(seed=0)
        out = []
        for _ in range(3):
            actions = policy.act(obs)
            out.append(actions)
            obs, *_ = env.step(actions)
        return np.array(out)

    first, again = run(), run()
    np.testing.assert_array_equal(first, again)
    assert policy._state is not None
    env.close()


def test_a_recurrent_agent_acts_on_each_member_as_it_does_alone():
    """Row by row (agents.rl.saved.by_rows): each member's LSTM state is its own, split from
    and joined back into the batch's, so a member's actions over several steps equal those of
    the same observations fed to the model alone."""
    env, model = _small_lstm(3)
    together = SB3Policy(model, recurrent=True)
    alone = [SB3Policy(model, recurrent=True) for _ in range(3)]
    for policy in (together, *alone):
        policy.reset(env)
    obs, _ = env.reset(seed=0)
    rng = np.random.default_rng(2)
    for _ in range(4):
        obs = {k: v * rng.uniform(0.5, 2.0, v.shape) for k, v in obs.items()}  # members differ
        actions = together.act(obs)
        for i, policy in enumerate(alone):
            mine = policy.act({k: v[i : i + 1] for k, v in obs.items()})
            np.testing.assert_array_equal(mine[0], actions[i])
        obs, *_ = env.step(actions)
    assert len({tuple(a) for a in actions}) == 3  # the members acted differently
    env.close()
