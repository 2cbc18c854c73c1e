"""A twin from servo logs: test logs of hidden machines, replayed through the loop (issue 64)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agents.twin.generate import excitation, machine_log, perturbed_plant
from agents.twin.replay import command_path, replay, replay_loop
from contour_gym.logs import ServoLog, read_csv, write_csv
from contour_gym.presets import resolve_preset


def _hidden_log(preset: str, ideal: bool, seed: int = 1) -> tuple[dict, ServoLog]:
    rng = np.random.default_rng(seed)
    plant = perturbed_plant(preset, rng)
    return plant, machine_log(plant, excitation(resolve_preset(plant), rng, seconds=3.0),
                              seed=seed, ideal=ideal)


def test_a_hidden_machine_differs_from_its_preset_within_the_bounds() -> None:
    plant = perturbed_plant("xy_servo_coulomb", np.random.default_rng(3))
    base, hidden = resolve_preset("xy_servo_coulomb"), resolve_preset(plant)
    for b, h in zip(base.stage.axes, hidden.stage.axes, strict=True):
        for key in ("mass", "damping", "force_constant"):
            assert 0.6 <= getattr(h, key) / getattr(b, key) <= 1.6
            assert getattr(h, key) != getattr(b, key)
        assert h.friction.fc != b.friction.fc  # type: ignore[union-attr]


@pytest.mark.parametrize(("preset", "ideal"), [("xy_servo_coulomb", True),
                                               ("xy_dc_servo", False)])
def test_replaying_a_log_on_its_own_machine_gives_back_its_feedback(
    preset: str, ideal: bool
) -> None:
    plant, log = _hidden_log(preset, ideal)
    loop = replay_loop(log, plant, members=2, ideal=ideal)
    x = replay(loop, log)
    reference = loop.trace().r
    for a, axis in enumerate(log.axes):
        assert np.abs(reference[:, :, a] - axis.cmd).max() < 1e-12  # the command, tick by tick
        step = resolve_preset(plant).stage.axes[a].encoder_resolution
        bound = 1e-9 if ideal else 0.5 * step + 1e-12  # exact, or the encoder's rounding
        assert np.abs(x[:, :, a] - axis.fb).max() <= bound
        assert np.array_equal(x[0], x[1])  # a member's replay does not depend on the others
    nominal = replay(replay_loop(log, preset, ideal=ideal), log)
    assert np.abs(nominal[0] - np.stack([a.fb for a in log.axes], axis=1)).max() > 20 * bound


def test_a_log_read_back_from_its_file_replays_the_same(tmp_path: Path) -> None:
    plant, log = _hidden_log("xy_dc_servo", False, seed=2)
    write_csv(log, tmp_path / "log.csv", length_unit="mm")
    again = read_csv(tmp_path / "log.csv", length_unit="mm")
    x = replay(replay_loop(log, plant), log)
    y = replay(replay_loop(again, plant), again)
    assert np.abs(x - y).max() < 1e-9


def test_a_log_that_cannot_drive_the_machine_is_named() -> None:
    _, log = _hidden_log("xy_dc_servo", True)
    with pytest.raises(ValueError, match=r"no command of axis 'y1'; the machine's contour runs "
                                         r"on axes x, y1"):
        command_path(log, "xyy_gantry")
    slow = ServoLog(log.time * 2.0, log.axes, source="slow.csv")
    with pytest.raises(ValueError, match=r"slow\.csv: a sample every 0\.002 s; the machine's "
                                         r"servo tick is 0\.001 s"):
        command_path(slow, "xy_dc_servo")
