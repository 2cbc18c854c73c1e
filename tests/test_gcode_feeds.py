"""New F words for a part program, nothing else changed (issue 65's writer)."""

from __future__ import annotations

import difflib

import pytest

from contour_gym.paths import GcodeError, feed_moves, from_gcode, rewrite_feeds

MM_MIN = 1e-3 / 60.0  # one mm/min in m/s
PROGRAM = """%
O1000 (FACE F300 DEMO)
N10 G21 G90 G17 G64 P0.01
N20 G0 X0 Y0 S12000 M3
N30 G1 X10 F600.0 ; first cut, F in the comment
N40 X20 Y5
N50 G2 X30 Y15 I0 J10 (arc F)
N60 G1 X40
N70 F250.5
N80 X50
N90 G0 X0 Y0
N100 M30
%
"""


def _changed(before: str, after: str) -> list[tuple[str, str]]:
    # the (old, new) lines that differ
    pairs = zip(before.splitlines(), after.splitlines(), strict=True)
    return [(a, b) for a, b in pairs if a != b]


def test_only_the_f_words_of_the_chosen_blocks_change() -> None:
    path = from_gcode(PROGRAM)
    assert feed_moves(path) == pytest.approx({5: 600 * MM_MIN, 6: 600 * MM_MIN,
                                              7: 600 * MM_MIN, 8: 600 * MM_MIN,
                                              10: 250.5 * MM_MIN})
    out = rewrite_feeds(PROGRAM, {5: 900 * MM_MIN, 7: 420.04 * MM_MIN})
    assert _changed(PROGRAM, out) == [
        ("N30 G1 X10 F600.0 ; first cut, F in the comment",
         "N30 G1 X10 F900.0 ; first cut, F in the comment"),
        ("N40 X20 Y5", "N40 X20 Y5 F600.0"),  # the modal F changed before it: its own back
        ("N50 G2 X30 Y15 I0 J10 (arc F)", "N50 G2 X30 Y15 I0 J10 F420.0 (arc F)"),
        ("N60 G1 X40", "N60 G1 X40 F600.0"),
    ]
    got = feed_moves(from_gcode(out))
    assert got == pytest.approx({5: 900 * MM_MIN, 6: 600 * MM_MIN, 7: 420 * MM_MIN,
                                 8: 600 * MM_MIN, 10: 250.5 * MM_MIN})
    assert rewrite_feeds(PROGRAM, {}) == PROGRAM  # nothing asked, nothing changed


def test_inch_programs_line_endings_and_decimals_are_kept() -> None:
    text = "G20 G90\r\nG1 X1 F20\r\nX2\r\nG21\r\nG1 X30 F500\r\n"
    out = rewrite_feeds(text, {3: 12.6 * 0.0254 / 60.0, 5: 499.6 * MM_MIN})
    assert out == "G20 G90\r\nG1 X1 F20\r\nX2 F13\r\nG21\r\nG1 X30 F500\r\n"
    diff = [d for d in difflib.ndiff(text.splitlines(), out.splitlines()) if d[0] in "+-"]
    assert diff == ["- X2", "+ X2 F13"]


@pytest.mark.parametrize(("feeds", "said"), [
    ({4: 0.01}, "line 4 is not a feed move"),  # the rapid
    ({5: -1.0}, "feedrate must be positive and finite"),
    ({5: float("nan")}, "feedrate must be positive and finite"),
    ({5: 1e-9}, "rounds to 0.0 at the program's 1 decimals"),
])
def test_a_bad_request_is_named(feeds: dict[int, float], said: str) -> None:
    with pytest.raises(ValueError, match=said):
        rewrite_feeds(PROGRAM, feeds)


def test_a_feed_never_rounds_past_the_ceiling() -> None:
    text = "G21 G90\nG1 X10 F1000\nG1 X20\n"
    # 1999.6 mm/min rounds to 2000 at 0 decimals: past a ceiling of 1999.7 it rounds down
    top = 1999.7e-3 / 60.0
    out = rewrite_feeds(text, {3: 1999.6e-3 / 60.0}, ceiling=top)
    assert out.splitlines()[2] == "G1 X20 F1999"
    assert rewrite_feeds(text, {3: 1999.6e-3 / 60.0}).splitlines()[2] == "G1 X20 F2000"
    # a wanted feed above the ceiling is written at it, rounded down
    assert rewrite_feeds(text, {3: 0.1}, ceiling=top).splitlines()[2] == "G1 X20 F1999"


def test_down_never_writes_a_feed_faster_than_asked() -> None:
    text = "G21 G90\nG1 X10 F1000\nG1 X20\nG1 X30\n"
    out = rewrite_feeds(text, {3: 848.6e-3 / 60.0}, down=True)
    assert out.splitlines()[2:] == ["G1 X20 F848", "G1 X30 F1000"]  # the next keeps its own
    assert rewrite_feeds(text, {3: 848.6e-3 / 60.0}).splitlines()[2] == "G1 X20 F849"


def test_an_unreadable_program_gets_the_readers_error() -> None:
    with pytest.raises(GcodeError, match="G-code line 2"):
        rewrite_feeds("G1 X1 F100\nG93 X2\n", {1: 0.01})
