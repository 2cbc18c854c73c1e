"""The ``contour-gym`` command: a library path, a G-code part file and their errors."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from agents.cli import _parser, main, read_part, scenario_of

CORPUS = pathlib.Path(__file__).parent / "data" / "gcode"
ROWS = ("max |contour error| (um)", "mean |contour error| (um)", "RMS contour error (um)",
        "cycle time (s)")
SQUARE = """G21 G90 G17
G0 X0 Y0
G1 X20 F1200
G1 Y20
G1 X0
G1 Y0
M2
"""


def _table_row(out: str, label: str) -> list[float]:
    line = next(ln for ln in out.splitlines() if ln.startswith(label))
    return [float(v) for v in line[len(label):].split()]


def _png(path: pathlib.Path) -> bool:
    return path.stat().st_size > 1000 and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_default_simulate_runs_the_paper_path(tmp_path, capsys):
    out = tmp_path / "circle.png"
    assert main(["simulate", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("plant xy_dc_servo (paper 000), path circle_r10")
    assert all(len(_table_row(text, row)) == 2 for row in ROWS)
    assert _png(out)


def test_a_part_file_runs_at_its_own_feeds(tmp_path, capsys):
    part, out = CORPUS / "part_2d.ngc", tmp_path / "plots" / "part.png"
    assert main(["simulate", "--gcode", str(part), "--out", str(out), "--dpi", "60"]) == 0
    text = capsys.readouterr().out
    assert text.startswith(f"plant xy_servo_coulomb (paper 004), part {part} (")
    assert "feeds up to 1200 mm/min" in text  # the program's highest F word
    for row in ROWS:
        no_ccc, pid_ccc = _table_row(text, row)
        assert 0.0 < no_ccc < 1e3 and 0.0 < pid_ccc < 1e3
    assert _png(out)
    assert [p.name for p in out.parent.iterdir()] == ["part.png"]  # no temporary left


def test_a_lower_feed_override_takes_longer(tmp_path, capsys):
    part = tmp_path / "square.nc"
    part.write_text(SQUARE)
    times = []
    for override in ("1.0", "0.5"):
        args = ["simulate", "--gcode", str(part), "--feedrate-override", override,
                "--out", str(tmp_path / f"square_{override}.png"), "--dpi", "40"]
        assert main(args) == 0
        times.append(_table_row(capsys.readouterr().out, "cycle time (s)"))
    full, half = times
    assert all(h > 1.5 * f for f, h in zip(full, half, strict=True))  # cutting at half speed


def test_a_rejected_line_names_the_file_and_the_line(tmp_path, capsys):
    part = tmp_path / "bad.nc"
    part.write_text("G21 G90\nG0 X1 Y1\nG41 G1 X5 F100\n")
    out = tmp_path / "bad.png"
    assert main(["simulate", "--gcode", str(part), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{part}: line 3: ") and "G41" in err and "Traceback" not in err
    assert not out.exists()


def test_a_line_the_machine_cannot_run_names_the_file_and_the_line(capsys):
    part = CORPUS / "arcs_3axis.ngc"  # an XZ arc, on an X-Y machine
    assert main(["simulate", "--gcode", str(part), "--plant", "xy_servo_coulomb"]) == 2
    assert capsys.readouterr().err.startswith(f"{part}: line ")


def test_a_missing_file_is_an_error_naming_it(tmp_path, capsys):
    part = tmp_path / "nowhere.nc"
    assert main(["simulate", "--gcode", str(part)]) == 2
    assert capsys.readouterr().err.strip() == f"{part}: No such file or directory"


@pytest.mark.parametrize("value", ["0", "-0.5", "nan", "inf", "fast"])
def test_the_feed_override_must_be_a_positive_number(value, capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", "--gcode", str(CORPUS / "part_2d.ngc"), "--feedrate-override", value])
    assert exit_.value.code == 2
    assert "argument --feedrate-override" in capsys.readouterr().err


def test_path_and_gcode_exclude_each_other(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["simulate", "--path", "circle", "--gcode", str(CORPUS / "part_2d.ngc")])
    assert exit_.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


def test_work_offsets_and_tool_lengths_are_given_in_mm(tmp_path):
    part = tmp_path / "offsets.nc"
    part.write_text("G21 G90 G55\nG0 X0 Y0 Z5\nG43 H2 G1 Z0 F300\nG1 X10\n")
    args = _parser().parse_args([
        "simulate", "--gcode", str(part), "--work-offset", "g55=100,50,-20",
        "--tool-length", "2=30",
    ])
    path = read_part(args)
    assert path.point(path.length) == pytest.approx([0.11, 0.05, -0.02 + 0.03])
    for bad in (["--work-offset", "G60=1,2"], ["--work-offset", "G54=1"],
                ["--tool-length", "0=5"], ["--tool-length", "1"]):
        with pytest.raises(SystemExit):
            _parser().parse_args(["simulate", *bad])


def test_a_part_plot_colours_the_cuts_and_dashes_the_rapids(tmp_path):
    from matplotlib.collections import LineCollection

    from contour_gym.api import run_trace
    from contour_gym.render import part_figure

    part = tmp_path / "square.nc"
    part.write_text("G21 G90\nG0 X10 Y0\nG1 X30 F1200\nY20\nX10\nY0\nG0 X0\nM2\n")
    args = _parser().parse_args(["simulate", "--gcode", str(part)])
    scenario = scenario_of(args)
    traces = {"no CCC": run_trace(scenario, None)[1]}
    fig = part_figure(scenario.path, traces, title="square")
    panel, colour_bar = fig.axes
    (cuts,) = [c for c in panel.collections if isinstance(c, LineCollection)]
    strokes = np.concatenate([s[:, :2] for s in cuts.get_segments()]) * 1e-3
    assert strokes[:, 0].min() > 0.0099 and strokes[:, 0].max() < 0.0301  # on the square only
    eps = np.abs(traces["no CCC"].eps[0, :, 0])
    assert 0.0 < cuts.get_array().max() <= np.nanmax(eps) * 1e6 + 1e-9
    rapids, worst = panel.get_lines()  # the dashed rapids, then the worst point's cross
    assert rapids.get_linestyle() == "--"
    assert worst.get_marker() == "x"
    wx, wy = worst.get_xydata()[0]
    assert any(t.get_text() == f"max {cuts.get_array().max():.3g} um" for t in panel.texts)
    ends = np.concatenate([s[1:2, :2] for s in cuts.get_segments()])
    assert [wx, wy] == ends[int(np.argmax(cuts.get_array()))].tolist()
    xy = rapids.get_xydata()
    assert np.nanmax(xy[:, 0]) == pytest.approx(10.0) and np.nanmax(xy[:, 1]) == pytest.approx(0.0)
    assert colour_bar.get_ylabel() == "|contour error| (um)"
