"""New F words for a G-code program: every other character of it kept as written.

:func:`rewrite_feeds` gives chosen feed moves new feedrates (a per-part feed optimiser's
result) and returns the program text with only F words changed or added: a block whose F word
changes keeps its place and format (the program's decimals); a feed move that needs a feed the
modal F no longer gives gets an F word at the end of its code (before its comment), so that
every other feed move still runs at its own feed. Comments, line numbers, rapids, M, S and T
words, modes and line endings stay as they are. The result is read back
(:func:`~contour_gym.paths.from_gcode`) and checked to give each feed move its feed.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from contour_gym._validate import positive
from contour_gym.paths._gcode import from_gcode
from contour_gym.paths._gcode_state import _UNIT
from contour_gym.paths._gcode_words import GcodeError

_F_WORD = re.compile(r"[Ff]\s*([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)
_UNITS = re.compile(r"[Gg]\s*0*(20|21)(?![.\d])", re.ASCII)


def feed_moves(path: Any) -> dict[int, float]:
    """``{line: feedrate (m/s)}`` of a program's feed moves (not rapids), from its path."""
    feed = ~np.asarray(path.rapid)
    lines = np.asarray(path.segment_lines)[feed]
    rates = np.asarray(path.segment_feedrates)[feed]
    return {int(line): float(rate) for line, rate in zip(lines, rates, strict=True)}


def rewrite_feeds(text: str, feeds: Mapping[int, float], *, ceiling: float | None = None,
                  down: bool = False, **read: Any) -> str:
    """The program ``text`` with the feed moves of ``feeds`` at their new feedrates.

    Args:
        text: The program (any dialect :func:`~contour_gym.paths.from_gcode` reads).
        feeds: ``{line: feedrate}``, m/s, for feed moves (1-based text lines); the other feed
            moves keep their feeds. Written in the program's unit per minute with the most
            decimals its F words have.
        ceiling: The largest feed to write, m/s (a machine's maximum): a feed that would
            round above it is written rounded down (None: every feed rounded to nearest).
        down: Round every new feed down, never faster than asked (a feed found to hold a
            tolerance stays within it as written).
        **read: :func:`~contour_gym.paths.from_gcode`'s options for this program (work
            offsets, tool lengths, ...).

    Returns:
        The new text: only F words differ (changed, or added to a block that needs one).

    Raises:
        GcodeError: from reading the program.
        ValueError: for a line of ``feeds`` that is not a feed move, a feedrate that is not
            positive and finite, or one that rounds to zero at the program's decimals.
    """
    before = feed_moves(from_gcode(text, **read))
    for line, rate in feeds.items():
        if line not in before:
            raise ValueError(f"G-code line {line} is not a feed move: only feed moves get new "
                             "feeds")
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"G-code line {line}: feedrate must be positive and finite, got "
                             f"{rate!r}")
    top = math.inf if ceiling is None else positive(ceiling, "ceiling")
    wanted = {**before, **{line: min(rate, top) for line, rate in feeds.items()}}
    decimals = _decimals(text)
    lines = text.splitlines(keepends=True)
    modal = math.nan  # the reader's default: no feed yet
    for i, (raw, unit) in enumerate(zip(lines, _units(lines), strict=True)):
        code = _code_mask(raw)
        words = [m for m in _F_WORD.finditer(raw) if code[m.start()]]
        if i + 1 not in wanted:
            if words:
                modal = float(words[-1].group(1)) * unit / 60.0
            continue
        written = _format(wanted[i + 1] * 60.0 / unit, decimals, i + 1,
                          top * 60.0 / unit, down and (i + 1) in feeds)
        lines[i] = _with_f(raw, code, words, written, modal, unit)
        modal = float(written) * unit / 60.0
    out = "".join(lines)
    _check(out, wanted, decimals, read)
    return out


def feed_grid(text: str) -> tuple[list[float], int]:
    """How :func:`rewrite_feeds` writes feeds into ``text``: the units, and the decimals.

    Returns per text line the metres of the length unit in force there (G20/G21), and the
    decimals of the program's F words: a feed ``f`` (m/s) written rounded down on line ``i``
    reads back as ``floor(f * 60 / unit[i - 1] * 10**decimals) / 10**decimals`` per minute.
    """
    lines = text.splitlines(keepends=True)
    return _units(lines), _decimals(text)


def _units(lines: list[str]) -> list[float]:
    """The length unit in force on each line, m (the reader's default: mm)."""
    out, unit = [], _UNIT[21]
    for raw in lines:
        code = _code_mask(raw)
        units = [m for m in _UNITS.finditer(raw) if code[m.start()]]
        if units:
            unit = _UNIT[int(units[-1].group(1))]
        out.append(unit)
    return out


def _with_f(raw: str, code: list[bool], words: list[re.Match[str]], written: str,
            modal: float, unit: float) -> str:
    """``raw`` with its F word set to ``written`` (or one added where the modal F differs)."""
    value = float(written) * unit / 60.0
    if words:
        last = words[-1]
        if float(last.group(1)) * unit / 60.0 == value:
            return raw  # as written
        return raw[: last.start(1)] + written + raw[last.end(1):]
    if value == modal:
        return raw
    end = max((k + 1 for k, c in enumerate(code) if c and not raw[k].isspace()), default=0)
    return raw[:end] + f" F{written}" + raw[end:]


def _code_mask(raw: str) -> list[bool]:
    """Per character of ``raw``: code (True), or a comment or line end (False)."""
    mask, depth, ended = [], 0, False
    for ch in raw:
        if ch == ";" and not depth:
            ended = True
        if ch == "(" and not ended:
            depth = 1
        mask.append(not (ended or depth) and ch not in "\r\n")
        if ch == ")" and depth:
            depth = 0
    return mask


def _decimals(text: str) -> int:
    """The most decimals an F word of ``text`` has (0 without any)."""
    places = [len(m.group(1).partition(".")[2]) for m in _F_WORD.finditer(text)]
    return max(places, default=0)


def _format(value: float, decimals: int, line: int, top: float, down: bool) -> str:
    written = f"{value:.{decimals}f}"
    up = float(written) > value * (1.0 + 1e-12)  # past the value (not by a float's last bit)
    if float(written) > top * (1.0 + 1e-12) or (down and up):  # rounded up: down instead
        steps = math.floor(min(value, top) * 10.0**decimals * (1.0 + 1e-12))
        written = f"{steps / 10.0**decimals:.{decimals}f}"
    if float(written) <= 0.0:
        raise ValueError(f"G-code line {line}: a feed of {value:.6g} per minute rounds to "
                         f"{written} at the program's {decimals} decimals")
    return written


def _check(text: str, wanted: Mapping[int, float], decimals: int, read: Mapping[str, Any]
           ) -> None:
    """Read ``text`` back: every feed move at its wanted feed, to the written decimals."""
    got = feed_moves(from_gcode(text, **read))
    step = 10.0**-decimals * _UNIT[20] / 60.0  # the coarsest rounding (down, inch per min)
    for line, rate in wanted.items():
        if line not in got or abs(got[line] - rate) > step + 1e-12 * rate:
            raise GcodeError(line, "F", f"the rewritten program runs line {line} at "
                             f"{got.get(line, math.nan):.6g} m/s, not {rate:.6g} m/s")


__all__ = ["feed_grid", "feed_moves", "rewrite_feeds"]
