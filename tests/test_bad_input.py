"""Bad input and faults: clear errors, flagged failures, nothing a user made is lost."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

import contour_gym
from agents.cli import main
from agents.tune import tune
from contour_gym.contour import ESTIMATORS
from contour_gym.envs import CCCEnv
from contour_gym.paths import from_gcode

CIRCLE = "000_circle"
FINISHED = {"status": "complete", "protocol": CIRCLE, "fitness": 1e-6, "params": {"k_e": 1.0}}


def _finished(folder: Path) -> bytes:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "result.json").write_text(json.dumps(FINISHED))
    return (folder / "result.json").read_bytes()


@pytest.mark.parametrize(
    "extra",
    [[], ["--population", "0"], ["--iterations", "0"], ["--population", "3", "--seed", "2"],
     ["--optimizer", "no_such_optimizer"]],
)
def test_tune_never_replaces_a_finished_result(tmp_path: Path, capsys, extra: list[str]) -> None:
    before = _finished(tmp_path / "run")
    code = main(["tune", CIRCLE, "--out", str(tmp_path / "run"), "--quiet", *extra])
    assert code == 2
    assert (tmp_path / "run" / "result.json").read_bytes() == before
    err = capsys.readouterr().err
    assert "finished" in err or "must be" in err or "no_such_optimizer" in err


def test_tune_names_a_bad_run_folder(tmp_path: Path) -> None:
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        tune(CIRCLE, population=2, iterations=1, out=tmp_path / "file", progress=False)
    (tmp_path / "corrupt").mkdir()
    (tmp_path / "corrupt" / "result.json").write_text('{"status": "compl')
    with pytest.raises(ValueError, match=r"corrupt.result\.json cannot be read"):
        tune(CIRCLE, population=2, iterations=1, out=tmp_path / "corrupt", progress=False)
    for bad in (0, 1.5, True, "3"):
        with pytest.raises(ValueError, match="population must be an int"):
            tune(CIRCLE, population=bad, iterations=0, out=tmp_path / "new", progress=False)
    assert not (tmp_path / "new").exists()


def test_tune_replaces_an_unfinished_result_and_overwrites_when_told(tmp_path: Path) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "result.json").write_text(json.dumps({"status": "interrupted"}))
    tune(CIRCLE, population=2, iterations=1, out=folder, progress=False)
    first = json.loads((folder / "result.json").read_text())
    assert first["status"] == "complete"
    with pytest.raises(ValueError, match="finished"):
        tune(CIRCLE, population=2, iterations=1, out=folder, progress=False, seed=1)
    tune(CIRCLE, population=2, iterations=1, out=folder, progress=False, seed=1, overwrite=True)
    assert json.loads((folder / "result.json").read_text())["seed"] == 1


@pytest.mark.parametrize("action", [np.array([1j, 0, 0]), np.array([0.1 + 0j, 0, 0])])
def test_actions_must_be_real(action: np.ndarray) -> None:
    env = CCCEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="real"):
        env.step(action)


@pytest.mark.parametrize("seed", [1.5, "1", [1, 2], -1])
def test_simulate_names_a_bad_seed(seed: object) -> None:
    with pytest.raises(ValueError, match="seed"):
        contour_gym.simulate(plant="xy_dc_servo", seed=seed)


@pytest.mark.parametrize("digit", ["\u0661", "\u00b2", "\uff11", "\u0967"])
def test_gcode_numbers_are_ascii(digit: str) -> None:
    with pytest.raises(ValueError, match="line 2"):
        from_gcode(f"G1 X0 Y0 F600\nG1 X{digit}0 Y0\n")


@pytest.mark.parametrize("name", sorted(ESTIMATORS.names()))
def test_every_estimator_rejects_a_misspelt_option(name: str) -> None:
    with pytest.raises(ValueError, match="half_widht"):
        contour_gym.simulate(plant="xy_dc_servo", estimator=name,
                             estimator_options={"half_widht": 2})


def test_a_run_cut_off_by_its_time_cap_is_a_failure_with_its_reason(tmp_path: Path, capsys) -> None:
    m = contour_gym.simulate(plant="xy_dc_servo", max_time=0.05)
    assert m["failed"] == 1.0 and m["finished"] == 0.0 and m["failure_reason"] == 4.0
    from contour_gym.loop import REASON_NAMES

    assert "time cap" in REASON_NAMES[m["failure_reason"]]
    ok = contour_gym.simulate(plant="xy_dc_servo")
    assert ok["failed"] == 0.0 and ok["failure_reason"] == 0.0 and ok["finished"] == 1.0


def test_a_program_without_f_words_is_refused_or_given_a_default_feed(tmp_path: Path, capsys):
    part = tmp_path / "part.nc"
    part.write_text("G0 X0 Y0\nG1 X10 Y0\nG1 X10 Y10\n")
    out = str(tmp_path / "p.png")
    assert main(["simulate", "--gcode", str(part), "--out", out]) == 2
    assert "line 2: a feed move before any F word" in capsys.readouterr().err
    assert main(["simulate", "--gcode", str(part), "--out", out, "--default-feed", "600"]) == 0


def test_a_vector_env_takes_a_list_of_seeds() -> None:
    from contour_gym.envs import CCCVectorEnv

    venv = CCCVectorEnv(num_envs=2, decision_ticks=50)
    listed, _ = venv.reset(seed=[3, 4])
    ranged, _ = venv.reset(seed=3)  # member i gets 3 + i: the same seeds
    for key in listed:
        np.testing.assert_array_equal(listed[key], ranged[key])
    venv.reset(seed=[5, None])
    for bad, match in (([1, 2, 3], "2 seeds"), ([1, -2], "non-negative"), (1.5, "non-negative"),
                       (["a", 1], "non-negative")):
        with pytest.raises(ValueError, match=match):
            venv.reset(seed=bad)


def test_axis_gains_as_mappings_or_a_named_error() -> None:
    gains = [{"kp": 2.0e3, "ki": 2.0e4, "kd": 15.0}] * 2
    as_dicts = contour_gym.simulate(plant={"preset": "xy_dc_servo", "axis_gains": gains})
    from contour_gym.servo import PIDGains

    typed = contour_gym.simulate(plant={"preset": "xy_dc_servo",
                                        "axis_gains": [PIDGains(**g) for g in gains]})
    assert as_dicts == typed
    for bad, match in (([{"kp": 1.0, "kq": 2.0}] * 2, r"axis_gains\[0\] needs kp"),
                       ([{"ki": 1.0}] * 2, "needs kp"), ([1.0, 2.0], "must be a PIDGains")):
        with pytest.raises(ValueError, match=match):
            contour_gym.simulate(plant={"preset": "xy_dc_servo", "axis_gains": bad})


def test_an_unknown_policy_kwargs_key_is_named_before_any_run_folder() -> None:
    from agents.rl.config import check_block

    block = {"n_timesteps": 1000, "policy": "MultiInputPolicy",
             "policy_kwargs": {"net_arch": [8], "net_archh": [8]}}
    with pytest.raises(ValueError, match="policy_kwargs: unknown argument.*'net_archh'"):
        check_block("ppo", "contour_gym/CCC-v0", block, "ppo.yml")
    check_block("ppo", "contour_gym/CCC-v0", {**block, "policy_kwargs": {"net_arch": [8]}},
                "ppo.yml")


@pytest.mark.parametrize("command", [["bench", "--suite", "tiny", "--quiet"],
                                     ["tune", CIRCLE, "--population", "2", "--quiet"]])
def test_out_on_a_file_is_an_error_naming_it(tmp_path: Path, capsys, command: list[str]) -> None:
    target = tmp_path / "taken"
    target.write_text("mine")
    assert main([*command, "--out", str(target)]) in (1, 2)
    assert str(target) in capsys.readouterr().err
    assert target.read_text() == "mine"


def test_an_env_episode_that_fails_says_why() -> None:
    from contour_gym.loop import REASON_NAMES

    env = CCCEnv(tolerance=1e-7, hard_limit=2e-7, decision_ticks=50)
    env.reset(seed=0)
    term = False
    while not term:
        _, _, term, trunc, info = env.step(np.zeros(3))
        assert not trunc
    assert info["failure"] and info["metrics"]["failure_reason"] == 5.0
    assert "hard limit" in REASON_NAMES[info["metrics"]["failure_reason"]]


def test_a_run_too_long_for_time_or_memory_is_refused_before_it_starts() -> None:
    from contour_gym.api import make_scenario, run_trace

    with pytest.raises(ValueError, match="ticks, more than a run may take"):
        contour_gym.simulate(plant="xy_dc_servo", max_time=1e9)
    with pytest.raises(ValueError, match=r"recording it needs .* GiB"):
        run_trace(make_scenario("xy_dc_servo", feedrate=1e-5), None)  # 3e7 ticks recorded


@pytest.mark.parametrize("preset", ["xy_dc_servo", "xyz_pmlsm", "lugre_linear_motor",
                                    "xyy_gantry", "xy_servo_coulomb"])
def test_every_preset_has_travel_and_refuses_a_path_beyond_it(preset: str) -> None:
    from contour_gym.presets import get_preset

    stage = get_preset(preset).stage
    assert all(a.travel is not None for a in stage.axes) and "Travel" in stage.notes
    z = " Z0" if stage.dim == 3 else ""
    with pytest.raises(ValueError, match=r"G-code line 2: the path reaches x = .* outside"):
        contour_gym.simulate(plant=preset, path=from_gcode(f"G1 X0 Y0{z} F600\nG1 X900"))


@pytest.mark.parametrize(
    ("program", "line", "axis"),
    [("G1 X10 Y0 F600\nG1 X99999999999\n", 2, "x"),
     ("G1 X10 F600\nG1 Y10\nG2 X10 Y-170 R-90\n", 3, "y"),
     ("G1 X0 Y0 F600\nG0 X-160\n", 2, "x")],
)
def test_a_program_beyond_the_travel_names_its_line_and_axis(program: str, line: int,
                                                             axis: str) -> None:
    with pytest.raises(ValueError, match=rf"G-code line {line}: the path reaches {axis} ="):
        contour_gym.simulate(plant="xy_dc_servo", path=from_gcode(program))


def test_train_shipped_refuses_a_trained_agent_before_training(tmp_path: Path, monkeypatch):
    from agents.rl import train_shipped as ts

    name = next(iter(ts.load_shipped()))
    (tmp_path / name).mkdir()
    (tmp_path / name / ts.MODEL_FILE).write_bytes(b"mine")
    monkeypatch.setattr(ts, "train", lambda *a, **k: pytest.fail("trained before refusing"))
    with pytest.raises(ValueError, match="holds a trained agent; pass --overwrite"):
        ts.train_shipped(name, tmp_path / "runs", tmp_path, progress=False)
    assert (tmp_path / name / ts.MODEL_FILE).read_bytes() == b"mine"


def test_a_tune_run_killed_mid_way_restarts_to_the_same_result(tmp_path: Path) -> None:
    # a killed tune leaves its last partial result.json ("running"): the rerun replaces it and
    # gives what an uninterrupted run gives, bit for bit
    clean = tune(CIRCLE, population=3, iterations=2, out=tmp_path / "clean", progress=False)
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / "result.json").write_text(json.dumps({"status": "running", "history": [1.0]}))
    again = tune(CIRCLE, population=3, iterations=2, out=killed, progress=False)
    assert again.params == clean.params and again.fitness == clean.fitness
    assert json.loads((killed / "result.json").read_text())["status"] == "complete"


def test_train_with_a_misspelt_policy_kwargs_key_makes_no_run_folder(tmp_path: Path, capsys):
    config = tmp_path / "ppo.yml"
    config.write_text("contour_gym/CCC-v0:\n  n_timesteps: 64\n  policy: MultiInputPolicy\n"
                      "  policy_kwargs: {net_archh: [8]}\n")
    runs = tmp_path / "runs"
    code = main(["train", "contour_gym/CCC-v0", "--config", str(config), "--out", str(runs),
                 "--quiet"])
    assert code == 2 and "net_archh" in capsys.readouterr().err
    assert not runs.exists()


def test_a_nanosecond_servo_period_is_refused_at_once() -> None:
    with pytest.raises(ValueError, match="ticks, more than a run may take"):
        contour_gym.simulate(plant={"preset": "xy_dc_servo", "stage": {"ts": 1e-9}})


def test_a_full_disk_is_one_line_naming_the_file(tmp_path: Path, monkeypatch, capsys) -> None:
    import errno

    from agents.tune import runner as tune_module

    def full(target: Path, data: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device", str(target))

    monkeypatch.setattr(tune_module, "_write_json", full)
    out = tmp_path / "run"
    assert main(["tune", CIRCLE, "--population", "2", "--iterations", "1", "--out", str(out),
                 "--quiet"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == f"contour-gym: error: {out / 'result.json'}: No space left on device"


def _killed_when(code: str, ready, timeout: float = 300.0) -> None:
    # run `code` in a fresh interpreter and SIGKILL it once ready() holds (it must still run)
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + timeout
    try:
        while not ready():
            assert proc.poll() is None, "the run ended before it could be killed"
            assert time.monotonic() < deadline, "the run never got ready"
            time.sleep(0.02)
    finally:
        proc.kill()
        proc.wait()


def test_bench_killed_by_sigkill_resumes_to_the_same_table(tmp_path: Path) -> None:
    from agents.bench import run_suite

    clean = run_suite("tiny", tmp_path / "clean", progress=False)
    out = tmp_path / "killed"
    cells = out / "cells"
    code = f"from agents.bench import run_suite; run_suite('tiny', {str(out)!r}, progress=False)"
    _killed_when(code, lambda: cells.exists() and any(cells.rglob("*.json")))
    assert not (out / "results.csv").exists()  # killed mid-run
    again = run_suite("tiny", out, progress=False)
    assert 0 < len(again.computed) < len(clean.computed)  # finished cells were kept
    assert (out / "results.csv").read_text() == (tmp_path / "clean" / "results.csv").read_text()


def test_train_killed_by_sigkill_resumes_from_its_checkpoint(tmp_path: Path) -> None:
    from agents.rl.saved import MODEL_FILE
    from agents.rl.train import algo_class, latest_checkpoint, train

    tiny = {"n_envs": 4, "env_kwargs": {"decision_ticks": 50}, "policy_kwargs": {"net_arch": [8]},
            "n_steps": 32, "batch_size": 64, "n_epochs": 1}
    code = (f"from agents.rl.train import train; train('contour_gym/CCC-Circle-v0', 'ppo', 4096, "
            f"out_dir={str(tmp_path)!r}, progress=False, eval_episodes=1, eval_every=4096, "
            f"checkpoint_every=128, **{tiny!r})")
    _killed_when(code, lambda: any(tmp_path.rglob("model_256_steps.zip")))
    run = next(p for p in tmp_path.iterdir() if p.is_dir())
    assert not (run / MODEL_FILE).exists() and latest_checkpoint(run) is not None
    (run / ".eval.png.k1ll3d.tmp").write_bytes(b"")  # a write the kill cut short, as it can
    train(resume=run, progress=False)
    assert algo_class("ppo").load(run / MODEL_FILE).num_timesteps == 4096
    assert not list(run.rglob(".*.tmp"))  # no half-written file outlives the resume


@pytest.mark.parametrize(
    ("args_yml", "config_yml", "checkpoint", "match"),
    [("algo: ppo\nenv_id: [", "x", None, r"args\.yml cannot be read"),
     ("algo: ppo\n", "x", None, r"args\.yml must map algo"),
     ("algo: ppo\nenv_id: contour_gym/CCC-v0\nseed: 0\ntotal_timesteps: 64\n",
      "contour_gym/CCC-v0: {n_timesteps: 64", None, r"config\.yml: cannot read the config"),
     ("algo: ppo\nenv_id: contour_gym/CCC-v0\nseed: 0\ntotal_timesteps: 64\n",
      "contour_gym/CCC-v0: {n_timesteps: 64, policy: MultiInputPolicy}\n", b"PK\x03\x04cut",
      r"model_32_steps\.zip .* cannot be loaded")],
)
def test_resuming_a_damaged_run_names_the_file(tmp_path: Path, capsys, args_yml: str,
                                               config_yml: str, checkpoint: bytes | None,
                                               match: str) -> None:
    run = tmp_path / "run"
    run.mkdir()
    (run / "args.yml").write_text(args_yml)
    (run / "config.yml").write_text(config_yml)
    if checkpoint is not None:
        (run / "checkpoints").mkdir()
        (run / "checkpoints" / "model_32_steps.zip").write_bytes(checkpoint)
    assert main(["train", "--resume", str(run), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(match, err[0])


@pytest.mark.parametrize(("steps", "resumed"), [(64, True), (128, False)])
def test_train_shipped_resumes_an_unfinished_run_and_exports_a_finished_one(
    tmp_path: Path, monkeypatch, steps: int, resumed: bool
) -> None:
    from agents.rl import train_shipped as ts
    from agents.rl.train import run_name

    name, entry = next(iter(ts.load_shipped().items()))
    run = tmp_path / "runs" / name / run_name(entry["env_id"], entry["algo"], entry.get("seed", 0))
    (run / "checkpoints").mkdir(parents=True)
    (run / "args.yml").write_text(f"algo: {entry['algo']}\nenv_id: {entry['env_id']}\nseed: 0\n"
                                  "total_timesteps: 128\n")
    (run / "checkpoints" / f"model_{steps}_steps.zip").write_bytes(b"")
    calls: list[object] = []
    monkeypatch.setattr(ts, "train", lambda *a, **k: calls.append(k.get("resume")) or run)
    monkeypatch.setattr(ts, "export_agent", lambda r, dest, command, act=None: dest)
    dest = ts.train_shipped(name, tmp_path / "runs", tmp_path / "agents", progress=False)
    assert dest == tmp_path / "agents" / name
    assert calls == ([run] if resumed else [])


def test_a_path_well_inside_the_travel_is_passed_without_evaluating_it(monkeypatch) -> None:
    from contour_gym.paths import Path as PathClass
    from contour_gym.paths import load
    from contour_gym.presets import get_preset

    path = load("circle_r10")
    monkeypatch.setattr(type(path), "point", lambda *a, **k: pytest.fail("evaluated"))
    assert isinstance(path, PathClass)
    get_preset("xy_dc_servo").stage.check_travel(path)  # bounding spheres suffice


# ------------------------------------------------------------------ issue 63: silently wrong
@pytest.mark.parametrize("options", [{"bogus": 1}, {"reset_mask": None, "seed": 3}])
def test_unknown_reset_options_are_refused_by_name(options: dict[str, object]) -> None:
    from contour_gym.envs import CCCVectorEnv

    env = CCCEnv()
    with pytest.raises(ValueError, match=r"unknown reset option.*: it takes keep_paths$"):
        env.reset(seed=0, options=options)
    venv = CCCVectorEnv(num_envs=2)
    with pytest.raises(ValueError, match=r"option\(s\) \['(bogus|seed)'\]: it takes reset_mask"):
        venv.reset(seed=0, options=options)
    env.reset(seed=0, options={})  # nothing asked: fine


def test_a_program_with_a_byte_order_mark_reads_as_without(tmp_path: Path) -> None:
    text = "G21 G90\nG1 X10 Y0 F600\nG1 X10 Y10\n"
    plain = from_gcode(text)
    marked = from_gcode("\ufeff" + text)
    np.testing.assert_array_equal(marked.table.data, plain.table.data)
    part = tmp_path / "bom.nc"
    part.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert main(["simulate", "--gcode", str(part), "--out", str(tmp_path / "p.png")]) == 0


@pytest.mark.parametrize("word, plain", [("F1e12", "1000000000000"), ("X1.5E-3", "0.0015")])
def test_a_number_with_an_exponent_is_refused_as_a_number(word: str, plain: str) -> None:
    with pytest.raises(contour_gym.paths.GcodeError, match=f"{word}: G-code numbers have no "
                                                           f"exponent; write {plain} out"):
        from_gcode(f"G21\nG1 X1 Y1 F600\nG1 {word} Y2\n")


def test_a_program_of_rapids_only_has_nothing_to_cut(tmp_path: Path, capsys) -> None:
    part = tmp_path / "rapids.nc"
    part.write_text("G21\nG0 X10 Y0\nG0 X10 Y10\n")
    assert main(["simulate", "--gcode", str(part), "--out", str(tmp_path / "p.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"{part}: nothing to cut")


def test_a_policy_returning_nan_is_named_with_its_scenario() -> None:
    from agents.evaluate import run_policy
    from agents.policy_base import Policy

    class NanPolicy(Policy):
        name = "my_nan_policy"
        tasks = ("ccc",)

        def act(self, obs):  # type: ignore[no-untyped-def]
            return np.full((len(obs["contour_error"]), 3), np.nan)

    with pytest.raises(ValueError, match=r"policy 'my_nan_policy' returned a non-finite action "
                                         r"\[nan, nan, nan\] at step 0 of member 0 "
                                         r"\(xy_dc_servo on circle_r10\)"):
        run_policy("contour_gym/CCC-v1", NanPolicy())


def test_a_hyperparameter_the_algorithm_refuses_is_named_and_no_run_folder_is_left(
        tmp_path: Path, capsys) -> None:
    argv = ["train", "contour_gym/CCC-v1", "--algo", "ppo", "--timesteps", "256", "--sweep",
            "n_steps=-1", "--out", str(tmp_path / "runs")]
    assert main(argv) == 2
    err = [line for line in capsys.readouterr().err.splitlines()
           if line.startswith("contour-gym: error")]
    assert err == ["contour-gym: error: ppo refuses its hyperparameters: `n_steps * n_envs` "
                   "must be greater than 1. Currently n_steps=-1 and n_envs=16"]
    assert not any((tmp_path / "runs").rglob("args.yml"))


def test_a_run_shorter_than_a_rollout_trains_that_many_steps(tmp_path: Path) -> None:
    from agents.rl.train import read_curve, train

    with pytest.warns(UserWarning, match="256 timesteps is less than one rollout .* this run "
                                         r"collects 16 steps x 16 envs \(n_steps 16, batch_size"):
        run = train("contour_gym/CCC-v1", "ppo", 256, seed=0, out_dir=tmp_path, progress=False)
    rows = read_curve(run / "eval.csv")
    assert rows[-1]["timesteps"] == 256 and len(rows) <= 12
    assert [r["timesteps"] for r in rows] == sorted({r["timesteps"] for r in rows})
