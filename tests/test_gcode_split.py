"""Straight feed moves split in two on the program's grid, nothing else changed (issue 65)."""

from __future__ import annotations

import numpy as np
import pytest

from contour_gym.paths import feed_moves, from_gcode, split_moves

PROGRAM = (
    "N10 G21 G90\r\n"
    "N20 G0 X0.5 Y0.25\r\n"
    "N30 G1 X10.125 Y3.5 F800 (cut)\r\n"
    "N40 X-3. Y7.33\r\n"
    "N50 G2 X0 Y0 R9\r\n"
    "G1 X1 Y1 M8\r\n"
    "G01 X5 S100\r\n"
    "/G1 X9\r\n"
    "G1 F400 X12.5 Y-2\r\n"
    "M30\r\n"
)


def _same_path(a: str, b: str) -> float:
    # the largest distance between the two programs' paths at 4001 arc lengths, m
    pa, pb = from_gcode(a), from_gcode(b)
    assert pa.length == pytest.approx(pb.length, rel=1e-12)
    s = np.linspace(0.0, pa.length, 4001)
    return float(np.max(np.abs(pa.point(s) - pb.point(s))))


def test_plain_moves_split_on_the_line_and_on_the_grid() -> None:
    new, origin = split_moves(PROGRAM, range(1, 11))
    lines = new.splitlines(keepends=True)
    assert [lines[i] for i in range(len(lines)) if origin[i] != origin[min(i + 1, len(lines) - 1)]
            or i == len(lines) - 1] == PROGRAM.splitlines(keepends=True)
    first = [lines[i] for i in range(len(lines) - 1) if origin[i] == origin[i + 1]]
    # the straight feed moves in absolute mode: lines 3, 4, 9 (line 8 is a block delete, 5
    # an arc, 6 and 7 carry M and S words)
    assert sorted(origin[i] for i in range(len(lines) - 1) if origin[i] == origin[i + 1]) == [
        3, 4, 9]
    assert first[0] == "G1 X5.274 Y1.862 F800\r\n"  # exact: 62/125 of the way, F copied
    assert first[2].startswith("G1 X") and first[2].endswith(" F400\r\n")
    assert _same_path(PROGRAM, new) < 1e-12
    # the same feeds: each line of the new program runs at its origin's feed
    old, got = feed_moves(from_gcode(PROGRAM)), feed_moves(from_gcode(new))
    assert got == {line: old[origin[line - 1]] for line in got}


@pytest.mark.parametrize(("text", "lines", "split"), [
    ("G91\nG1 X10 F100\nM30\n", [2], []),  # incremental: the original line would change
    ("G21 G90\nG1 X0.001 F100\nM30\n", [2], []),  # one grid step: no point strictly inside
    # the mm move splits; the inch move's start (10.0001 mm) is off the inch grid
    ("G21 G90\nG1 X10.0001 F100\nG20\nG1 X1.\nM30\n", [2, 4], [2]),
])
def test_moves_that_cannot_split_exactly_stay_whole(text: str, lines: list[int],
                                                   split: list[int]) -> None:
    new, origin = split_moves(text, lines)
    assert new.count("\n") == text.count("\n") + len(split)
    assert sorted(line for line in set(origin) if origin.count(line) == 2) == split
    if not split:
        assert new == text and origin == list(range(1, text.count("\n") + 1))
