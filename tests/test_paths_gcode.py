"""G-code import: lengths of lines and arcs in every form, feedrates, and strict errors."""

from __future__ import annotations

import math

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
    first = cgp.from_gcode("G0 X5\nG1 X10\nG1 X20 F120")
    assert first.rapid.tolist() == [True, False, False]
    assert np.isnan(first.segment_feedrates[:2]).all()
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
        ("G1 X10 F100\n\nG54 X20", 3, "unsupported code G54"),
        ("G1 X10\nM98 P100", 2, "unsupported code M98"),
        ("G1 X10 F100\nG3 X20 Y0 I3 J0", 2, "radius"),
        ("G1 X10 F100\nG2 X20 Y5", 2, "centre"),
        ("G18\nG1 X10", 1, "XY plane"),
        ("G19 G1 X10", 1, "XY plane"),
        ("X10 Y10", 1, "without a motion mode"),
        ("G1 X10 X20", 1, "twice"),
        ("G0 G1 X10", 1, "two motion codes"),
        ("G1 X10 F100\nG1 X20 I5", 2, "need G2 or G3"),
        ("G1 X10\nG2 X20 R2", 2, "smaller than half"),
        ("G1 X10\nG2 X10 Y0 R2", 2, "full circle"),
        ("G1 X10\nG3 X20 R5 I5", 2, "either I/J or R"),
        ("G1 X10 (comment", 1, "unclosed comment"),
        ("G1 X10 F-5", 1, "feedrate"),
        ("G1 X1.2.3", 1, "cannot read"),
        ("N5 G1 X$", 1, "cannot read"),
        ("G1 X10\nG3 X10 Y0 I0 J0", 2, "radius is zero"),
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
