"""Machine files: a preset with its own numbers, loaded wherever a plant is (issue 64)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

import contour_gym
from agents.cli import main
from contour_gym.machines import is_machine_file, read_machine, write_machine
from contour_gym.plant import LuGreFriction
from contour_gym.presets import resolve_preset

MINE = {"preset": "xy_dc_servo", "name": "my_mill",
        "stage": {"axes": {"x": {"mass": 400.0, "friction": {"law": "coulomb", "fc": 5.0}},
                           "y": {"damping": 31000.0}}},
        "axis_gains": {"x": {"kp": 7000.0}}}


def test_a_machine_file_is_the_plant_dict_it_holds(tmp_path: Path) -> None:
    path = write_machine(tmp_path / "mill.yaml", MINE, identified={"fit": {"x": 0.04}})
    assert is_machine_file(path) and is_machine_file(str(path)) and not is_machine_file("x")
    assert read_machine(path) == MINE  # what identify records is not loaded back
    from_file, from_dict = resolve_preset(str(path)), resolve_preset(MINE)
    assert from_file == from_dict and from_file.name == "my_mill"
    assert from_file.stage.axes[0].mass == 400.0 and from_file.axis_gains[0].kp == 7000.0
    assert contour_gym.simulate(str(path)) == contour_gym.simulate(MINE)


def test_a_friction_law_key_replaces_the_model() -> None:
    lugre = {"law": "lugre", "sigma0": 500.0, "sigma1": 2.0, "sigma2": 0.4, "fc": 1.0,
             "fs": 1.5, "vs": 0.01}
    preset = resolve_preset({"preset": "xy_dc_servo",
                             "stage": {"axes": {"x": {"friction": lugre}, "y": {"friction": {
                                 "law": "none"}}}}})
    x, y = preset.stage.axes[0].friction, preset.stage.axes[1].friction
    assert isinstance(x, LuGreFriction) and x.sigma0 == 500.0 and y is None


def test_every_entry_point_takes_a_machine_file(tmp_path: Path, capsys) -> None:
    path = str(write_machine(tmp_path / "mill.yml", MINE))
    env = gym.make("contour_gym/CCC-v1", plant=path)
    assert env.unwrapped.task.preset.name == "my_mill"  # type: ignore[attr-defined]
    assert main(["simulate", "--plant", path, "--out", str(tmp_path / "p.png")]) == 0
    assert "plant my_mill (paper 000)" in capsys.readouterr().out


@pytest.mark.parametrize(("text", "said"), [
    (None, r"machine file .*none\.yaml does not exist"),
    ("preset: [", r"machine file .*none\.yaml cannot be read: "),
    ("stage: {}", r"machine file .*none\.yaml must map 'preset'"),
    ("preset: xy_dc_servo\nstage: {axes: {x: {mas: 1}}}",
     r"machine file .*none\.yaml: unknown field\(s\) \['mas'\] of plant\.stage\.axes\['x'\]"),
    ("preset: xy_dc_servo\nstage: {axes: {x: {friction: {law: bogus}}}}",
     r"machine file .*none\.yaml: unknown friction law 'bogus'"),
    ("preset: xy_dc_servo\nstage: {axes: {x: {mass: -1}}}", r"none\.yaml: .*mass"),
    ("preset: xy_dc_servo\nstage: {axes: {x: {friction: {law: coulomb, bogus: 1}}}}",
     r"none\.yaml: unknown field\(s\) \['bogus'\] of plant\.stage\.axes\['x'\]\.friction"),
    ("preset: xy_dc_servo\nstage: {axes: {x: {friction: {law: coulomb, fc: .nan}}}}",
     r"none\.yaml: fc must be finite"),
])
def test_a_bad_machine_file_is_named(tmp_path: Path, text: str | None, said: str) -> None:
    path = tmp_path / "none.yaml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(ValueError, match=said):
        resolve_preset(str(path))


def test_the_command_line_names_a_plant_that_is_neither(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["simulate", "--plant", "my_mill", "--out", "never.png"])
    assert "'my_mill' is neither a preset" in capsys.readouterr().err


def test_a_machine_name_is_safe_in_a_run_folders_name(tmp_path: Path) -> None:
    from contour_gym.machines import plant_of

    path = write_machine(tmp_path / "m.yaml", {**MINE, "name": "../shop floor/mill 2"})
    assert plant_of(str(path))[1] == "_shop_floor_mill_2"
    assert plant_of("xy_dc_servo") == ("xy_dc_servo", "xy_dc_servo")
