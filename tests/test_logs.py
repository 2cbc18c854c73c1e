"""contour_gym.logs: servo logs read from CSV and halsampler files, written back exactly."""

import os
import pickle
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contour_gym.logs import (
    MIN_SAMPLES,
    AxisLog,
    LogError,
    ServoLog,
    encoder_step,
    read_csv,
    read_halsampler,
    read_log,
    write_csv,
    write_halsampler,
)

PERIOD = 1e-3
KINDS = ("cmd", "fb", "effort", "vel_cmd")


def make_log(n=300, names=("x", "y"), effort=True, vel_cmd=True, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * PERIOD
    axes = []
    for i, name in enumerate(names):
        cmd = 0.01 * np.sin(2 * np.pi * (i + 1) * t) + 0.002 * i
        axes.append(AxisLog(name, cmd, cmd + 1e-6 * rng.normal(size=n),
                            rng.normal(size=n) if effort else None,
                            np.gradient(cmd, t) if vel_cmd else None))
    return ServoLog(t, tuple(axes), "made")


def assert_same(a, b, ulps=0):
    """b reproduces a: exactly, or within ``ulps`` units in the last place (lengths only)."""
    assert a.names == b.names
    np.testing.assert_array_equal(a.time, b.time)
    for x, y in zip(a.axes, b.axes, strict=True):
        for kind in KINDS:
            u, v = getattr(x, kind), getattr(y, kind)
            assert (u is None) == (v is None), kind
            if u is None:
                continue
            if ulps and kind != "effort":
                np.testing.assert_array_max_ulp(u, v, maxulp=ulps)
            else:
                np.testing.assert_array_equal(u, v)


def csv_text(log=None, header=None):
    log = log or make_log(effort=False, vel_cmd=False, names=("x",))
    rows = [",".join(map(repr, r)) for r in np.column_stack(
        [log.time, *[c for a in log.axes for c in (a.cmd, a.fb)]]).tolist()]
    header = header or ",".join(["time", *[f"{a.name}_{k}" for a in log.axes for k in KINDS[:2]]])
    return [header, *rows]


def write_lines(path, lines, encoding="utf-8"):
    path.write_text("\n".join(lines) + "\n", encoding=encoding)
    return path


# ------------------------------------------------------------------------------ round trips


def test_a_csv_written_in_metres_reads_back_exactly(tmp_path):
    log = make_log()
    write_csv(log, tmp_path / "a.csv")
    back = read_csv(tmp_path / "a.csv")
    assert_same(log, back)
    assert back.source == str(tmp_path / "a.csv")
    assert (tmp_path / "a.csv").read_text().splitlines()[0] == (
        "time,x_cmd,x_fb,x_effort,x_vel_cmd,y_cmd,y_fb,y_effort,y_vel_cmd")


@pytest.mark.parametrize(("unit", "per_metre"), [("mm", 1000.0), ("inch", 1 / 0.0254)])
def test_a_csv_in_mm_or_inch_holds_those_units_and_reads_back_within_an_ulp(tmp_path, unit,
                                                                            per_metre):
    log = make_log()
    write_csv(log, tmp_path / "a.csv", length_unit=unit)
    first = (tmp_path / "a.csv").read_text().splitlines()[2].split(",")
    assert float(first[1]) == pytest.approx(log.axes[0].cmd[1] * per_metre, rel=1e-15)
    assert float(first[3]) == log.axes[0].effort[1]  # the effort is never scaled
    assert_same(log, read_csv(tmp_path / "a.csv", length_unit=unit), ulps=2)


@pytest.mark.parametrize("tag", [False, True])
@pytest.mark.parametrize("unit", ["m", "mm", "inch"])
def test_a_halsampler_file_reads_back_with_and_without_the_tag(tmp_path, tag, unit):
    log = make_log()
    columns = write_halsampler(log, tmp_path / "h.txt", length_unit=unit, tag=tag)
    assert columns == ("joint.0.motor-pos-cmd,joint.0.motor-pos-fb,pid.0.output,joint.0.vel-cmd,"
                       "joint.1.motor-pos-cmd,joint.1.motor-pos-fb,pid.1.output,joint.1.vel-cmd")
    first = (tmp_path / "h.txt").read_text().splitlines()[1].split()
    assert len(first) == 8 + tag and (first[0] == "1") == tag
    back = read_halsampler(tmp_path / "h.txt", columns, PERIOD, length_unit=unit)
    assert_same(log, back, ulps=0 if unit == "m" else 2)


def test_the_tag_gives_the_sample_numbers_and_so_the_time_origin(tmp_path):
    log = make_log(n=400).window(0.1, 0.4)
    columns = write_halsampler(log, tmp_path / "h.txt", tag=True)
    assert (tmp_path / "h.txt").read_text().split(" ", 1)[0] == "100"
    back = read_halsampler(tmp_path / "h.txt", columns, PERIOD)
    np.testing.assert_array_equal(back.time, np.arange(100, 400) * PERIOD)
    untagged = write_halsampler(log, tmp_path / "u.txt")
    assert read_halsampler(tmp_path / "u.txt", untagged, PERIOD).time[0] == 0.0


@settings(max_examples=12, deadline=None)
@given(names=st.lists(st.from_regex(r"[a-z][a-z0-9]{0,3}", fullmatch=True), min_size=1,
                      max_size=4, unique=True),
       effort=st.booleans(), vel_cmd=st.booleans(), seed=st.integers(0, 2**32 - 1),
       scale=st.sampled_from([1e-9, 1e-3, 1.0, 1e6]))
def test_any_axes_and_values_round_trip_through_both_formats(tmp_path_factory, names, effort,
                                                             vel_cmd, seed, scale):
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.5, 1.5, MIN_SAMPLES)) * PERIOD
    axes = tuple(AxisLog(n, np.linspace(0, 1e-3, t.size) + rng.normal(size=t.size) * scale,
                         rng.normal(size=t.size) * scale,
                         rng.normal(size=t.size) if effort else None,
                         rng.normal(size=t.size) if vel_cmd else None) for n in names)
    log = ServoLog(t, axes, "random")
    folder = tmp_path_factory.mktemp("random")
    write_csv(log, folder / "a.csv")
    assert_same(log, read_csv(folder / "a.csv"))
    even = ServoLog(np.arange(t.size) * PERIOD, axes)
    columns = write_halsampler(even, folder / "h.txt", joints={})  # plain names
    assert_same(even, read_halsampler(folder / "h.txt", columns, PERIOD, joints={}))


# ------------------------------------------------------------------------------ what a CSV may be


def test_a_byte_order_mark_crlf_and_blank_lines_are_read(tmp_path):
    log = make_log(effort=False, vel_cmd=False, names=("x",))
    lines = csv_text(log)
    path = tmp_path / "a.csv"
    path.write_bytes(("\r\n".join([lines[0], "", *lines[1:5], "  ", *lines[5:]]) + "\r\n\r\n")
                     .encode("utf-8-sig"))
    assert_same(log, read_csv(path))
    lines[20] = lines[20].replace(",", ",abc", 1)
    path.write_bytes(("\r\n".join([lines[0], "", *lines[1:]])).encode("utf-8-sig"))
    with pytest.raises(LogError, match=r"a\.csv, line 22, column 2 \(x_cmd\): 'abc"):
        read_csv(path)


def test_headers_are_case_insensitive_and_spaces_around_names_ignored(tmp_path):
    log = make_log(effort=False, vel_cmd=False, names=("x", "y1"))
    path = write_lines(tmp_path / "a.csv",
                       csv_text(log, header=" Time , X_CMD,x_Fb,\"Y1_cmd\" , Y1_FB "))
    assert_same(log, read_csv(path))


def test_effort_and_vel_cmd_columns_are_optional_and_only_lengths_are_scaled(tmp_path):
    log = make_log(names=("x",))
    write_csv(log, tmp_path / "a.csv", length_unit="mm")
    back = read_csv(tmp_path / "a.csv", length_unit="mm")
    np.testing.assert_array_equal(back.axes[0].effort, log.axes[0].effort)
    np.testing.assert_array_max_ulp(back.axes[0].vel_cmd, log.axes[0].vel_cmd, maxulp=2)
    plain = read_csv(write_lines(tmp_path / "b.csv", csv_text()))
    assert plain.axes[0].effort is None and plain.axes[0].vel_cmd is None


def bad_csv(lines, row, text):
    """The CSV ``lines`` with line ``row`` (1-based) replaced by ``text``."""
    out = list(lines)
    out[row - 1] = text
    return out


LINES = csv_text()


@pytest.mark.parametrize(("lines", "message"), [
    ([LINES[0].replace("time", "t"), *LINES[1:]],
     r"a\.csv, line 1: the header has no time column \(s\)$"),
    (["", " ", "x_cmd,x_fb", *LINES[1:]], r"a\.csv, line 3: the header has no time column"),
    ([LINES[0].replace(",", ";"), *LINES[1:]], r"no time column \(s\); the fields are split at"),
    ([LINES[0] + ",y_cmd", *[r + ",0.5" for r in LINES[1:]]],
     r"line 1, column 4 \(y_cmd\): axis 'y' has cmd but no fb column: an axis needs both"),
    ([LINES[0] + ",y_fb", *[r + ",0.5" for r in LINES[1:]]], r"axis 'y' has fb but no cmd col"),
    ([LINES[0] + ",y_effort", *[r + ",0.5" for r in LINES[1:]]],
     r"column 4 \(y_effort\): axis 'y' has effort but no cmd or fb column"),
    ([LINES[0] + ",x_pos", *[r + ",0.5" for r in LINES[1:]]],
     r"line 1, column 4 \(x_pos\): unknown column: a CSV log's columns are time, <axis>_cmd, "
     r"<axis>_fb, <axis>_effort or <axis>_vel_cmd"),
    ([LINES[0] + ",X_CMD", *[r + ",0.5" for r in LINES[1:]]],
     r"column 4 \(X_CMD\): a second cmd column of axis 'x' \(the first is column 2 \(x_cmd\)\)"),
    ([LINES[0] + ",time", *[r + ",0.5" for r in LINES[1:]]], r"column 4 \(time\): a second time"),
    (bad_csv(LINES, 7, "0.005,0.1"), r"line 7: 2 fields; the header has 3$"),
    (bad_csv(LINES, 7, LINES[6] + ","), r"line 7: 4 fields; the header has 3$"),
    (bad_csv(LINES, 9, "0.007,abc,0.1"), r"line 9, column 2 \(x_cmd\): 'abc' is not a number$"),
    (bad_csv(LINES, 9, "0.007,0.1,"), r"line 9, column 3 \(x_fb\): is empty$"),
    (bad_csv(LINES, 9, "0.007,0.1, NaN"), r"line 9, column 3 \(x_fb\): 'NaN' is not a finite"),
    (bad_csv(LINES, 9, "0.007,-inf,0"), r"line 9, column 2 \(x_cmd\): '-inf' is not a finite"),
    (bad_csv(LINES, 9, "0.007,1e999,0"), r"column 2 \(x_cmd\): '1e999' is not a finite number"),
    (bad_csv(LINES, 12, "0.009,0,0"),
     r"line 12, column 1 \(time\): time 0\.009 s does not increase from 0\.009\d* s on line "
     r"11$"),
    (bad_csv(LINES, 12, "0.001,0,0"), r"line 12, .*time 0.001 s does not increase from 0.009"),
    (LINES[:MIN_SAMPLES], r"a\.csv: has 99 samples; a log needs 100 or more$"),
    ([], r"a\.csv: is empty: a CSV log needs a header naming time, <axis>_cmd"),
])
def test_a_bad_csv_is_refused_naming_the_line_and_column(tmp_path, lines, message):
    with pytest.raises(LogError, match=message):
        read_csv(write_lines(tmp_path / "a.csv", lines))


def test_an_axis_that_never_moved_is_named(tmp_path):
    log = make_log(effort=False, vel_cmd=False)
    still = AxisLog("y", np.full(log.time.size, 0.1), log.axes[1].fb)
    write_csv(ServoLog(log.time, (log.axes[0], still)), tmp_path / "a.csv")
    assert read_csv(tmp_path / "a.csv").still == ("y",)  # read; identification keeps it out
    assert log.still == ()
    nearly = AxisLog("x", 0.1 + np.linspace(0, 0.9e-6, log.time.size), log.axes[1].fb)
    write_csv(ServoLog(log.time, (nearly, still)), tmp_path / "b.csv")
    with pytest.raises(LogError, match=r"b\.csv: no axis moved: the commands span x 0\.900 um, "
                                       r"y 0\.000 um \(each needs 1 um\)$"):
        read_csv(tmp_path / "b.csv")


def test_bad_units_and_undecodable_bytes_are_refused(tmp_path):
    path = write_lines(tmp_path / "a.csv", LINES)
    with pytest.raises(LogError, match=r"length_unit 'cm' is not one of m, mm, inch$"):
        read_csv(path, length_unit="cm")
    path.write_bytes("\n".join(LINES[:5]).encode() + b"\n0.1,\xff,0\n")
    with pytest.raises(LogError, match=r"line 6: is not UTF-8 text \(byte 0xff\)"):
        read_csv(path)


def test_a_log_error_is_one_line_and_pickles(tmp_path):
    with pytest.raises(LogError) as caught:
        read_csv(write_lines(tmp_path / "a\nb.csv", bad_csv(LINES, 9, "0.007,0.1,x\ny")))
    assert "\n" not in str(caught.value)
    again = pickle.loads(pickle.dumps(caught.value))
    assert str(again) == str(caught.value) and again.line == caught.value.line == 9
    assert isinstance(again, ValueError)


# ------------------------------------------------------------------------------ halsampler


def halsampler_file(tmp_path, log=None, tag=False, unit="m"):
    log = log or make_log(effort=False, vel_cmd=False)
    columns = write_halsampler(log, tmp_path / "h.txt", length_unit=unit, tag=tag)
    return tmp_path / "h.txt", columns, log


def test_joints_map_as_dict_or_string_and_pin_spellings(tmp_path):
    log = make_log(names=("x", "y1"))
    path = tmp_path / "h.txt"
    write_halsampler(log, path, joints={0: "x", 2: "y1"})
    columns = ["joint.0.pos-cmd", "joint.0.pos-fb", "joint.0.effort", "joint.0.vel-cmd",
               " JOINT.2.MOTOR-POS-CMD ", "joint.2.motor-pos-fb", "pid.2.output",
               "joint.2.vel-cmd"]
    for joints in ({0: "x", 2: "y1"}, "0=x, 2=Y1"):
        assert_same(log, read_halsampler(path, columns, PERIOD, joints=joints))
    plain = ["x_cmd", "x_fb", "x_effort", "x_vel_cmd", "pid.y1.output", "y1_fb", "y1_cmd", "-"]
    back = read_halsampler(path, plain, PERIOD)
    np.testing.assert_array_equal(back.axes[1].effort, log.axes[1].cmd)
    np.testing.assert_array_equal(back.axes[1].cmd, log.axes[1].effort)
    assert back.axes[1].vel_cmd is None


def test_pid_output_is_the_effort_unscaled_and_default_joints_are_xyz(tmp_path):
    log = make_log(names=("x", "y", "z"))
    columns = write_halsampler(log, tmp_path / "h.txt", length_unit="mm")
    assert "pid.2.output" in columns
    back = read_log(tmp_path / "h.txt", columns=columns, period=PERIOD, length_unit="mm")
    assert back.names == ("x", "y", "z")
    np.testing.assert_array_equal(back.axis("z").effort, log.axis("z").effort)


def test_an_overrun_line_or_a_jump_of_the_sample_number_is_refused(tmp_path):
    path, columns, _ = halsampler_file(tmp_path, tag=True)
    lines = path.read_text().splitlines()
    write_lines(path, [*lines[:40], *lines[43:]])
    with pytest.raises(LogError, match=r"h\.txt, line 41, column 1 \(sample number\): the sample "
                                       r"number jumps from 39 to 43: 3 samples were lost"):
        read_halsampler(path, columns, PERIOD)
    write_lines(path, [*lines[:29], "overrun", *lines[32:]])
    with pytest.raises(LogError, match=r"line 30: halsampler wrote 'overrun': samples were lost"):
        read_halsampler(path, columns, PERIOD)
    write_lines(path, ["overrun", *lines[5:]])  # lost before the recording began: harmless
    back = read_halsampler(path, columns, PERIOD)
    assert back.time[0] == 5 * PERIOD and back.time.size == len(lines) - 5
    write_lines(path, ["overrun", *lines[5:9], lines[9].replace(" ", " x", 1), *lines[10:]])
    with pytest.raises(LogError, match=r"line 6, column 2 \(joint\.0\.motor-pos-cmd\): 'x"):
        read_halsampler(path, columns, PERIOD)


def test_a_first_field_that_is_no_sample_number_is_refused(tmp_path):
    path, columns, _ = halsampler_file(tmp_path)
    short = "-," + ",".join(columns.split(",")[2:])
    with pytest.raises(LogError, match=r"line 2, column 1 \(sample number\): .* does not follow "
                                       r"sample number 0 \(columns names one field fewer\)$"):
        read_halsampler(path, short, PERIOD)
    lines = path.read_text().splitlines()
    write_lines(path, [lines[0].replace("0.0", "0.25", 1), *lines[1:]])
    with pytest.raises(LogError, match=r"line 1, column 1 \(sample number\): 0\.25 is not a "):
        read_halsampler(path, short, PERIOD)


@pytest.mark.parametrize(("edit", "columns", "message"), [
    (None, "joint.0.motor-pos-cmd,joint.0.motor-pos-fb",
     r"line 1: 4 fields; columns names 2 \(or 3 with halsampler -t's sample number first\)$"),
    (lambda s: s.rsplit(" ", 1)[0], None, r"line 50: 3 fields; columns names 4$"),
    (lambda s: "nan " + s.split(" ", 1)[1], None,
     r"line 50, column 1 \(joint\.0\.motor-pos-cmd\): 'nan' is not a finite number$"),
    (None, "joint.0.motor-pos-cmd,joint.0.motor-pos-xyz,joint.1.motor-pos-cmd,-",
     r"column 2 \(joint\.0\.motor-pos-xyz\): not a pin this reader knows; it knows "
     r"joint\.N\.motor-pos-cmd or joint\.N\.pos-cmd \(cmd\), .*or - to skip the column$"),
    (None, "joint.0.motor-pos-cmd,joint.0.motor-pos-fb,joint.9.motor-pos-cmd,-",
     r"column 3 \(joint\.9\.motor-pos-cmd\): joint 9 has no axis in joints \(0=x,1=y,2=z,"
     r"3=a,4=b,5=c,6=u,7=v,8=w\): add 9=<axis>$"),
    (None, "joint.0.motor-pos-cmd,joint.0.pos-cmd,joint.1.motor-pos-cmd,joint.1.motor-pos-fb",
     r"column 2 \(joint\.0\.pos-cmd\): a second cmd column of axis 'x' \(the first is column "
     r"1 \(joint\.0\.motor-pos-cmd\)\)$"),
    (None, "joint.0.motor-pos-cmd,-,joint.1.motor-pos-cmd,joint.1.motor-pos-fb",
     r"column 1 \(joint\.0\.motor-pos-cmd\): axis 'x' has cmd but no fb column"),
    (None, "joint.0.motor-pos-cmd,,joint.1.motor-pos-cmd,joint.1.motor-pos-fb",
     r"column 2 has no name \(name a column to skip '-'\)$"),
    (None, "-,-,-,-", r"name no axis column$"),
])
def test_a_bad_halsampler_file_is_refused_naming_the_line_and_pin(tmp_path, edit, columns,
                                                                  message):
    path, written, _ = halsampler_file(tmp_path)
    if edit:
        lines = path.read_text().splitlines()
        lines[49] = edit(lines[49])
        write_lines(path, lines)
    with pytest.raises(LogError, match=message):
        read_halsampler(path, columns or written, PERIOD)


def test_a_nan_in_a_skipped_column_is_not_read(tmp_path):
    path, columns, log = halsampler_file(tmp_path)
    lines = path.read_text().splitlines()
    write_lines(path, [f"{line} nan" for line in lines])
    back = read_halsampler(path, columns + ",-", PERIOD)
    assert_same(log, back)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"period": 0.0}, r"period 0\.0 is not a time step > 0 s$"),
    ({"period": float("nan")}, r"period nan is not a time step"),
    ({"joints": "0=x,1"}, r"joints '0=x,1': 1= is not <joint number>=<axis name>"),
    ({"joints": {0: "x", 1: "x"}}, r"joint 1 or axis 'x' twice$"),
    ({"joints": {"a": "x"}}, r"a=x is not <joint number>=<axis name>"),
])
def test_bad_halsampler_arguments_are_refused(tmp_path, kwargs, message):
    path, columns, _ = halsampler_file(tmp_path)
    with pytest.raises(LogError, match=message):
        read_halsampler(path, columns, **{"period": PERIOD, **kwargs})


def test_a_tagged_row_too_long_or_a_short_halsampler_log_is_refused(tmp_path):
    path, columns, _ = halsampler_file(tmp_path, tag=True)
    lines = path.read_text().splitlines()
    write_lines(path, [*lines[:70], lines[70] + " 0.5", *lines[71:]])
    with pytest.raises(LogError, match=r"line 71: 6 fields; columns names 4 and -t's sample "
                                       r"number: 5$"):
        read_halsampler(path, columns, PERIOD)
    write_lines(path, lines[:MIN_SAMPLES - 1])
    with pytest.raises(LogError, match=r"h\.txt: has 99 samples; a log needs 100 or more$"):
        read_halsampler(path, columns, PERIOD)


# ------------------------------------------------------------------------------ read_log


def test_read_log_reads_a_csv_or_a_halsampler_file_by_its_first_line(tmp_path):
    log = make_log()
    write_csv(log, tmp_path / "a.csv", length_unit="inch")
    assert_same(log, read_log(tmp_path / "a.csv", length_unit="inch"), ulps=2)
    path, columns, hal = halsampler_file(tmp_path, tag=True)
    assert_same(hal, read_log(path, columns=columns.split(","), period=PERIOD))
    write_lines(tmp_path / "b.csv", ["", "TIME,x_cmd,x_fb", *LINES[1:]], encoding="utf-8-sig")
    assert read_log(tmp_path / "b.csv").names == ("x",)


def test_read_log_says_what_a_halsampler_file_needs_and_a_csv_does_not(tmp_path):
    path, columns, _ = halsampler_file(tmp_path)
    with pytest.raises(LogError, match=r"h\.txt: has no CSV header with a time column, so it is "
                                       r"read as halsampler output, which needs columns and "
                                       r"period: columns= the HAL pin"):
        read_log(path)
    with pytest.raises(LogError, match=r"which needs period: "):
        read_log(path, columns=columns)
    write_csv(make_log(), tmp_path / "a.csv")
    with pytest.raises(LogError, match=r"a\.csv: is a CSV \(its header has a time column\): "
                                       r"columns, period are for halsampler files; leave them"):
        read_log(tmp_path / "a.csv", columns=columns, period=PERIOD)


# ------------------------------------------------------------------------------ writing


def test_writes_are_atomic_and_leave_no_temp_file(tmp_path, monkeypatch):
    log = make_log()
    target = tmp_path / "a.csv"
    target.write_text("old")
    write_csv(log, target)
    assert read_csv(target).names == ("x", "y")
    uneven = ServoLog(log.time ** 1.5, log.axes)
    write_halsampler(log, tmp_path / "h.txt")
    before = (tmp_path / "h.txt").read_text()
    with pytest.raises(LogError, match=r"h\.txt: the log's time is not on a grid of steps of"):
        write_halsampler(uneven, tmp_path / "h.txt")
    assert (tmp_path / "h.txt").read_text() == before
    assert sorted(os.listdir(tmp_path)) == ["a.csv", "h.txt"]

    def interrupted(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_csv(make_log(names=("z",)), target)
    monkeypatch.undo()
    assert read_csv(target).names == ("x", "y")
    assert sorted(os.listdir(tmp_path)) == ["a.csv", "h.txt"]
    with pytest.raises(LogError, match=r"grid of multiples of its period"):
        write_halsampler(ServoLog(log.time + 0.3 * PERIOD, log.axes), tmp_path / "t.txt",
                         tag=True)
    assert sorted(os.listdir(tmp_path)) == ["a.csv", "h.txt"]


# ------------------------------------------------------------------------------ the data model


def test_window_takes_t0_up_to_not_including_t1():
    log = make_log(n=400)
    part = log.window(0.1, 0.2)
    inside = (log.time >= 0.1) & (log.time < 0.2)
    assert inside.sum() == 100
    np.testing.assert_array_equal(part.time, log.time[inside])
    for a, b in zip(log.axes, part.axes, strict=True):
        for kind in KINDS:
            np.testing.assert_array_equal(getattr(b, kind), getattr(a, kind)[inside])
    assert part.period == pytest.approx(PERIOD) and part.duration == pytest.approx(0.099)
    assert log.window(-1.0, 1e9).time.size == 400
    with pytest.raises(ValueError, match=r"window \[0\.5, 0\.6\) s holds 0 samples of made"):
        log.window(0.5, 0.6)


def test_the_model_checks_its_arrays_and_names():
    log = make_log()
    with pytest.raises(ValueError, match=r"made has no axis 'z': its axes are x, y$"):
        log.axis("z")
    assert log.axis("y") is log.axes[1]
    with pytest.raises(ValueError, match="strictly increasing"):
        ServoLog(log.time[::-1], log.axes)
    with pytest.raises(ValueError, match="names unique"):
        ServoLog(log.time, (log.axes[0], log.axes[0]))
    with pytest.raises(ValueError, match=re.escape("axis name 'X'")):
        AxisLog("X", log.time, log.time)
    with pytest.raises(ValueError, match="differ in length"):
        AxisLog("x", log.time, log.time[1:])
    with pytest.raises(ValueError, match="read-only"):
        log.time[0] = 1.0


# ------------------------------------------------------------------------------ encoder_step


def test_encoder_step_recovers_the_quantisation_step():
    rng = np.random.default_rng(3)
    # moves of up to thousands of steps, and some smallest moves of 2 steps
    x = 0.02 * np.sin(np.linspace(0, 600, 3000)) + 1e-7 * rng.normal(size=3000)
    for step in (1e-6, 0.5e-6, 0.005 / 4096):
        quantised = np.round(x / step) * step
        assert encoder_step(quantised) == step  # exactly: its last bits are not noise
        # halsampler prints mm with six decimals: a step that is no decimal is rounded
        printed = np.array([float(f"{v:f}") for v in quantised * 1e3]) * 1e-3
        assert encoder_step(printed) == pytest.approx(step, rel=1e-6)
    counts = np.cumsum(rng.choice([2, 3, -2, -3], size=1000))  # moves of 2 or 3 counts
    assert encoder_step(counts * 1e-6) == 1e-6


def test_encoder_step_is_none_for_unquantised_or_too_little_data():
    rng = np.random.default_rng(4)
    x = 0.02 * np.sin(np.linspace(0, 20, 3000))
    assert encoder_step(x + 1e-7 * rng.normal(size=x.size)) is None
    assert encoder_step(rng.normal(size=1000)) is None
    assert encoder_step(np.zeros(100)) is None
    assert encoder_step(np.arange(10) * 1e-6) is None
    with pytest.raises(ValueError, match="finite"):
        encoder_step([0.0, np.nan])
