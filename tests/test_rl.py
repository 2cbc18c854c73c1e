import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import gymnasium as gym  # noqa: E402
import torch  # noqa: E402
import yaml  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv  # noqa: E402

import agents.rl.train as rl_train  # noqa: E402
from agents import policies  # noqa: E402
from agents.evaluate import evaluate, run_policy  # noqa: E402
from agents.rl.config import algo_class, load_config  # noqa: E402
from agents.rl.saved import (  # noqa: E402
    SavedAgent,
    SB3Policy,
    by_rows,
    mean_actions,
    register_saved_agents,
)
from agents.rl.train import latest_checkpoint, load_checkpoint, read_curve, train  # noqa: E402
from agents.rl.train_shipped import export_agent, load_shipped  # noqa: E402
from agents.rl.vec_env import make_native_vec_env  # noqa: E402
from contour_gym import ENV_IDS  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
CCC = "contour_gym/CCC-Circle-v0"
# a tiny run: 4 members, short decisions (a circle in ~60 steps), small updates
TINY = {"n_envs": 4, "env_kwargs": {"decision_ticks": 50}, "policy_kwargs": {"net_arch": [16]}}
TINY_PPO = {**TINY, "n_steps": 32, "batch_size": 64, "n_epochs": 2}
TINY_SAC = {**TINY, "learning_starts": 32, "batch_size": 32, "buffer_size": 2000,
            "gradient_steps": 1}


def _tiny(tmp_path, algo="ppo", steps=256, seed=0, **kw):
    extra = {**(TINY_PPO if algo == "ppo" else TINY_SAC), "eval_every": steps, **kw}
    return train(CCC, algo, steps, seed=seed, out_dir=tmp_path, progress=False,
                 eval_episodes=2, **extra)


@pytest.mark.parametrize(
    "env_id, kwargs, steps",
    [
        (CCC, {"decision_ticks": 250, "randomize": True}, 40),  # arrivals and failures
        ("contour_gym/Feedrate-Corner-v0", {"step_limit": 4}, 10),  # truncations
    ],
)
def test_adapter_equals_dummy_vec_env_of_single_envs(env_id, kwargs, steps):
    n = 3
    native = make_native_vec_env(env_id, n, **kwargs)
    dummy = DummyVecEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)])
    for venv in (native, dummy):
        venv.seed(7)
    obs_a, obs_d = native.reset(), dummy.reset()
    rng = np.random.default_rng(0)
    ended = {"terminated": 0, "truncated": 0}
    for _ in range(steps):
        action = rng.uniform(-1, 1, (n, *native.action_space.shape)).astype(np.float32)
        obs_a, rew_a, done_a, infos_a = native.step(action)
        obs_d, rew_d, done_d, infos_d = dummy.step(action)
        assert obs_a.keys() == obs_d.keys()
        for key in obs_a:
            np.testing.assert_array_equal(obs_a[key], obs_d[key])
        assert rew_a.dtype == rew_d.dtype == np.float32
        np.testing.assert_array_equal(rew_a, rew_d)
        np.testing.assert_array_equal(done_a, done_d)
        for i in np.flatnonzero(done_d):
            a, d = infos_a[i], infos_d[i]
            assert a["TimeLimit.truncated"] == d["TimeLimit.truncated"]
            ended["truncated" if d["TimeLimit.truncated"] else "terminated"] += 1
            for key in d["terminal_observation"]:
                np.testing.assert_array_equal(a["terminal_observation"][key],
                                              d["terminal_observation"][key])
            assert a["metrics"] == d["metrics"]
            assert a["failure"] == d["failure"]
        assert [i["TimeLimit.truncated"] for i in infos_a] == [
            i["TimeLimit.truncated"] for i in infos_d
        ]
    assert ended["truncated" if "step_limit" in kwargs else "terminated"] >= n
    native.close()
    dummy.close()


def test_flattened_adapter_equals_flatten_observation_of_single_envs():
    """flatten=True: the Box of gymnasium's FlattenObservation on each single env, bit for bit."""
    n, kwargs = 3, {"decision_ticks": 250, "randomize": True}
    native = make_native_vec_env(CCC, n, flatten=True, **kwargs)
    dummy = DummyVecEnv([lambda: gym.wrappers.FlattenObservation(gym.make(CCC, **kwargs))
                         for _ in range(n)])
    assert native.observation_space == dummy.observation_space
    for venv in (native, dummy):
        venv.seed(5)
    np.testing.assert_array_equal(native.reset(), dummy.reset())
    rng, ends = np.random.default_rng(1), 0
    for _ in range(30):
        action = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        obs_a, rew_a, done_a, infos_a = native.step(action)
        obs_d, rew_d, done_d, infos_d = dummy.step(action)
        assert obs_a.dtype == obs_d.dtype == np.float32
        np.testing.assert_array_equal(obs_a, obs_d)
        np.testing.assert_array_equal(rew_a, rew_d)
        np.testing.assert_array_equal(done_a, done_d)
        for i in np.flatnonzero(done_d):
            ends += 1
            np.testing.assert_array_equal(infos_a[i]["terminal_observation"],
                                          infos_d[i]["terminal_observation"])
    assert ends >= n


def test_only_flatten_observation_is_a_native_env_wrapper(tmp_path):
    with pytest.raises(ValueError, match="env_wrapper.*FlattenObservation"):
        _tiny(tmp_path, env_wrapper="gymnasium.wrappers.TimeAwareObservation")


def test_a_flat_agent_acts_on_dict_observations(tmp_path):
    """An agent trained on the flattened Dict (the shipped configs) takes the env's Dict."""
    run = _tiny(tmp_path, steps=128)
    agent = SavedAgent(export_agent(run, tmp_path / "flat_agent", "test"))
    assert agent.model.observation_space.shape == (14,)
    venv = gym.make_vec(CCC, num_envs=2, vectorization_mode="vector_entry_point",
                        decision_ticks=50)
    agent.reset(venv)
    obs, _ = venv.reset(seed=0)
    batch, _ = agent.predict(obs)
    single, _ = agent.predict({k: v[1] for k, v in obs.items()})
    assert batch.shape == (2, 3) and single.shape == (3,)
    np.testing.assert_array_equal(batch[1], single)  # row by row: as alone, bit for bit
    with pytest.raises(ValueError, match="flat Box of 14"):
        agent.predict({k: v[:, :1] for k, v in obs.items()})
    with pytest.raises(ValueError, match="does not fit"):
        agent.reset(gym.make("contour_gym/Feedrate-Corner-v0"))


def test_adapter_full_info_equals_dummy_infos():
    native = make_native_vec_env(CCC, 2, full_info=True, decision_ticks=250)
    dummy = DummyVecEnv([lambda: gym.make(CCC, decision_ticks=250) for _ in range(2)])
    for venv in (native, dummy):
        venv.seed(3)
        venv.reset()
    action = np.zeros((2, 3), dtype=np.float32)
    for _ in range(3):
        _, _, _, infos_a = native.step(action)
        _, _, _, infos_d = dummy.step(action)
        for a, d in zip(infos_a, infos_d, strict=True):
            assert a.keys() == d.keys()
            np.testing.assert_array_equal(a["tracking_error"], d["tracking_error"])
            assert a["reward_components"] == d["reward_components"]


def test_training_is_deterministic(tmp_path):
    runs = [_tiny(tmp_path / name, seed=seed) for name, seed in (("a", 0), ("b", 0), ("c", 1))]
    models = [algo_class("ppo").load(run / "model.zip") for run in runs]
    weights = [[p.detach() for p in m.policy.parameters()] for m in models]
    assert all(torch.equal(p, q) for p, q in zip(weights[0], weights[1], strict=True))
    assert not all(torch.equal(p, q) for p, q in zip(weights[0], weights[2], strict=True))
    curves = [read_curve(run / "eval.csv") for run in runs[:2]]
    assert curves[0][-1]["max_contour_error_um"] == curves[1][-1]["max_contour_error_um"]


def test_run_folder_holds_config_args_model_stats_curve_and_logs(tmp_path):
    run = _tiny(tmp_path, steps=128, eval_every=64, checkpoint_every=64)
    for name in ("config.yml", "args.yml", "model.zip", "vecnormalize.pkl", "eval.csv", "eval.png"):
        assert (run / name).is_file(), name
    assert list((run / "tensorboard").rglob("events.out.tfevents.*"))
    assert [int(r["timesteps"]) for r in read_curve(run / "eval.csv")] == [64, 128]
    assert latest_checkpoint(run).name == "model_128_steps.zip"
    # the resolved config is an rl-zoo block that loads back
    assert load_config("ppo", CCC, run / "config.yml").n_timesteps == 128


def test_interrupt_saves_and_resume_continues_the_step_count(tmp_path, monkeypatch):
    evaluate = rl_train.EvalCurve.evaluate

    def interrupt(self, model):
        if model.num_timesteps < 256:
            raise KeyboardInterrupt
        return evaluate(self, model)

    monkeypatch.setattr(rl_train.EvalCurve, "evaluate", interrupt)
    with pytest.raises(KeyboardInterrupt):
        _tiny(tmp_path, "sac", steps=256, eval_every=128)
    run = next(tmp_path.iterdir())
    assert (run / "model.zip").is_file() and (run / "vecnormalize.pkl").is_file()
    checkpoint = latest_checkpoint(run)
    assert checkpoint.name == "model_128_steps.zip"
    assert checkpoint.with_name("replay_buffer_128_steps.pkl").is_file()
    config = load_config("sac", CCC, run / "config.yml")
    restored = load_checkpoint(run, config, checkpoint, seed=0)
    saved = algo_class("sac").load(run / "model.zip")
    assert restored.num_timesteps == saved.num_timesteps == 128
    # SB3 stores a step's transitions after the callbacks: the checkpoint's step is not in it
    assert restored.replay_buffer.size() == 128 // 4 - 1
    stats = restored.get_vec_normalize_env().obs_rms  # one flat Box (FlattenObservation)
    assert stats.count > 128  # the saved statistics, not a fresh start (count 1e-4)

    monkeypatch.setattr(rl_train.EvalCurve, "evaluate", evaluate)
    # a row of steps the checkpoint does not hold (a run killed after evaluating at 200)
    rl_train.append_row(run / "eval.csv", {k: 200.0 for k in rl_train.EVAL_COLUMNS})
    train(resume=run, progress=False)
    assert algo_class("sac").load(run / "model.zip").num_timesteps == 256
    assert latest_checkpoint(run).name == "model_256_steps.zip"
    assert [int(r["timesteps"]) for r in read_curve(run / "eval.csv")] == [256]


def _bad_config(tmp_path, key, value):
    block = yaml.safe_load((REPO / "configs/rl/ppo.yml").read_text())[CCC]
    block[key] = value
    path = tmp_path / "bad.yml"
    path.write_text(yaml.safe_dump({CCC: block}))
    return path


@pytest.mark.parametrize(
    "key, value",
    [
        ("n_envs", "four"),
        ("policy_kwargs", "dict(net_arch=[64, 64])"),
        ("n_stepz", 8),
        ("batch_size", 6.5),
        ("normalize", {"norm_obs": "yes please"}),
    ],
)
def test_bad_yaml_is_a_clear_error_before_any_work(tmp_path, key, value):
    config = _bad_config(tmp_path, key, value)
    with pytest.raises(ValueError) as err:
        train(CCC, "ppo", config_file=config, out_dir=tmp_path / "runs", progress=False)
    message = str(err.value)
    assert str(config) in message and CCC in message and key in message
    assert not (tmp_path / "runs").exists()


def test_unknown_algo_and_env_id_are_rejected(tmp_path):
    with pytest.raises(ValueError, match="unknown RL algorithm 'dqn'; accepted: .*ppo.*sac.*td3"):
        algo_class("dqn")
    with pytest.raises(ValueError, match="CCC-Nowhere-v0"):
        train("contour_gym/CCC-Nowhere-v0", "ppo", out_dir=tmp_path)


@pytest.mark.parametrize("algo", ["ppo", "sac", "td3"])
def test_shipped_configs_cover_every_id_and_the_agent_list_loads(algo):
    for env_id in ENV_IDS:
        config = load_config(algo, env_id)
        assert config.normalize is not None and config.block["policy"] == "MlpPolicy"
        assert rl_train.flattens(config)  # env_wrapper FlattenObservation
    for entry in load_shipped().values():
        load_config(entry["algo"], entry["env_id"])


def test_each_shipped_agents_meta_file_follows_its_entry():
    """A shipped folder's meta.yaml is what train_shipped writes from its entry: the env it acts
    in is the training env updated with act_env_kwargs, and the command reproduces it."""
    trained = Path(__file__).resolve().parent.parent / "agents" / "trained"
    for name, entry in load_shipped().items():
        meta = yaml.safe_load((trained / name / "meta.yaml").read_text(encoding="utf-8"))
        env = entry.get("env_kwargs") or {}
        assert meta["algo"] == entry["algo"] and meta["env_id"] == entry["env_id"], name
        assert meta["env_kwargs"] == {**env, **entry.get("act_env_kwargs", {})}, name
        assert meta.get("trained_env_kwargs", env) == env, name
        assert meta["command"] == f"python -m agents.rl.train_shipped {name}", name


def test_rl_zoo3_trains_from_the_shipped_yaml(tmp_path):
    pytest.importorskip("rl_zoo3", reason="rl_zoo3 is not installed (pip install '.[zoo]')")
    command = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", CCC,
               "--gym-packages", "contour_gym", "--conf-file", "configs/rl/ppo.yml",
               "-n", "300", "-f", str(tmp_path), "--seed", "0"]
    done = subprocess.run(command, cwd=REPO, capture_output=True, text=True, env=os.environ,
                          timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    models = list(tmp_path.rglob("*.zip"))
    assert models, done.stdout[-2000:]
    assert algo_class("ppo").load(models[0]).num_timesteps >= 300


@pytest.fixture(scope="module")
def agent_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("agents")
    run = _tiny(root / "runs", steps=128)
    return export_agent(run, root / "trained" / "tiny_ccc_agent", "pytest")


def test_saved_agent_loads_by_path_and_predicts_single_and_batched(agent_dir):
    agent = SavedAgent(agent_dir)
    # its training env's kwargs, with the observation of its id (v0 here)
    assert agent.env_id == CCC and agent.env_kwargs == {"decision_ticks": 50, "observation": "v0"}
    venv = gym.make_vec(CCC, num_envs=3, vectorization_mode="vector_entry_point",
                        **agent.env_kwargs)
    agent.reset(venv)
    obs, _ = venv.reset(seed=0)
    batch, _ = agent.predict(obs)
    single, _ = agent.predict({k: v[1] for k, v in obs.items()})
    assert batch.shape == (3, 3) and single.shape == (3,)
    np.testing.assert_array_equal(single, batch[1])
    np.testing.assert_array_equal(agent.act(obs), batch)
    assert np.all(np.abs(batch) <= 1.0)


def test_a_saved_agent_acts_on_each_member_as_it_does_alone(agent_dir):
    """torch rounds a batch's products by its size; the agent acts row by row (by_rows)."""
    agent = SavedAgent(agent_dir)
    venv = gym.make_vec(CCC, num_envs=7, vectorization_mode="vector_entry_point",
                        **agent.env_kwargs)
    agent.reset(venv)
    obs, _ = venv.reset(seed=0)
    obs = {k: v * np.random.default_rng(1).uniform(0.5, 2.0, v.shape) for k, v in obs.items()}
    batch = agent.act(obs)
    for i in range(7):
        np.testing.assert_array_equal(agent.act({k: v[i : i + 1] for k, v in obs.items()})[0],
                                      batch[i])
    kwargs = {"id": CCC, **agent.env_kwargs, "randomize": True}
    together = evaluate(agent, kwargs, n_episodes=3, seed=4)["episodes"]
    assert together == [run_policy(kwargs, agent, seed=4 + i) for i in range(3)]


def test_a_saved_agent_runs_on_a_users_env_instance(agent_dir):
    """evaluate(agent, env) on a single env the user made gives what the env's kwargs give
    (the agent checks the env's spaces at reset: the single env runs as a vector env of one)."""
    agent = SavedAgent(agent_dir)
    env = gym.make(CCC, **agent.env_kwargs)
    mine = evaluate(agent, env, n_episodes=2, seed=4)["episodes"]
    assert mine == evaluate(agent, {"id": CCC, **agent.env_kwargs}, n_episodes=2,
                            seed=4)["episodes"]
    env.close()


def test_saved_agents_share_a_model_until_its_file_changes(agent_dir, tmp_path):
    first, second = SavedAgent(agent_dir), SavedAgent(agent_dir)
    assert first.model is second.model  # read once per process
    assert first.normalizer is not None and first.normalizer is second.normalizer
    copy = tmp_path / "copy"
    shutil.copytree(agent_dir, copy)
    before = SavedAgent(copy)
    assert before.model is not first.model  # another file (read now, when first asked for)
    model = copy / "model.zip"
    os.utime(model, ns=(model.stat().st_atime_ns, model.stat().st_mtime_ns + 10**9))
    after = SavedAgent(copy)
    assert after.model is not before.model  # rewritten: read again


def test_saved_agent_acts_as_the_fully_loaded_model(agent_dir):
    # loaded to act (no optimizer): the same weights and actions as stable-baselines3's load
    agent = SavedAgent(agent_dir)
    full = algo_class("ppo").load(agent_dir / "model.zip", device="cpu")
    for name, tensor in full.policy.state_dict().items():
        assert torch.equal(agent.model.policy.state_dict()[name], tensor), name
    venv = gym.make_vec(CCC, num_envs=2, vectorization_mode="vector_entry_point",
                        **agent.env_kwargs)
    plain = SB3Policy(full, agent.normalizer, agent.env_kwargs)
    agent.reset(venv)
    plain.reset(venv)
    obs, _ = venv.reset(seed=1)
    np.testing.assert_array_equal(agent.act(obs), plain.act(obs))


def _random_obs(space, batch, rng):
    if hasattr(space, "spaces"):
        return {k: _random_obs(s, batch, rng) for k, s in space.spaces.items()}
    return (3.0 * rng.normal(size=(batch, *space.shape))).astype(np.float32)


def _models():
    # every shipped agent's model, a Dict-observation PPO, one with gSDE, an A2C, and a SAC
    # (which has no shortcut)
    for name in SHIPPED:
        yield name, SavedAgent(REPO / "agents" / "trained" / name).model
    feed = gym.make("contour_gym/Feedrate-Corner-v0")
    yield "ppo_dict", algo_class("ppo")("MultiInputPolicy", feed, device="cpu", seed=0)
    yield "ppo_gsde", algo_class("ppo")("MultiInputPolicy", feed, use_sde=True, device="cpu",
                                        seed=0)
    yield "a2c", algo_class("a2c")("MultiInputPolicy", feed, device="cpu", seed=0)
    yield "sac", algo_class("sac")("MultiInputPolicy", feed, device="cpu", seed=0)


def test_the_mean_action_shortcut_equals_predict_bit_for_bit():
    rng = np.random.default_rng(0)
    for name, model in _models():
        fast = mean_actions(model)
        if name == "sac":
            assert fast is None  # an off-policy actor: predict acts
            continue
        assert fast is not None, name
        for batch in (1, 5):
            obs = _random_obs(model.observation_space, batch, rng)
            model.policy.set_training_mode(True)  # as a training run leaves it: set back
            got = fast(obs)
            want, _ = by_rows(model, obs, batch)  # predict on each row alone
            assert got.dtype == np.float64 and got.shape == (batch, *model.action_space.shape)
            np.testing.assert_array_equal(got, want, err_msg=name)
            assert not model.policy.training


def test_a_policy_given_a_new_model_checks_envs_against_the_new_one(agent_dir):
    agent = SavedAgent(agent_dir)
    plain = SB3Policy(agent.model, agent.normalizer, agent.env_kwargs)
    env = gym.make(CCC, **agent.env_kwargs)
    plain.reset(env)  # fits: the agent's own training env
    other = algo_class("ppo")("MultiInputPolicy", gym.make("contour_gym/Feedrate-Corner-v0"),
                              device="cpu")
    plain.model = other  # a model of another observation: the checks read it afresh
    with pytest.raises(ValueError, match="observes"):
        plain.reset(env)


def test_an_agent_not_read_yet_reads_its_model_after_pickling(agent_dir):
    # an agent sent to another process before it acted (a Ray task, a worker) reads it there
    agent = SavedAgent(agent_dir)
    copy = pickle.loads(pickle.dumps(agent))
    venv = gym.make_vec(CCC, num_envs=2, vectorization_mode="vector_entry_point",
                        **agent.env_kwargs)
    agent.reset(venv)
    copy.reset(venv)
    obs, _ = venv.reset(seed=2)
    np.testing.assert_array_equal(copy.act(obs), agent.act(obs))


def test_an_agent_reads_its_model_when_first_needed_without_torch_dynamo(agent_dir):
    # made, it has not imported torch (a suite makes every policy to check it); read to act,
    # no torch._dynamo (torch's optimizers import it when first made: ~1 s of a start)
    code = ("import sys; from agents.rl.saved import SavedAgent; "
            f"agent = SavedAgent({str(agent_dir)!r}); print('torch' in sys.modules); "
            "agent.model; print('torch' in sys.modules, 'torch._dynamo' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                          text=True, check=True)
    assert done.stdout.split() == ["False", "True", "False"]


def test_saved_agent_registers_by_name(agent_dir):
    names = register_saved_agents(agent_dir.parent)
    try:
        assert names == ["tiny_ccc_agent"] and "tiny_ccc_agent" in policies.available()
        env = gym.make(CCC, decision_ticks=50)
        assert isinstance(policies.make("tiny_ccc_agent", env), SavedAgent)
    finally:
        policies.POLICIES.unregister("tiny_ccc_agent")


def test_saved_agent_on_an_env_it_does_not_fit_names_both_shapes(agent_dir):
    agent = SavedAgent(agent_dir)
    with pytest.raises(ValueError, match=r"flat Box of 14.*'feedrate': \(2,\)"):
        agent.reset(gym.make("contour_gym/Feedrate-Corner-v0"))
    with pytest.raises(ValueError, match="observes"):
        agent.predict({"feedrate": np.zeros(2)})


def test_saved_agent_without_model_file_names_the_path(agent_dir, tmp_path):
    broken = tmp_path / "broken_agent"
    broken.mkdir()
    (broken / "meta.yaml").write_text((agent_dir / "meta.yaml").read_text())
    with pytest.raises(ValueError, match=str(broken / "model.zip")):
        SavedAgent(broken)


SHIPPED = sorted(p.name for p in (REPO / "agents" / "trained").iterdir() if p.is_dir())
USER_PART = """G21 G90 G17
G1 X10 Y0 F600
G3 X20 Y10 R10 F900
G1 Y20
M2
"""


def test_the_shipped_agents_are_listed_by_available():
    assert SHIPPED, "no shipped agent under agents/trained"
    assert set(SHIPPED) <= set(policies.available())


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_agent_loads_by_name_and_runs_a_user_path(name):
    from agents.evaluate import run_policy
    from contour_gym.paths import from_gcode, parametric

    agent = policies.make(name)
    meta = yaml.safe_load((REPO / "agents" / "trained" / name / "meta.yaml").read_text())
    curve = parametric(lambda t: np.stack([0.02 * t, 0.0025 * np.sin(2 * np.pi * t)], 1),
                       0.0, 1.0)
    if "Feedrate" in meta["env_id"]:
        spec = {"id": "contour_gym/Feedrate-v0", "plant": "xy_servo_coulomb",
                "path": from_gcode(USER_PART)}
    else:
        kw = agent.env_kwargs  # an agent acts with the estimator it trained with
        spec = {"id": "contour_gym/CCC-v0", "plant": kw.get("plant", "xy_dc_servo"),
                "path": curve, "estimator": kw.get("estimator", "two_circle")}
    m = run_policy(spec, agent)
    assert m["finished"] and not m["failed"] and not m["truncated"]
    assert np.isfinite(m["max_contour_error"])


def test_an_agent_trained_flat_on_random_paths_acts_on_the_v1_observation(tmp_path):
    """Trained on -v1 with a new random path per episode, the flat agent acts on any path's
    observation (issue 26), single and batched."""
    run = train("contour_gym/CCC-Circle-v1", "ppo", 128, seed=0, out_dir=tmp_path,
                progress=False, eval_episodes=2, eval_every=128,
                **{**TINY_PPO, "env_kwargs": {"decision_ticks": 50, "path": "random"}})
    agent = SavedAgent(export_agent(run, tmp_path / "general", "test"))
    # it keeps its interface (the v1 observation), not its world of paths
    assert agent.env_kwargs == {"decision_ticks": 50, "observation": "v1"}
    # exported to act in another env than its training one: both in its meta file
    acting = SavedAgent(export_agent(run, tmp_path / "acting", "test", {"decision_ticks": 40}))
    assert acting.env_kwargs == {"decision_ticks": 40, "observation": "v1"}
    assert acting.meta["trained_env_kwargs"] == {"decision_ticks": 50, "path": "random"}
    venv = gym.make_vec("contour_gym/CCC-v1", num_envs=2, decision_ticks=50, path="random")
    agent.reset(venv)
    obs, _ = venv.reset(seed=7)
    assert "progress" not in obs and "corner" in obs
    actions, _ = agent.predict(obs)
    assert actions.shape == (2, 3) and np.all(np.abs(actions) <= 1.0)
    venv.close()
