"""A part program back with new F words, within a contour tolerance (issue 65)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from agents.optimize import AUDIT, _Search, optimize_part, peaks_on_machines, random_machines
from contour_gym import simulate
from contour_gym.api import make_scenario
from contour_gym.paths import from_gcode

PART = (Path(__file__).parent / "data" / "gcode" / "part_2d.ngc").read_text()


def _without_f(text: str) -> list[str]:
    # each line with its F words taken out (the comments have none here)
    return [re.sub(r"\s*F[\d.]+", "", line) for line in text.splitlines()]


def _without_splits(text: str) -> list[str]:
    # the lines without F words, less the first halves of split moves (G1 and axis words)
    return [line for line in _without_f(text)
            if not re.fullmatch(r"G1(?: [XYZ]-?\d+\.\d*)+", line)]


def test_the_optimised_program_holds_the_tolerance_as_written() -> None:
    result = optimize_part(PART, "xy_servo_coulomb", 5e-6)
    assert _without_splits(result.text) == _without_f(PART)  # only F words and splits
    assert result.too_tight == ()
    # read back and run at its own F words: what the result reports
    run = simulate("xy_servo_coulomb", from_gcode(result.text), ccc_gains=_gains())
    assert run["max_contour_error"] <= 5e-6
    assert run["cycle_time"] == pytest.approx(result.after["cycle_time"], rel=5e-3)
    assert result.after["cycle_time"] < 0.7 * result.before["cycle_time"]
    # the blocks' peaks hold the run's (a tick at a stop may count for the block after it too)
    assert run["max_contour_error"] <= max(result.block_peak.values()) * (1 + 1e-12) <= 5e-6
    assert max(result.feeds.values()) <= 0.1 + 1e-12  # the machine's largest feed


def _gains() -> tuple[float, float, float]:
    from contour_gym.presets import resolve_preset

    return resolve_preset("xy_servo_coulomb").ccc_gains.as_tuple()


def test_a_tolerance_no_feed_holds_names_its_lines() -> None:
    with pytest.raises(ValueError, match=r"cannot be held at the slowest feed .* G-code lines "):
        optimize_part(PART, "xy_servo_coulomb", 1e-7)
    result = optimize_part(PART, "xy_servo_coulomb", 1e-7, best_effort=True)
    assert result.too_tight and set(result.too_tight) <= set(result.block_peak)


@pytest.mark.parametrize("tolerance", [0.0, -1e-6, float("nan")])
def test_a_bad_tolerance_is_named(tolerance: float) -> None:
    with pytest.raises(ValueError, match="tolerance must be positive and finite"):
        optimize_part(PART, "xy_servo_coulomb", tolerance)


def test_the_command_writes_the_program_and_its_tables(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    part = tmp_path / "part.ngc"
    part.write_text(PART)
    assert main(["optimize", str(part), "--plant", "xy_servo_coulomb", "--tolerance", "5um",
                 "--max-feed", "3000", "--diff"]) == 0
    said = capsys.readouterr().out
    written = (tmp_path / "part_opt.ngc").read_text()
    assert "| optimised |" in said and "| line | old F (mm/min) | new F (mm/min) |" in said
    assert "+G1 X70 F" in said and "program written to" in said
    assert _without_splits(written) == _without_f(PART)
    feeds = [float(f) for f in re.findall(r"F([\d.]+)", written)]
    assert max(feeds) <= 3000  # --max-feed, mm/min
    assert (tmp_path / "part_opt_report.png").stat().st_size > 10_000  # the part drawn


def test_robust_feeds_hold_on_every_machine_they_were_searched_on() -> None:
    # the search's 3 machines, then the audit's 3 * AUDIT drawn after them
    machines = random_machines("xy_servo_coulomb", 3 * (1 + AUDIT), seed=0)
    result = optimize_part(PART, "xy_servo_coulomb", 5e-6, robust=3, seed=0)
    peaks = peaks_on_machines(result.text, "xy_servo_coulomb", machines)
    assert peaks.shape == (3 * (1 + AUDIT),) and np.all(peaks <= 5e-6)
    assert result.after["worst_machine_error"] == pytest.approx(
        max(peaks.max(), result.after["max_contour_error"]))
    # the machines differ (mass within 10 %, friction 0.5-1.5x, disturbance 0-2x) and come
    # again from the seed
    assert len({float(m["friction"][0]) for m in machines}) == len(machines)
    again = random_machines("xy_servo_coulomb", len(machines), seed=0)
    assert all(np.array_equal(a[k], b[k]) for a, b in zip(machines, again, strict=True)
               for k in a)
    # the robust program is no faster than the one for the machine alone
    alone = optimize_part(PART, "xy_servo_coulomb", 5e-6)
    assert result.after["cycle_time"] >= alone.after["cycle_time"] * (1 - 1e-3)


def test_an_audit_machine_that_breaks_the_tolerance_adds_its_block_peaks() -> None:
    plant, given = "xy_servo_coulomb", from_gcode(PART)
    hard = {"mass": np.array([0.9, 1.1]), "damping": np.ones(2),
            "force_constant": np.array([1.1, 0.9]), "friction": np.array([0.5, 1.5]),
            "disturbance": np.array([2.0, 2.0])}
    own = peaks_on_machines(PART, plant, [hard])[0]
    alone = simulate(plant, given, ccc_gains=_gains())["max_contour_error"]
    assert own > alone  # the hard machine is worse than the nominal one
    tolerance = (own + alone) / 2.0
    search = _Search(PART, plant, tolerance, None, "machine", {}, [], [hard])
    plain = _Search(PART, plant, tolerance, None, "machine", {}, [], [])
    path = search.path
    result, peaks = search.checked(path)
    _, nominal = plain.checked(path)
    scenario = make_scenario(plant, given)
    _, on_hard = plain._run_members([path], scenario, [hard], spread=False)
    # the machine broke it: its run recorded, each block's peak the larger of the two
    assert result["worst_machine_error"] == pytest.approx(own)
    np.testing.assert_array_equal(peaks, np.maximum(nominal, on_hard[0]))
    assert peaks.max() > tolerance >= nominal.max()
    # an audit machine that holds it changes nothing
    easy = _Search(PART, plant, own * 2.0, None, "machine", {}, [], [hard])
    np.testing.assert_array_equal(easy.checked(path)[1], nominal)


def test_the_blocks_near_a_broken_one_are_found_in_a_short_program() -> None:
    from agents.optimize import _dilated

    # fewer blocks than the reach's window (np.convolve's "same" would grow the array)
    np.testing.assert_array_equal(_dilated(np.array([False, True, False, False]), 2),
                                  [True, True, True, True])
    np.testing.assert_array_equal(_dilated(np.array([True, False, False, False, False]), 1),
                                  [True, True, False, False, False])
    assert _dilated(np.array([True]), 2).tolist() == [True]


@pytest.mark.parametrize("n", [-1, 1.5, True])
def test_a_bad_number_of_robust_machines_is_named(n: object) -> None:
    with pytest.raises(ValueError, match="robust must be a whole number of machines"):
        random_machines("xy_servo_coulomb", n, seed=0)  # type: ignore[arg-type]


def test_the_command_checks_robust_feeds_on_fresh_machines(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    part = tmp_path / "part.ngc"
    part.write_text(PART)
    assert main(["optimize", str(part), "--plant", "xy_servo_coulomb", "--tolerance", "5um",
                 "--robust", "2", "--seed", "0", "--best-effort"]) == 0
    said = capsys.readouterr().out
    assert "on the worst machine (um)" in said
    assert re.search(r"on 2 fresh machines \(seed 1\): the tolerance holds on [0-2] of 2", said)


@pytest.mark.parametrize(("argv", "said"), [
    (["--tolerance=-1um"], "'-1um': a tolerance is > 0"),
    (["--tolerance", "5 parsecs"], "is not a length"),
])
def test_bad_arguments_are_named(tmp_path: Path, capsys, argv: list[str], said: str) -> None:
    from agents.cli import main

    part = tmp_path / "part.ngc"
    part.write_text(PART)
    with pytest.raises(SystemExit):
        main(["optimize", str(part), "--plant", "xy_servo_coulomb", *argv])
    assert said in capsys.readouterr().err


def test_an_unreadable_program_is_named_and_nothing_written(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    part = tmp_path / "bad.ngc"
    part.write_text("G1 X1 F100\nG93 X2\n")
    assert main(["optimize", str(part), "--plant", "xy_servo_coulomb", "--tolerance",
                 "5um"]) == 2
    assert "bad.ngc: G-code line 2" in capsys.readouterr().err
    assert not (tmp_path / "bad_opt.ngc").exists()


@pytest.mark.parametrize(("text", "kwargs", "said"), [
    ("G21 G90\nG0 X10\nG0 Y10\n", {}, "the program cuts nothing"),
    (PART, {"max_feed": float("nan")}, "max_feed must be finite and > 0 m/s"),
    (PART, {"max_feed": -1.0}, "max_feed must be finite and > 0 m/s"),
])
def test_a_program_or_feed_it_cannot_use_is_named(text: str, kwargs: dict, said: str) -> None:
    with pytest.raises(ValueError, match=said):
        optimize_part(text, "xy_servo_coulomb", 5e-6, **kwargs)


def test_the_part_itself_is_never_the_output(tmp_path: Path, capsys) -> None:
    from agents.cli import main

    part = tmp_path / "part.ngc"
    part.write_text(PART)
    assert main(["optimize", str(part), "--plant", "xy_servo_coulomb", "--tolerance", "5um",
                 "--out", str(part)]) == 2
    assert "is the part itself" in capsys.readouterr().err
    assert part.read_text() == PART


def test_bisection_searches_one_member_a_round_and_holds() -> None:
    result = optimize_part(PART, "xy_servo_coulomb", 5e-6, method="bisection")
    run = simulate("xy_servo_coulomb", from_gcode(result.text), ccc_gains=_gains())
    assert run["max_contour_error"] <= 5e-6 and result.too_tight == ()
    assert run["cycle_time"] == pytest.approx(result.after["cycle_time"], rel=5e-3)
    assert result.after["cycle_time"] < 0.7 * result.before["cycle_time"]
    with pytest.raises(ValueError, match="unknown method .annealing.; accepted: bisection, levels"):
        optimize_part(PART, "xy_servo_coulomb", 5e-6, method="annealing")


def test_long_moves_split_where_two_feeds_are_faster() -> None:
    # a W of 20 mm strokes, 157 degree turns: each stroke wants speed, each turn less
    part = (Path(__file__).parents[1] / "docs" / "metrics_part.nc").read_text()
    whole = optimize_part(part, "xy_servo_coulomb", 5e-6, split=False)
    split = optimize_part(part, "xy_servo_coulomb", 5e-6)
    assert _without_f(whole.text) == _without_f(part)
    assert _without_splits(split.text) == _without_f(part)
    assert len(split.text.splitlines()) > len(part.splitlines())
    assert split.after["cycle_time"] < 0.95 * whole.after["cycle_time"]
    run = simulate("xy_servo_coulomb", from_gcode(split.text), ccc_gains=_gains())
    assert run["max_contour_error"] <= 5e-6
    assert run["cycle_time"] == pytest.approx(split.after["cycle_time"], rel=5e-3)
    # each line of the result names the line it comes from; the halves of a move differ in F
    halves = [j for j, src in split.source_lines.items() if split.source_lines.get(j + 1) == src]
    new, old = _without_f(split.text), _without_f(part)
    assert all(new[line - 1] == old[source - 1] for line, source in split.source_lines.items()
               if line not in halves)
    assert halves and all(split.feeds[j] != split.feeds[j + 1] for j in halves)
