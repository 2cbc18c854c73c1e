"""G-code import: lengths of lines and arcs in every form, feedrates, and strict errors."""

from __future__ import annotations

import functools
import math
import pathlib
import pickle
import re

import numpy as np
import pytest

import contour_gym.paths as cgp

PART = """%
(test part: lines and arcs in both directions)
N10 G21 G90 G17 ; metric, absolute
N20 G0 X0 Y0            (zero-length rapid: skipped)
N30 G1 X50 F600
N40 G3 X60 Y10 I0 J10   ; CCW quarter, I/J form
N50 G1 Y40
N60 G3 X50 Y50 R10      ; CCW quarter, R form
N70 G1 X20
N80 G2 X10 Y60 R10      ; CW quarter, R form
N90 G91 G1 Y20          ; incremental
N100 G2 X-10 Y-10 R-10  ; CW three-quarter arc, negative R
N110 G90 G20 G1 X0 Y1 F10  ; inch
N120 G21 Y0
/N130 G2 I-10 J0        ; full clockwise circle, block delete off
N140 M30
N150 G1 X999            ; after the end: ignored
"""

def _line(nword):
    """Text line number (1-based) of the block with line number word N<nword>."""
    return next(i for i, t in enumerate(PART.splitlines(), 1) if t.lstrip("/").startswith(
        f"N{nword} "))


PART_LENGTH_MM = 50 + 5 * math.pi + 30 + 5 * math.pi + 30 + 5 * math.pi + 20 + 15 * math.pi \
    + (70 - 25.4) + 25.4 + 20 * math.pi


def test_part_has_its_exact_length():
    path = cgp.from_gcode(PART)
    assert path.dim == 2
    assert path.length == pytest.approx(PART_LENGTH_MM * 1e-3, abs=1e-12)
    assert path.closed  # ends at the origin where it started
    # each arc is where the program says
    np.testing.assert_allclose(path.point(0.05 + 5e-3 * math.pi / 2),
                               [0.05 + 0.01 * math.sin(math.pi / 4),
                                0.01 - 0.01 * math.cos(math.pi / 4)], atol=1e-15)
    kinds = path.table.kind
    assert list(kinds).count(cgp.HELIX) == 5 and list(kinds).count(cgp.LINE) == 6


def test_arc_directions_and_centres():
    path = cgp.from_gcode(PART)
    lines = path.segment_lines
    curv = {int(ln): path.signed_curvature(0.5 * (path.table.s0[i] + path.table.s0[i + 1]))
            for i, ln in enumerate(lines) if path.table.kind[i] == cgp.HELIX}
    assert sorted(curv) == [_line(n) for n in (40, 60, 80, 100, 130)]
    assert curv[_line(40)] == pytest.approx(100.0)  # G3: turning left
    assert curv[_line(60)] == pytest.approx(100.0)
    assert curv[_line(80)] == pytest.approx(-100.0)  # G2: turning right
    assert curv[_line(100)] == pytest.approx(-100.0)
    assert curv[_line(130)] == pytest.approx(-100.0)
    i100 = int(np.nonzero(lines == _line(100))[0][0])
    seg = path.table.s0[i100 + 1] - path.table.s0[i100]
    assert seg == pytest.approx(15e-3 * math.pi, abs=1e-15)  # negative R: the long way
    np.testing.assert_allclose(path.table.data[i100, :3], [0.01, 0.07, 0.0], atol=1e-15)
    # the full circle is centred 10 mm to the left of the origin
    i130 = int(np.nonzero(lines == _line(130))[0][0])
    np.testing.assert_allclose(path.table.data[i130, :3], [-0.01, 0.0, 0.0], atol=1e-15)


def test_feedrates_per_segment():
    path = cgp.from_gcode(PART)
    feed = path.segment_feedrates
    lines = path.segment_lines
    assert feed.shape == (path.table.n_segments,)
    np.testing.assert_allclose(feed[lines == _line(30)], 0.6 / 60.0)  # 600 mm/min
    np.testing.assert_allclose(feed[lines == _line(100)], 0.6 / 60.0)  # F is modal
    np.testing.assert_allclose(feed[lines == _line(110)], 10 * 0.0254 / 60.0)  # 10 in/min
    np.testing.assert_allclose(feed[lines == _line(120)], 10 * 0.0254 / 60.0)
    assert _line(20) not in lines  # the zero-length move was skipped
    assert not path.rapid.any()
    with pytest.raises(cgp.GcodeError, match="line 2: a feed move before any F word"):
        cgp.from_gcode("G0 X5\nG1 X10\nG1 X20 F120")  # a controller would not guess a feed
    first = cgp.from_gcode("G0 X5\nG1 X10\nG1 X20 F120", default_feed=0.001)
    assert first.rapid.tolist() == [True, False, False]
    assert np.isnan(first.segment_feedrates[0]) and first.segment_feedrates[1] == 0.001
    assert first.segment_feedrates[2] == pytest.approx(0.002)


def test_helical_arc_is_3d_with_exact_length():
    path = cgp.from_gcode("G1 X10 F100\nG3 X10 Y0 Z4 I-10 J0\nG2 X0 Y10 Z6 R10")
    assert path.dim == 3
    turn = math.hypot(2 * math.pi * 10, 4)
    quarter = math.hypot(10 * math.pi / 2, 2)  # CW quarter about (10, 10)
    assert path.length == pytest.approx((10 + turn + quarter) * 1e-3, abs=1e-12)
    np.testing.assert_allclose(path.point(path.length), [0.0, 0.01, 0.006], atol=1e-15)


def test_inch_incremental_program():
    path = cgp.from_gcode("G20 G91\nG1 X1 Y0 F5\nG1 X0 Y2\nG3 X-1 Y1 I-1 J0")
    inch = 0.0254
    assert path.length == pytest.approx(inch * (1 + 2 + math.pi / 2), abs=1e-12)
    np.testing.assert_allclose(path.point(path.length), [0.0, 3 * inch], atol=1e-15)


def test_small_radius_mismatch_is_absorbed():
    path = cgp.from_gcode("G1 X10 F100\nG3 X0 Y10.0000005 I-10 J0")
    np.testing.assert_allclose(path.point(path.length), [0.0, 0.0100000005], atol=1e-15)
    assert path.length == pytest.approx(0.01 + 0.01 * math.pi / 2, abs=1e-9)


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        ("G1 X10 F100\nG1 X20 A5", 2, "unsupported word A"),
        ("G1 X10 F100\n\nG68 X20", 3, "unsupported code G68"),  # G54 is now accepted
        ("G1 X10 F100\nM98 P100", 2, "unsupported code M98"),
        ("G1 X10 F100\nG3 X20 Y0 I3 J0", 2, "radius"),
        ("G1 X10 F100\nG2 X20 Y5", 2, "centre"),
        ("G17 G1 X10 F100\nG2 X20 I5 K1", 2, "K word is not used by arcs in the G17"),
        ("G18 G1 X10 F100\nG2 X20 I5 J1", 2, "J word is not used by arcs in the G18"),
        ("X10 Y10", 1, "without a motion mode"),
        ("G1 X10 X20", 1, "twice"),
        ("G0 G1 X10", 1, "two motion codes"),
        ("G1 X10 F100\nG1 X20 I5", 2, "need G2 or G3"),
        ("G1 X10 F100\nG2 X20 R2", 2, "smaller than half"),
        ("G1 X10 F100\nG2 X10 Y0 R2", 2, "full circle"),
        ("G1 X10 F100\nG3 X20 R5 I5", 2, "either I/J or R"),
        ("G1 X10 (comment", 1, "unclosed comment"),
        ("G1 X10 F-5", 1, "feedrate"),
        ("G1 X1.2.3", 1, "cannot read"),
        ("N5 G1 X$", 1, "cannot read"),
        ("G1 X10 F100\nG3 X10 Y0 I0 J0", 2, "radius is zero"),
    ],
)
def test_errors_name_the_line(text, line, what):
    with pytest.raises(ValueError, match=rf"line {line}:.*{what}"):
        cgp.from_gcode(text)


def test_program_without_motion_is_rejected():
    with pytest.raises(ValueError, match="no motion"):
        cgp.from_gcode("(nothing)\nG21 G90\nM30")
    with pytest.raises(ValueError, match="text must be a str"):
        cgp.from_gcode(b"G1 X1")  # type: ignore[arg-type]


def test_start_position_and_lowercase():
    path = cgp.from_gcode("g1 x10 y0 f100", start=(0.0, 0.005))
    np.testing.assert_allclose(path.point(0.0), [0.0, 0.005])
    assert path.length == pytest.approx(math.hypot(0.01, 0.005), abs=1e-15)


# dialects, per-segment program data and machine mapping -------------------------------------

DATA = pathlib.Path(__file__).parent / "data" / "gcode"
CORPUS = {"linuxcnc_pocket.ngc": 3, "grbl_engrave.gcode": 3, "cam_bracket.nc": 3,
          "fanuc_plate.nc": 3, "part_2d.ngc": 2, "arcs_3axis.ngc": 3}
MM = 1e-3
MM_MIN = 1e-3 / 60.0  # 1 mm/min in m/s


def _text(name):
    return (DATA / name).read_text()


def _at(text, snippet):
    """1-based text line holding ``snippet`` (which must occur on exactly one line)."""
    hits = [i for i, t in enumerate(text.splitlines(), 1) if snippet in t]
    assert len(hits) == 1, (snippet, hits)
    return hits[0]


def _segs(path, line):
    idx = np.flatnonzero(path.segment_lines == line)
    assert idx.size, line
    return idx


def _end_point(path, i):
    return path.point(path.table.s0[i + 1])


def test_corpus_is_complete_and_small():
    assert sorted(p.name for p in DATA.iterdir()) == sorted(CORPUS)
    for name in CORPUS:
        assert len(_text(name).splitlines()) < 100


@pytest.mark.parametrize("name", sorted(CORPUS))
def test_every_corpus_program_parses(name):
    path = cgp.from_gcode(_text(name))
    n = path.table.n_segments
    assert path.dim == CORPUS[name]
    assert np.isfinite(path.table.data).all() and path.length > 0.0
    for arr in (path.segment_feedrates, path.segment_lines, path.rapid, path.cutting,
                path.exact_stop, path.blend_tolerance, path.path_control, path.dwell_before):
        assert arr.shape == (n,) and not arr.flags.writeable
    assert path.exact_stop[-1]
    assert not (path.cutting & path.rapid).any()
    assert np.isnan(path.segment_feedrates[path.rapid]).all()
    back = pickle.loads(pickle.dumps(path))
    assert type(back) is cgp.GcodePath and back.dwell_after_end == path.dwell_after_end
    for attr in ("segment_feedrates", "segment_lines", "rapid", "cutting", "exact_stop",
                 "blend_tolerance", "path_control", "dwell_before"):
        np.testing.assert_array_equal(getattr(back, attr), getattr(path, attr))
    moved = path.transformed(offset=np.full(path.dim, 0.01))
    assert isinstance(moved, cgp.GcodePath)
    np.testing.assert_array_equal(moved.exact_stop, path.exact_stop)
    np.testing.assert_array_equal(moved.cutting, path.cutting)


def test_linuxcnc_program_modes_dwell_and_cutting():
    text = _text("linuxcnc_pocket.ngc")
    path = cgp.from_gcode(text)
    at = functools.partial(_at, text)
    outline = np.concatenate([_segs(path, at(s)) for s in (
        "G1 X50 F800", "G3 X60 Y20 R10", "G1 Y40", "G3 X50 Y50", "G1 X10", "G3 X0 Y40",
        "G1 Y20", "G3 X10 Y10 I10")])
    np.testing.assert_allclose(path.blend_tolerance[outline], 0.01 * MM)  # G64 P0.01 mm
    assert (path.path_control[outline] == 64.0).all()
    assert path.cutting[outline].all() and not path.exact_stop[outline[:-1]].any()
    assert path.exact_stop[outline[-1]]  # a rapid follows
    np.testing.assert_allclose(path.segment_feedrates[outline], 800 * MM_MIN)
    plunge = _segs(path, at("(outline") - 1)  # G1 Z-1 F200
    assert not path.cutting[plunge].any() and not path.rapid[plunge].any()
    # G61: exact stop at every block end, no blending
    slot = np.concatenate([_segs(path, at(s)) for s in (
        "G0 X20 Y25", "G1 X40 F500", "G1 Y35", "G1 X20", "G1 Y25")])
    assert (path.path_control[slot] == 61.0).all() and (path.blend_tolerance[slot] == 0).all()
    assert path.exact_stop[slot].all()
    # G4 P0.5: seconds, at the start of the next move
    assert path.dwell_before[_segs(path, at("G1 Y35"))[0]] == 0.5
    assert path.dwell_before.sum() == 0.5 and path.dwell_after_end == 0.0
    # G64 P0.02 applies to the retract after the slot
    retract = _segs(path, at("G64 P0.02") + 1)
    np.testing.assert_allclose(path.blend_tolerance[retract], 0.02 * MM)
    # G61.1: no blending, stop only where the tangent jumps
    ln = {s: _segs(path, at(s))[-1] for s in ("G1 X90 F600", "G3 X90 Y30 J10", "G1 X70")}
    assert (path.path_control[list(ln.values())] == 61.1).all()
    assert (path.blend_tolerance[list(ln.values())] == 0.0).all()
    assert not path.exact_stop[ln["G1 X90 F600"]]  # tangent into the arc
    assert not path.exact_stop[ln["G3 X90 Y30 J10"]]  # tangent out of the arc
    assert path.exact_stop[ln["G1 X70"]]  # 90 degree corner
    # plain G64 at the end: controller default
    assert np.isnan(path.blend_tolerance[_segs(path, at("G0 X0 Y0"))]).all()


def test_linuxcnc_tool_length_shifts_z():
    text = _text("linuxcnc_pocket.ngc")
    plain = cgp.from_gcode(text)
    long_tool = cgp.from_gcode(text, tool_lengths={1: 0.05})
    assert long_tool.table.n_segments == plain.table.n_segments
    # G43 H1 comes before the first move: every point after the start is 50 mm higher
    s_long = long_tool.table.s0[1:]
    np.testing.assert_allclose(long_tool.point(s_long) - plain.point(plain.table.s0[1:]),
                               np.tile([0.0, 0.0, 0.05], (s_long.size, 1)), atol=1e-15)
    np.testing.assert_array_equal(long_tool.point(0.0), plain.point(0.0))  # machine start
    np.testing.assert_array_equal(long_tool.cutting, plain.cutting)  # work Z is unchanged


def test_grbl_program_and_its_xy_machine_timing():
    text = _text("grbl_engrave.gcode")
    path = cgp.from_gcode(text)
    at = functools.partial(_at, text)
    assert path.dwell_before[0] == 1.5  # G4 P1.5 before the first move
    helix = _segs(path, at("; helix"))
    assert helix.size == 4  # one turn cut into quarter pieces
    assert path.cutting[helix].all()
    rate = 0.1
    xy = path.for_machine(2, rapid_rate=rate)
    assert xy.dim == 2
    kept = {int(ln): i for i, ln in enumerate(xy.segment_lines)}
    # Z-only moves are gone; their time waits at the start of the next X-Y move
    z_only = [at("G4 P1.5") + 1, at("G1 Z-0.500"), at("G0 X50.000") - 1, at("G1 Z0.000")]
    assert not set(z_only) & set(kept)  # the two G0 Z3.000, the plunge, the approach
    assert xy.dwell_before[kept[at("G0 X5.000 Y0.000")]] == pytest.approx(1.5 + 3 * MM / rate)
    assert xy.dwell_before[kept[at("G1 X25.000 F600")]] == pytest.approx(3.5 * MM / (120 * MM_MIN))
    assert xy.dwell_before[kept[at("G0 X50.000")]] == pytest.approx(3.5 * MM / rate)
    ramp = kept[at("; ramp")]
    assert xy.dwell_before[ramp] == pytest.approx(3 * MM / (300 * MM_MIN))
    assert xy.dwell_before[kept[at("G0 X0.000 Y0.000")]] == pytest.approx(4 * MM / rate)
    assert xy.dwell_after_end == 0.0
    assert xy.exact_stop[kept[at("G3 X5.000 Y0.000")]]  # Z retract follows
    # mixed moves keep their duration: feed * xy / xyz
    assert xy.segment_feedrates[ramp] == pytest.approx(300 * MM_MIN * 5 / math.hypot(5, 0.5))
    turn = kept[at("; helix")]
    assert xy.table.kind[turn] == cgp.HELIX and list(xy.segment_lines).count(at("; helix")) == 1
    assert xy.table.s0[turn + 1] - xy.table.s0[turn] == pytest.approx(20 * math.pi * MM)
    assert xy.segment_feedrates[turn] == pytest.approx(
        400 * MM_MIN * 20 * math.pi / math.hypot(20 * math.pi, 0.5))
    seg_t = np.diff(path.table.s0)[helix].sum() / path.segment_feedrates[helix[0]]
    assert np.diff(xy.table.s0)[turn] / xy.segment_feedrates[turn] == pytest.approx(seg_t)
    np.testing.assert_allclose(xy.point(xy.table.s0[turn + 1]), [0.055, 0.015], atol=1e-15)
    assert not xy.cutting[kept[at("G0 X50.000")]] and xy.cutting[turn]
    # every kept move starts where the program's move starts, seen from above
    firsts = [_segs(path, ln)[0] for ln in xy.segment_lines]
    np.testing.assert_allclose(xy.point(xy.table.s0[:-1]),
                               path.point(path.table.s0[firsts])[:, :2], atol=1e-15)


OFFSET = (0.1, 0.05, -0.2)
TOOL = 0.08


def test_cam_program_offsets_tool_length_and_machine_moves():
    text = _text("cam_bracket.nc")
    at = functools.partial(_at, text)
    plain = cgp.from_gcode(text)
    path = cgp.from_gcode(text, work_offsets={"G54": OFFSET}, tool_lengths={1: TOOL})
    assert path.closed and plain.closed  # G53 returns to the machine origin
    first_g53 = at("(WHEN USING") + 1  # G53 G0 Z0.
    last_g53 = at("G53 G0 X0. Y0.") - 1  # G53 G0 Z0.
    assert first_g53 not in path.segment_lines  # G53 Z0 from the origin: zero length
    g53 = np.concatenate([_segs(path, ln) for ln in (last_g53, last_g53 + 1)])
    assert path.rapid[g53].all() and np.isnan(path.segment_feedrates[g53]).all()
    # cutting segments are the plain program shifted by offset + tool length
    shift = np.array(OFFSET) + [0.0, 0.0, TOOL]
    cut = np.flatnonzero(path.cutting)
    np.testing.assert_array_equal(cut, np.flatnonzero(plain.cutting))
    np.testing.assert_allclose(path.table.data[cut, :3] - plain.table.data[cut, :3],
                               np.tile(shift, (cut.size, 1)), atol=1e-15)
    assert len(cut) == 8
    np.testing.assert_allclose(path.point(path.table.s0[cut[0]]),
                               shift + [-3 * MM, -3 * MM, -1 * MM], atol=1e-15)
    # G43 Z15. H1: a rapid to 15 mm above the work in the work system
    g43 = _segs(path, at("G43 Z15. H1"))[0]
    np.testing.assert_allclose(_end_point(path, g43), shift + [-3 * MM, -3 * MM, 15 * MM],
                               atol=1e-15)
    # G53 G0 Z0. near the end: machine Z 0 whatever the offsets
    assert _end_point(path, _segs(path, last_g53)[0])[2] == 0.0
    # plunges do not cut
    plunges = [i for i in range(path.table.n_segments)
               if not path.rapid[i] and path.table.kind[i] == cgp.LINE
               and abs(path.table.data[i, 5]) == 1.0]
    assert len(plunges) == 2 and not path.cutting[plunges].any()
    # on an X-Y machine, the Z moves become waiting time
    rate = 0.5
    xy = path.for_machine(2, rapid_rate=rate)
    kept = {int(ln): i for i, ln in enumerate(xy.segment_lines)}
    z_before_cut = (15 * MM + OFFSET[2] + TOOL) - 0.0  # G43 rapid from machine Z 0
    expect = abs(z_before_cut) / rate + 10 * MM / rate + 6 * MM / (300 * MM_MIN)
    assert xy.dwell_before[kept[at("G1 X43. F1000.")]] == pytest.approx(expect)
    assert xy.dwell_before[kept[at("G1 X25. F1000.")]] == pytest.approx(
        10 * MM / rate + 6 * MM / (300 * MM_MIN))
    assert xy.dwell_before[kept[at("G53 G0 X0. Y0.")]] == pytest.approx(
        16 * MM / rate + abs(15 * MM + OFFSET[2] + TOOL) / rate)
    assert (xy.cutting == path.cutting[[_segs(path, ln)[-1] for ln in xy.segment_lines]]).all()


def test_fanuc_program():
    text = _text("fanuc_plate.nc")
    at = functools.partial(_at, text)
    path = cgp.from_gcode(text, work_offsets={"g54": (0.2, 0.1)}, tool_lengths={1: 0.1})
    plunge = _segs(path, at("N90"))[0]
    first_cut = _segs(path, at("N120"))[0]
    assert path.exact_stop[plunge] and path.dwell_before[first_cut] == 0.5  # G04 X0.5
    for n in ("N120", "N130"):
        i = _segs(path, at(n))[-1]
        assert path.path_control[i] == 61.0 and path.exact_stop[i]
        assert path.blend_tolerance[i] == 0.0
    arc = _segs(path, at("N150"))[0]
    assert path.path_control[arc] == 64.0 and np.isnan(path.blend_tolerance[arc])
    assert path.cutting[arc] and not path.exact_stop[arc]
    np.testing.assert_allclose(path.point(path.table.s0[first_cut]),
                               [0.2, 0.1, -2 * MM + 0.1], atol=1e-15)
    # G91 G28 Z0. then G28 X0. Y0.: rapids home to the machine origin
    home = np.concatenate([_segs(path, at(n)) for n in ("N200", "N210")])
    assert path.rapid[home].all() and path.table.n_segments - 1 == home[-1]
    np.testing.assert_allclose(path.point(path.length), [0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(path.point(path.table.s0[home[0]]), [0.2, 0.1, 0.15],
                               atol=1e-15)
    assert path.exact_stop[_segs(path, at("N180"))[0]]  # M05 follows


def test_2d_part_and_its_3d_machine_form():
    text = _text("part_2d.ngc")
    path = cgp.from_gcode(text)
    assert path.dim == 2
    np.testing.assert_array_equal(path.cutting, ~path.rapid)  # 2-D: every feed move cuts
    outline = path.table.s0[_segs(path, 12)[0] + 1] - path.table.s0[_segs(path, 5)[0]]
    assert outline == pytest.approx((180 + 20 * math.pi) * MM, abs=1e-12)
    assert path.for_machine(2, rapid_rate=1.0) is path
    high = path.for_machine(3, rapid_rate=1.0, z=0.01)
    assert high.dim == 3 and high.length == path.length
    s = np.linspace(0.0, path.length, 41)
    np.testing.assert_allclose(high.point(s), np.column_stack([path.point(s), np.full(41, 0.01)]),
                               atol=1e-15)
    for attr in ("segment_feedrates", "segment_lines", "rapid", "cutting", "exact_stop",
                 "blend_tolerance", "dwell_before"):
        np.testing.assert_array_equal(getattr(high, attr), getattr(path, attr))
    assert high.for_machine(2, rapid_rate=1.0).length == pytest.approx(path.length)


def test_arcs_in_every_plane_and_the_xy_machine_refusal():
    text = _text("arcs_3axis.ngc")
    at = functools.partial(_at, text)
    path = cgp.from_gcode(text)

    def mid(snippet):
        i = _segs(path, at(snippet))
        return path.point(0.5 * (path.table.s0[i[0]] + path.table.s0[i[-1] + 1]))

    np.testing.assert_allclose(mid("G18 G2 X20"), [0.01, 0.0, -0.01], atol=1e-15)
    np.testing.assert_allclose(mid("G19 G3"), [0.02, 0.01, -0.01], atol=1e-15)
    np.testing.assert_allclose(mid("G18 G2 X0"), [0.01, 0.02, 0.01], atol=1e-15)
    helix = _segs(path, at("G17 G2"))
    rise = path.table.s0[helix[-1] + 1] - path.table.s0[helix[0]]
    assert rise == pytest.approx(math.hypot(20 * math.pi, 6) * MM, abs=1e-12)
    np.testing.assert_allclose(_end_point(path, helix[-1]), [0.0, 0.02, -0.006], atol=1e-15)
    cutting = {ln: bool(path.cutting[_segs(path, at(ln))].all())
               for ln in ("G18 G2 X20", "G19 G3", "G18 G2 X0", "G17 G2")}
    assert cutting == {"G18 G2 X20": True, "G19 G3": True, "G18 G2 X0": False, "G17 G2": True}
    # the bulge reaches 10 mm: it cuts when the surface is higher
    high = cgp.from_gcode(text, cut_z=0.0105)
    assert high.cutting[_segs(high, at("G18 G2 X0"))].all()
    with pytest.raises(cgp.GcodeError, match=rf"line {at('G18 G2 X20')}:.*XZ plane \(G18\)"):
        path.for_machine(2, rapid_rate=0.5)
    with pytest.raises(cgp.GcodeError, match=r"line 2:.*YZ plane \(G19\)") as info:
        cgp.from_gcode("G1 X1 F100\nG19 G2 Y10 J5").for_machine(2, rapid_rate=0.5)
    assert info.value.line == 2 and info.value.word == "G19"


@pytest.mark.parametrize(
    ("text", "line", "word"),
    [
        ("G1 X10 F100\nG1 X[1+2]", 2, r"X\[1\+2\]"),
        ("#1 = 5\nG1 X#1", 1, "#1"),
        ("G1 X10 F100\nG1 X#<len> Y2", 2, "X#<len>"),
        ("O100 sub\nG1 X1\nO100 endsub", 1, "O100 sub"),
        ("G1 X1 F100\nO100 call [2]", 2, "O100 call"),
        ("G1 X1 F100\no100 endsub", 2, "O100 endsub"),
        ("G1 X1 F100\nO101 while [#1 LT 3]", 2, "O101 while"),
        ("O<probe> sub", 1, "O<probe> sub"),
        ("O1001\nG1 X1 F100\nO2000\nG1 X2", 3, "O2000"),
        ("O1001 G1 X1 F100", 1, "O1001"),
        ("G1 X10 F100\nM98 P100", 2, "M98"),
        ("G1 X10 F100\nM99", 2, "M99"),
        ("G1 X10 F100\nG65 P9010", 2, "G65"),
        ("G0 Z5\nG81 X10 Y10 Z-2 R1 F100", 2, "G81"),
        ("G0 Z5\nG83 X10 Y10 Z-2 R1 Q1 F100", 2, "G83"),
        ("G73 X1", 1, "G73"),
        ("G74 X1", 1, "G74"),
        ("G76 X1", 1, "G76"),
        ("G89 X1", 1, "G89"),
        ("G93 G1 X10 F2", 1, "G93"),
        ("G95 G1 X10 F0.1", 1, "G95"),
        ("G1 X1 F100\nG41 D1 G1 X10", 2, "G41"),
        ("G42 G1 X10 F100", 1, "G42"),
        ("G43.1 Z0.1", 1, "G43.1"),
        ("G30 Z0", 1, "G30"),
        ("G1 X1 F100\nG28", 2, "G28"),
        ("G92 X0", 1, "G92"),
        ("G10 L2 P1 X0", 1, "G10"),
        ("G68 X0 Y0 R45", 1, "G68"),
        ("G1 X1 F100\nM47", 2, "M47"),
        ("G1 X1 A5 F100", 1, "A5"),
        ("G1 X1 F100\nG4", 2, "G4"),
        ("G4 P-1", 1, "P-1"),
        ("G4 P1 X2", 1, "X2"),
        ("G1 X10 F100\nG4 P1 Y5", 2, "Y5"),
        ("G1 X10 P2 F100", 1, "P2"),
        ("G4 G64 P2", 1, "P2"),
        ("G1 X10 H1 F100", 1, "H1"),
        ("G1 X10 Q1 F100", 1, "Q1"),
        ("G64 P-0.1", 1, "P-0.1"),
        ("G43 G1 Z5 F100", 1, "G43"),
        ("G1 X1 F100\nG53 G91 G0 Z0", 2, "G53"),
        ("G1 X1 F100\nG2\nG53 X1", 3, "G53"),
        ("G1 X1 F100\nG53 G0 X1 I1", 2, "I1"),
        ("G1 X1 F100\nG53 G0", 2, "G53"),
        ("G90.1\nG1 X10 F100\nG2 X20 Y0 I15", 3, "J"),
        ("G1 X1 F100\nM3 M5", 2, "M5"),
        ("G1 X1 F100\nT1.5 M6", 2, "T1.5"),
        ("G1 X1 F100\nG2 X3 R1 I1", 2, "R1"),
    ],
)
def test_rejected_constructs_name_line_and_word(text, line, word):
    with pytest.raises(cgp.GcodeError, match=rf"line {line}:.*{word}") as info:
        cgp.from_gcode(text)
    assert info.value.line == line
    assert re.fullmatch(word, info.value.word, flags=re.IGNORECASE), (info.value.word, word)


def test_offsets_and_tool_lengths_must_be_given_for_what_is_used():
    with pytest.raises(cgp.GcodeError, match=r"line 2:.*G55") as info:
        cgp.from_gcode("G1 X1 F100\nG55 G1 X2", work_offsets={"G54": (0, 0, 0)})
    assert info.value.word == "G55"
    with pytest.raises(cgp.GcodeError, match=r"line 1:.*G54"):
        cgp.from_gcode("G1 X1 F100", work_offsets={"G55": (0.1, 0.0)})
    with pytest.raises(cgp.GcodeError, match=r"line 2:.*H2"):
        cgp.from_gcode("G1 X1 F100\nG43 H2 Z5", tool_lengths={1: 0.1})
    with pytest.raises(ValueError, match="work_offsets key"):
        cgp.from_gcode("G1 X1 F100", work_offsets={"G60": (0, 0)})
    with pytest.raises(ValueError, match="must be finite"):
        cgp.from_gcode("G1 X1 F100", work_offsets={"G54": (0, math.nan)})
    with pytest.raises(ValueError, match="tool_lengths key 0"):
        cgp.from_gcode("G1 X1 F100", tool_lengths={0: 0.1})
    # H0 is no tool; G43 without H takes the tool loaded by M6; G49 cancels
    path = cgp.from_gcode("G43 H0 G1 Z-1 F100\nT2 M6\nG43 Z-1\nG49 Z-1\nG59.1 X1",
                          tool_lengths={2: 0.03}, work_offsets={"G54": (0, 0, 0),
                                                                "G59.1": (0.5, 0, 0)})
    ends = path.point(path.table.s0[1:])
    np.testing.assert_allclose(ends, [[0, 0, -0.001], [0, 0, 0.029], [0, 0, -0.001],
                                      [0.501, 0, -0.001]], atol=1e-15)


def test_program_end_stops_reading():
    text = "%\nG1 X10 F100\nM30\nG1 X20\nG93 #1 [garbage\n"
    assert cgp.from_gcode(text).length == pytest.approx(0.01)
    assert cgp.from_gcode("G1 X10 F100\nM2\nG1 X20").length == pytest.approx(0.01)
    # the block's own motion runs before M30 (RS274 order of execution)
    assert cgp.from_gcode("G1 X10 F100 M30\nG1 X20").length == pytest.approx(0.01)
    # a second % ends the program; one at the start opens it
    assert cgp.from_gcode("%\nG1 X10 F100\n%\nG1 X20 A$").length == pytest.approx(0.01)
    assert cgp.from_gcode("G1 X10 F100\n%\nG1 X20").length == pytest.approx(0.01)
    path = cgp.from_gcode("%\nO0001 (NAME)\n(comment; with a semicolon)\nG1 X10 F100\n%")
    assert path.length == pytest.approx(0.01)
    assert cgp.from_gcode("O0001\n%\nG1 X10 F100\n%").length == pytest.approx(0.01)


def test_arc_centre_modes_and_planes():
    quarter = (10 + 5 * math.pi) * MM
    absolute = cgp.from_gcode("G90.1 G1 X10 F100\nG3 X0 Y10 I0 J0")
    incremental = cgp.from_gcode("G91.1 G1 X10 F100\nG3 X0 Y10 I-10 J0")
    assert absolute.length == pytest.approx(quarter, abs=1e-12)
    np.testing.assert_array_equal(absolute.table.data, incremental.table.data)
    # absolute centres are program coordinates: they move with the work offset
    shifted = cgp.from_gcode("G90.1 G1 X10 F100\nG3 X0 Y10 I0 J0",
                             work_offsets={"G54": (0.1, 0.2, 0.0)}, start=(0.1, 0.2))
    np.testing.assert_allclose(shifted.table.data[1, :3], [0.1, 0.2, 0.0], atol=1e-15)
    # G18 uses I K, G19 uses J K; R works in every plane
    xz = cgp.from_gcode("G18 G3 X20 Z0 R10 F100")  # counter-clockwise seen from +Y: over the top
    np.testing.assert_allclose(xz.point(xz.length / 2), [0.01, 0.0, 0.01], atol=1e-15)
    for code in ("G2", "G3"):
        r_form = cgp.from_gcode(f"G18 {code} X10 Z10 R10 F100")
        ik_form = cgp.from_gcode(f"G18 {code} X10 Z10 F100 "
                                 + ("K10" if code == "G2" else "I10 K0"))
        np.testing.assert_allclose(r_form.table.data, ik_form.table.data, atol=1e-15)
    yz = cgp.from_gcode("G19 G2 Y20 Z0 J10 K0 F100")
    np.testing.assert_allclose(yz.point(yz.length / 2), [0.0, 0.01, 0.01], atol=1e-15)
    helix_y = cgp.from_gcode("G18 G2 X0 Z0 Y5 I10 K0 F100")  # full XZ turn rising along Y
    assert helix_y.dim == 3
    assert helix_y.length == pytest.approx(math.hypot(20 * math.pi, 5) * MM, abs=1e-12)
    np.testing.assert_allclose(helix_y.point(helix_y.length), [0, 0.005, 0], atol=1e-15)


def test_path_tolerance_units_and_default():
    inch = cgp.from_gcode("G20 G64 P0.001\nG1 X1 F10")
    assert inch.blend_tolerance[0] == pytest.approx(0.001 * 0.0254)
    assert np.isnan(cgp.from_gcode("G64 P0 Q0.01\nG1 X1 F10").blend_tolerance[0])
    default = cgp.from_gcode("G1 X1 F10\nG1 Y1")
    assert np.isnan(default.blend_tolerance).all() and (default.path_control == 64.0).all()
    assert default.exact_stop.tolist() == [False, True]  # G64 blends the corner


def test_stops_from_program_codes():
    path = cgp.from_gcode("G1 X1 F100\nG1 X2\nG4 P0\nG1 X3\nM0\nG1 X4\nM1\nG1 X5\n"
                          "M6\nG1 X6\nM5\nG1 X7\nM8\nG1 X8\nG0 X9\nG0 X10\nG1 X11")
    assert path.exact_stop.tolist() == [False, True, True, False, True, True, False,
                                        True, False, True, True]
    assert (path.dwell_before == 0.0).all()
    tail = cgp.from_gcode("G1 X1 F100\nG4 P2\nG4 X0.5\nM30")
    assert tail.dwell_after_end == 2.5 and tail.exact_stop.tolist() == [True]


def test_for_machine_arguments_and_empty_results():
    path = cgp.from_gcode("G1 X1 Z-1 F100")
    with pytest.raises(ValueError, match="dim must be 2 or 3"):
        path.for_machine(4, rapid_rate=1.0)
    with pytest.raises(ValueError, match="rapid_rate"):
        path.for_machine(2, rapid_rate=0.0)
    with pytest.raises(ValueError, match="z must be finite"):
        path.for_machine(2, rapid_rate=1.0, z=math.nan)
    with pytest.raises(ValueError, match="no X-Y motion"):
        cgp.from_gcode("G0 Z5\nG1 Z-1 F100").for_machine(2, rapid_rate=1.0)
    with pytest.raises(cgp.GcodeError, match=r"line 1: a feed move before any F word") as info:
        cgp.from_gcode("G1 Z-1\nG1 X1 F100").for_machine(2, rapid_rate=1.0)
    assert info.value.word == "F"
    # trailing Z moves become dwell_after_end
    flat = cgp.from_gcode("G1 X10 F600\nG0 Z5\nG4 P1").for_machine(2, rapid_rate=0.05)
    assert flat.dwell_after_end == pytest.approx(0.1 + 1.0)
    assert flat.table.n_segments == 1 and flat.exact_stop.tolist() == [True]


def test_gcode_error_is_a_value_error_that_pickles():
    err = cgp.GcodeError(7, "G93", "unsupported code G93 (inverse-time feed)")
    assert isinstance(err, ValueError) and str(err).startswith("G-code line 7: ")
    back = pickle.loads(pickle.dumps(err))
    assert (back.line, back.word, str(back)) == (7, "G93", str(err))


def test_gcode_path_constructor_defaults():
    old = cgp.from_gcode("G0 X5\nG1 X10 F120")
    path = cgp.GcodePath(old.table, "p", old.segment_feedrates, old.segment_lines, old.rapid)
    assert path.cutting.tolist() == [False, True]
    assert path.exact_stop.tolist() == [True, True]  # rapid to feed, end
    assert np.isnan(path.blend_tolerance).all() and path.dwell_after_end == 0.0
    with pytest.raises(ValueError, match="dwell_before"):
        cgp.GcodePath(old.table, "p", old.segment_feedrates, old.segment_lines, old.rapid,
                      dwell_before=[0.0, -1.0])
    with pytest.raises(ValueError, match="path_control"):
        cgp.GcodePath(old.table, "p", old.segment_feedrates, old.segment_lines, old.rapid,
                      path_control=[64.0, 62.0])
