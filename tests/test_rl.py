import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from agents.rl.train import load_hyperparameters, train  # noqa: E402


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ["contour_gym/CCC-v0", "contour_gym/Feedrate-v0"])
@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_sb3_trains_a_few_thousand_steps_on_each_generic_id(env_id, algo, tmp_path):
    from stable_baselines3 import PPO, SAC

    steps = 2048
    overrides = {"n_steps": 256} if algo == "ppo" else {"learning_starts": 256}
    path = train(
        env_id,
        algo,
        total_timesteps=steps,
        out_dir=tmp_path,
        checkpoint_every=1024,
        env_kwargs={"decision_ticks": 20},
        **overrides,
    )
    assert path.exists()
    assert list((path.parent / "checkpoints").glob("*.zip"))
    model = {"ppo": PPO, "sac": SAC}[algo].load(path)
    assert model.num_timesteps >= steps
    for p in model.policy.parameters():
        assert np.all(np.isfinite(p.detach().numpy()))


def test_unknown_algo_is_rejected():
    with pytest.raises(ValueError, match="ppo"):
        load_hyperparameters("dqn")
