"""Tuning and training on your own machine: ``--plant MACHINE.yaml`` (issue 64, item 4)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from agents.cli import main
from agents.tune import get_protocol, tune
from agents.tune.objective import PopulationObjective
from agents.tune.setters import PID_FACTOR_NAMES, pid_gains
from agents.twin.check import copies_of
from agents.twin.identified import tuning_copies
from contour_gym.api import simulate
from contour_gym.machines import plant_of, undetermined_of, write_machine
from contour_gym.presets import resolve_preset

SLOW = {"preset": "xy_dc_servo", "name": "slow_mill",
        "stage": {"axes": {"x": {"mass": 900.0}, "y": {"mass": 900.0}}}}


def test_pid_factors_scale_the_machines_own_gains() -> None:
    gains = pid_gains([[2.0, 0.5, 0.001], [1.0, 1.0, 0.0]], (100.0, 40.0, 3.0))
    np.testing.assert_allclose(gains, [[200.0, 20.0, 200.0 * (0.03 + 0.001)], [100.0, 40.0, 3.0]])
    with pytest.raises(ValueError, match="its kp is 0.0"):
        pid_gains([[1.0, 1.0, 0.0]], (0.0, 1.0, 0.0))


def test_a_protocol_on_a_machine_runs_every_scenario_there(tmp_path: Path) -> None:
    path = write_machine(tmp_path / "slow.yaml", SLOW)
    plant, name = plant_of(str(path))
    assert (plant, name) == (SLOW, "slow_mill")
    base = get_protocol("pid")
    mine = base.on_plant(plant, name)
    assert mine.name == "pid@slow_mill" and mine.params == base.params
    assert mine.scenario_kwargs["paper"] == {"id": "contour_gym/CCC-v1", "plant": SLOW}
    # the machine's own gains (the reference point) score what simulate gives on that machine
    reference = [mine.reference_point()[n] for n in PID_FACTOR_NAMES]
    objective = PopulationObjective(mine, workers=1)
    try:
        peak = objective.metrics(reference)[0]["max_contour_error"][0]
    finally:
        objective.close()
    gains = resolve_preset(SLOW).ccc_gains
    assert peak == simulate(SLOW, None, ccc_gains=gains)["max_contour_error"]
    assert peak != simulate("xy_dc_servo", None, ccc_gains=gains)["max_contour_error"]


def test_tune_on_a_machine_file_says_the_gains_to_carry(tmp_path: Path, capsys) -> None:
    path = str(write_machine(tmp_path / "slow.yaml", SLOW))
    out = tmp_path / "run"
    assert main(["tune", "pid", "--plant", path, "--population", "4", "--iterations", "1",
                 "--out", str(out), "--quiet"]) == 0
    said = capsys.readouterr().out
    result = json.loads((out / "result.json").read_text())
    assert result["protocol"] == "pid@slow_mill"
    assert result["settings"]["scenario_kwargs"]["paper"]["plant"] == SLOW  # recorded whole
    kp, ki, kd = pid_gains([list(result["params"].values())],
                           resolve_preset(SLOW).ccc_gains.as_tuple())[0]
    assert "on the machine (slow_mill): the CCC law 'pid'" in said
    assert "caution" not in said  # a machine file identify did not write
    assert f"kp = {kp:.6g} control unit/m" in said and f"kd = {kd:.6g} control unit s/m" in said
    # the line to paste into the machine file runs the tuned gains there
    pasted = yaml.safe_load(said.split("add to the machine file: ")[1].splitlines()[0])
    assert resolve_preset({**SLOW, **pasted}).ccc_gains.as_tuple() == pytest.approx(
        (kp, ki, kd), rel=1e-5)
    # the same search through the API on the same machine gives the same result
    again = tune(get_protocol("pid").on_plant(SLOW, "slow_mill"), population=4, iterations=1,
                 progress=False)
    assert again.params == result["params"]


def test_tune_on_a_twin_names_the_values_its_logs_left_open(tmp_path: Path, capsys) -> None:
    record = {"undetermined": {"x": ["damping"], "y": ["mass", "damping"]}}
    path = str(write_machine(tmp_path / "twin.yaml", SLOW, identified=record))
    assert main(["tune", "pid", "--plant", path, "--population", "4", "--iterations", "1",
                 "--out", str(tmp_path / "run"), "--quiet"]) == 0
    said = capsys.readouterr().out
    assert f"caution: the logs {path} was identified from do not determine x.damping, " \
           "y.mass, y.damping" in said
    assert undetermined_of(path) == record["undetermined"]
    assert undetermined_of("xy_dc_servo") == {} and undetermined_of(SLOW) == {}


TWIN = {"preset": "xy_servo_coulomb", "name": "twin",
        "stage": {"axes": {n: {"mass": m, "damping": 40.0,
                               "friction": {"law": "coulomb", "fc": 2.0}}
                           for n, m in (("x", 5.0), ("y", 4.0))}}}
FOUND = {"values": {"x": {"mass": 5.0, "damping": 40.0, "fc": 2.0},
                    "y": {"mass": 4.0, "damping": 40.0, "fc": 2.0}},
         "std": {"x": {"mass": 0.05, "damping": 20.0, "fc": 0.01},
                 "y": {"mass": 0.04, "damping": 4.0, "fc": 0.01}},
         "undetermined": {"x": ["damping"], "y": ["damping"]}}


def test_a_twin_with_undetermined_values_has_copies_within_their_uncertainty() -> None:
    copies = tuning_copies(TWIN, FOUND["values"], FOUND["std"], FOUND["undetermined"], 50)
    assert len(copies) == 50 and copies == tuning_copies(
        TWIN, FOUND["values"], FOUND["std"], FOUND["undetermined"], 50)  # seeded
    assert tuning_copies(TWIN, FOUND["values"], FOUND["std"], {}, 50) == []  # all determined
    factors = np.array([[c["stage"]["axes"][a][k] / TWIN["stage"]["axes"][a][k]
                         for a in ("x", "y") for k in ("mass", "damping")] for c in copies])
    # each value within two of its log-std, which is capped at 0.3 (x's damping: 0.5)
    assert np.all(np.abs(np.log(factors)) <= 2 * np.array([0.01, 0.3, 0.01, 0.1]) + 1e-12)
    assert np.all(np.abs(np.log(factors)).max(axis=0) > [0.01, 0.3, 0.01, 0.1])
    assert TWIN["stage"]["axes"]["x"]["mass"] == 5.0  # the twin itself is left alone
    unknown = {**FOUND["std"], "x": {**FOUND["std"]["x"], "fc": float("nan")}}  # no Jacobian
    drawn = [c["stage"]["axes"]["x"]["friction"]["fc"] / 2.0 for c in tuning_copies(
        TWIN, FOUND["values"], unknown, FOUND["undetermined"], 20)]
    assert np.all(np.abs(np.log(drawn)) <= 0.6 + 1e-12) and np.ptp(drawn) > 0.0
    protocol = get_protocol("pid").on_plant(TWIN, "twin", copies[:2])
    assert protocol.scenarios == ("paper", "random-101", "random-102", "paper#1",
                                  "random-101#1", "random-102#1", "paper#2", "random-101#2",
                                  "random-102#2")
    assert protocol.scenario_kwargs["random-101#2"] == {
        "id": "contour_gym/CCC-v1", "path": "random", "path_seed": 101, "plant": copies[1]}


def test_tune_on_a_twin_runs_its_copies_too(tmp_path: Path, capsys) -> None:
    path = str(write_machine(tmp_path / "twin.yaml", TWIN, identified=FOUND))
    out = tmp_path / "run"
    assert main(["tune", "pid", "--plant", path, "--population", "4", "--iterations", "1",
                 "--copies", "2", "--out", str(out), "--quiet"]) == 0
    said = capsys.readouterr().out
    assert "do not determine x.damping, y.damping (its report says why): tuned on it and 2 " \
           "copies drawn within those values' uncertainty" in said
    result = json.loads((out / "result.json").read_text())
    kwargs = result["settings"]["scenario_kwargs"]
    assert len(kwargs) == 9 and kwargs["paper#2"]["plant"] == copies_of(path, 2)[1]
    assert "--copies 2" in result["settings"]["command"]
    with pytest.raises(ValueError, match="--copies must be 0 or more, got -1"):
        copies_of(path, -1)


def test_train_on_a_machine_file_records_it(tmp_path: Path, capsys) -> None:
    pytest.importorskip("torch")
    from agents.rl.train import train

    path = str(write_machine(tmp_path / "slow.yaml", SLOW))
    run = train("contour_gym/CCC-Circle-v0", "ppo", 16, out_dir=tmp_path, progress=False,
                eval_episodes=1, plant=path, n_envs=2, n_steps=8, batch_size=16,
                policy_kwargs={"net_arch": [8]})
    assert run.name == "CCC-Circle-v0_on_slow_mill_ppo_seed0"
    config = yaml.safe_load((run / "config.yml").read_text())
    block = next(iter(config.values()))
    assert block["env_kwargs"]["plant"] == SLOW
    assert main(["train", "--resume", str(run), "--plant", path]) == 2
    assert "not with --plant" in capsys.readouterr().err


def test_a_3d_machine_tunes_on_the_paths_it_can_run() -> None:
    assert get_protocol("pid").scenarios == ("paper", "random-101", "random-102")
    assert get_protocol("pid").on_plant("xyz_pmlsm", "xyz").scenarios == ("paper",)
    with pytest.raises(ValueError, match="runs random paths only"):
        get_protocol("000_general").on_plant("xyz_pmlsm", "xyz")
