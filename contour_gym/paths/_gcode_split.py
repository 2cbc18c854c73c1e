"""Straight feed moves of a G-code program split in two, every other character kept.

:func:`split_moves` gives a per-part feed optimiser a block where it needs two speeds (a long
line into a tight corner): the chosen lines become two blocks, a new line to a point near the
middle of the move, then the line as written. The point lies exactly on the move and on the
program's coordinate grid (its most decimals of X/Y/Z, at least 3 in mm and 4 in inch): the
move's steps in grid units ``d`` have a greatest common divisor ``g``, and the point is
``k / g`` of the way, ``k = g // 2``. The new line is ``G1``, the axis words the move writes
(with a decimal point, which a Fanuc control needs to read millimetres), and the move's own F
word if it has one; the program runs the same path at the same feeds. A line is left whole
unless it is a plain straight feed move in absolute mode: only an optional N, G1 (or the modal
G1), axis words X Y Z, an F word and a comment; not in a program that uses G91 anywhere, with
``g >= 2``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from typing import Any

import numpy as np

from contour_gym.paths._gcode import from_gcode
from contour_gym.paths._gcode_feeds import _code_mask, _units
from contour_gym.paths._gcode_state import _UNIT
from contour_gym.paths._geom import LINE

_WORD = re.compile(r"([A-Za-z])\s*([-+]?(?:\d+\.?\d*|\.\d+))", re.ASCII)
_INCREMENTAL = re.compile(r"[Gg]\s*0*91(?![.\d])", re.ASCII)
_COORD = re.compile(r"[XxYyZz]\s*[-+]?(?:\d*\.(\d*))", re.ASCII)


def split_moves(text: str, lines: Iterable[int], **read: Any) -> tuple[str, list[int]]:
    """``text`` with each of ``lines`` that is a plain straight feed move split in two.

    Args:
        text: The program (any dialect :func:`~contour_gym.paths.from_gcode` reads).
        lines: 1-based lines to split (others, and those that cannot be split, stay whole).
        **read: :func:`~contour_gym.paths.from_gcode`'s options for this program.

    Returns:
        The new text, and for each of its lines the line of ``text`` it comes from (a new
        line: the line it was split from).
    """
    raw_lines = text.splitlines(keepends=True)
    wanted = set(lines)
    if not wanted or _uses_incremental(raw_lines):
        return text, list(range(1, len(raw_lines) + 1))
    path = from_gcode(text, **read)
    steps = _line_steps(path)
    units, decimals = _units(raw_lines), _coordinate_decimals(raw_lines)
    out: list[str] = []
    origin: list[int] = []
    for i, raw in enumerate(raw_lines, start=1):
        if i in wanted and i in steps:
            new = _first_half(raw, steps[i], units[i - 1], decimals[units[i - 1]])
            if new is not None:
                out.append(new + _line_end(raw))
                origin.append(i)
        out.append(raw)
        origin.append(i)
    return "".join(out), origin


def _uses_incremental(raw_lines: list[str]) -> bool:
    for raw in raw_lines:
        code = _code_mask(raw)
        if any(code[m.start()] for m in _INCREMENTAL.finditer(raw)):
            return True
    return False


def _line_steps(path: Any) -> dict[int, np.ndarray]:
    """Line -> (3,) end minus start of its move, m, for lines that are one straight feed move."""
    t = path.table
    kinds = np.asarray(t.kind)
    lines = np.asarray(path.segment_lines)
    starts = path.point(t.s0[:-1])
    ends = path.point(t.s0[1:])
    out: dict[int, np.ndarray] = {}
    count: dict[int, int] = {}
    for j, line in enumerate(lines.tolist()):
        count[line] = count.get(line, 0) + 1
        if not path.rapid[j] and kinds[j] == LINE:
            step = np.zeros(3)
            step[: path.dim] = ends[j] - starts[j]
            out[line] = step
    return {line: step for line, step in out.items() if count[line] == 1}


def _coordinate_decimals(raw_lines: list[str]) -> dict[float, int]:
    """The grid's decimals per unit: the program's most in an axis word, at least 3 mm / 4 in."""
    places = [0]
    for raw in raw_lines:
        code = _code_mask(raw)
        places += [len(m.group(1)) for m in _COORD.finditer(raw) if code[m.start()]]
    return {_UNIT[21]: max(max(places), 3), _UNIT[20]: max(max(places), 4)}


def _first_half(raw: str, step: np.ndarray, unit: float, decimals: int) -> str | None:
    """The new line to a grid point near the middle of ``raw``'s move, or None (kept whole)."""
    code = _code_mask(raw)
    body = "".join(c for c, keep in zip(raw, code, strict=True) if keep)
    found = [(m.group(1).upper(), m.group(2)) for m in _WORD.finditer(body)]
    if (raw.lstrip().startswith("/") or _WORD.sub("", body).strip()
            or not all(_plain(letter, value) for letter, value in found)):
        return None
    words = {letter: float(value) for letter, value in found if letter in "XYZ"}
    if not words or len(words) != sum(letter in "XYZ" for letter, _ in found):
        return None
    scale = 10.0**decimals
    exact = {axis: step["XYZ".index(axis)] / unit * scale for axis in words}
    grid = {axis: round(v) for axis, v in exact.items()}
    if any(abs(exact[a] - grid[a]) > 1e-6 or abs(words[a] * scale - round(words[a] * scale))
           > 1e-6 for a in words):
        return None  # the start or the end is off the grid (another unit wrote it)
    g = math.gcd(*(abs(v) for v in grid.values()))
    if g < 2:
        return None
    k = g // 2
    parts = ["G1"]
    for axis, end in words.items():
        end_units = round(end * scale)
        point = end_units - grid[axis] + k * grid[axis] // g
        parts.append(f"{axis}{_coordinate(point, decimals)}")
    parts += [f"F{value}" for letter, value in found if letter == "F"]
    return " ".join(parts)


def _plain(letter: str, value: str) -> bool:
    """Whether a word may stand in a move that is split: N, G1, an axis word or F."""
    return letter in "NXYZF" or (letter == "G" and float(value) == 1.0)


def _coordinate(units: int, decimals: int) -> str:
    """``units / 10**decimals`` with a decimal point and no trailing zeros (``6.``, ``-0.25``)."""
    sign = "-" if units < 0 else ""
    whole, frac = divmod(abs(units), 10**decimals)
    digits = f"{frac:0{decimals}d}".rstrip("0")
    return f"{sign}{whole}.{digits}"


def _line_end(raw: str) -> str:
    return raw[len(raw.rstrip("\r\n")):] or "\n"


__all__ = ["split_moves"]
