"""A small strict G-code reader: G0/G1/G2/G3 moves in the XY plane (G17), helical arcs.

Supported words and codes (anything else is a ValueError naming the line number):

* ``G0`` rapid and ``G1`` feed lines; ``G2`` (clockwise) and ``G3`` (counter-clockwise) arcs with
  centre offsets ``I J`` (always relative to the arc start) or radius ``R`` (negative R = the arc
  longer than half a turn); a ``Z`` change during ``G2``/``G3`` makes a helical arc; ``I J`` with
  the end equal to the start is a full circle.
* ``G17`` (the only plane; ``G18``/``G19`` are rejected), ``G20``/``G21`` inch/mm (default mm),
  ``G90``/``G91`` absolute/incremental (default absolute), ``G91.1`` (incremental arc centres,
  which is the only mode anyway), and the no-op cancels ``G40 G49 G80 G94``.
* ``F`` feedrate in units per minute, ``X Y Z`` coordinates, ``N`` line numbers (ignored).
* ``M0 M1 M3-M9`` and ``S``/``T`` words are accepted and ignored; ``M2``/``M30`` end the program.
* Comments ``( ... )`` and ``; ...``, a leading ``/`` (block delete, treated as switched off: the
  block runs) and ``%`` lines are ignored.

Choices: the machine starts at the origin (or ``start``); rapid ``G0`` moves become line
segments of the path like ``G1`` moves (with NaN feedrate and ``rapid`` set); zero-length moves
are skipped; the path is 3-D as soon as a ``Z`` word appears, else 2-D. An arc whose start and
end radii differ by more than 1e-6 m (or 1e-6 relative for radii over 1 m) is an error; a
smaller mismatch is absorbed by moving the centre onto the perpendicular bisector of the chord.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array
from contour_gym.paths._geom import HELIX, LINE
from contour_gym.paths._path import Path
from contour_gym.paths._table import PathTable, line_row, make_table, split_helix

FloatArray = NDArray[np.float64]

_WORD = re.compile(r"\s*([A-Za-z])\s*([+-]?(?:\d+\.?\d*|\.\d+))")
_UNIT = {20: 0.0254, 21: 0.001}
_GROUPS = {"motion": {0, 1, 2, 3}, "units": {20, 21}, "distance": {90, 91},
           "plane": {17, 18, 19}}
_NOOP_G = {40.0, 49.0, 80.0, 94.0, 91.1}
_NOOP_M = {0, 1, 3, 4, 5, 6, 7, 8, 9}
_END_M = {2, 30}
_VALUE_WORDS = set("XYZIJRF")
_IGNORED_WORDS = set("NST")
_EZ = np.array([0.0, 0.0, 1.0])


class GcodeError(ValueError):
    """A G-code line that cannot be read (a ValueError naming the line number)."""


class GcodePath(Path):
    """A path read from G-code, with per-segment program data.

    Attributes:
        segment_feedrates: Programmed feedrate of each table segment, m/s; NaN for rapid moves
            and before the first ``F`` word.
        segment_lines: 1-based G-code line number of each table segment.
        rapid: True for segments from ``G0`` moves.
    """

    __slots__ = ("_feed", "_lines", "_rapid")
    _feed: FloatArray
    _lines: NDArray[np.int64]
    _rapid: NDArray[np.bool_]

    def __init__(self, table: PathTable, name: str, feedrates: ArrayLike, lines: ArrayLike,
                 rapid: ArrayLike) -> None:
        """Wrap a table with its per-segment program data (each (n_segments,))."""
        super().__init__(table, name)
        for attr, value, dtype in (("_feed", feedrates, np.float64), ("_lines", lines, np.int64),
                                   ("_rapid", rapid, np.bool_)):
            arr = np.array(value, dtype=dtype)
            if arr.shape != (table.n_segments,):
                raise ValueError(f"{attr[1:]} must have one value per segment")
            arr.flags.writeable = False
            object.__setattr__(self, attr, arr)

    def __reduce__(self) -> tuple[Any, ...]:
        return (GcodePath, (self.table, self.name, self._feed, self._lines, self._rapid))

    @property
    def segment_feedrates(self) -> FloatArray:
        """Feedrate per table segment, m/s (NaN where none applies)."""
        return self._feed

    @property
    def segment_lines(self) -> NDArray[np.int64]:
        """G-code line number (1-based) per table segment."""
        return self._lines

    @property
    def rapid(self) -> NDArray[np.bool_]:
        """True for segments from rapid (G0) moves."""
        return self._rapid

    def _rebuilt(self, table: PathTable) -> Path:
        return GcodePath(table, self.name, self._feed, self._lines, self._rapid)


@dataclass
class _State:
    pos: FloatArray
    motion: int | None = None
    unit: float = 0.001
    incremental: bool = False
    feed: float = math.nan
    saw_z: bool = False
    kinds: list[int] = field(default_factory=list)
    lengths: list[float] = field(default_factory=list)
    rows: list[FloatArray] = field(default_factory=list)
    feeds: list[float] = field(default_factory=list)
    lines: list[int] = field(default_factory=list)
    rapid: list[bool] = field(default_factory=list)

    def add(self, kind: int, lengths: list[float], rows: list[FloatArray], lineno: int) -> None:
        is_rapid = self.motion == 0
        for length, row in zip(lengths, rows, strict=True):
            self.kinds.append(kind)
            self.lengths.append(length)
            self.rows.append(row)
            self.feeds.append(math.nan if is_rapid else self.feed)
            self.lines.append(lineno)
            self.rapid.append(is_rapid)


def _strip(raw: str, lineno: int) -> str:
    text = raw.split(";", 1)[0]
    out = []
    depth = 0
    for ch in text:
        if ch == "(":
            if depth:
                raise GcodeError(f"G-code line {lineno}: nested comment: {raw.strip()!r}")
            depth = 1
        elif ch == ")":
            if not depth:
                raise GcodeError(f"G-code line {lineno}: unmatched ')': {raw.strip()!r}")
            depth = 0
        elif not depth:
            out.append(ch)
    if depth:
        raise GcodeError(f"G-code line {lineno}: unclosed comment: {raw.strip()!r}")
    line = "".join(out).strip()
    if line.startswith("/"):
        line = line[1:].strip()
    return "" if line == "%" else line


def _tokens(line: str, lineno: int) -> list[tuple[str, float]]:
    words = []
    pos = 0
    while pos < len(line):
        m = _WORD.match(line, pos)
        if m is None:
            rest = line[pos:].strip()
            if not rest:
                break
            raise GcodeError(f"G-code line {lineno}: cannot read {rest!r}")
        words.append((m.group(1).upper(), float(m.group(2))))
        pos = m.end()
    return words


def _classify(words: list[tuple[str, float]], lineno: int
              ) -> tuple[dict[str, int], dict[str, float], list[int]]:
    """Split words into modal G codes by group, value words and M codes; reject the rest."""
    groups: dict[str, int] = {}
    values: dict[str, float] = {}
    mcodes: list[int] = []
    for letter, num in words:
        if letter == "G":
            if num in _NOOP_G:
                continue
            group = next((g for g, codes in _GROUPS.items() if num in codes), None)
            if group is None:
                raise GcodeError(f"G-code line {lineno}: unsupported code G{num:g}")
            if group in groups:
                raise GcodeError(f"G-code line {lineno}: two {group} codes on one line")
            groups[group] = int(num)
        elif letter == "M":
            if num not in _NOOP_M and num not in _END_M:
                raise GcodeError(f"G-code line {lineno}: unsupported code M{num:g}")
            mcodes.append(int(num))
        elif letter in _VALUE_WORDS:
            if letter in values:
                raise GcodeError(f"G-code line {lineno}: word {letter} given twice")
            values[letter] = num
        elif letter not in _IGNORED_WORDS:
            raise GcodeError(f"G-code line {lineno}: unsupported word {letter}{num:g}")
    return groups, values, mcodes


def _apply_modes(st: _State, groups: dict[str, int], values: dict[str, float],
                 lineno: int) -> None:
    if groups.get("plane", 17) != 17:
        raise GcodeError(f"G-code line {lineno}: only the XY plane (G17) is supported, "
                         f"got G{groups['plane']}")
    if "units" in groups:
        st.unit = _UNIT[groups["units"]]
    if "distance" in groups:
        st.incremental = groups["distance"] == 91
    if "motion" in groups:
        st.motion = groups["motion"]
    if "F" in values:
        if values["F"] <= 0.0:
            raise GcodeError(f"G-code line {lineno}: feedrate must be > 0, got F{values['F']:g}")
        st.feed = values["F"] * st.unit / 60.0


def _target(st: _State, values: dict[str, float]) -> FloatArray:
    end = st.pos.copy()
    for axis, letter in enumerate("XYZ"):
        if letter in values:
            v = values[letter] * st.unit
            end[axis] = end[axis] + v if st.incremental else v
            st.saw_z = st.saw_z or letter == "Z"
    return end


def _arc_center(st: _State, values: dict[str, float], end: FloatArray, lineno: int
                ) -> FloatArray:
    start = st.pos
    chord = end[:2] - start[:2]
    d = float(np.hypot(*chord))
    if "R" in values:
        if "I" in values or "J" in values:
            raise GcodeError(f"G-code line {lineno}: give either I/J or R, not both")
        r = values["R"] * st.unit
        if d == 0.0:
            raise GcodeError(f"G-code line {lineno}: an R-form arc cannot be a full circle")
        if abs(r) < 0.5 * d - 1e-6 * max(1.0, abs(r)):
            raise GcodeError(f"G-code line {lineno}: radius {abs(r):.9g} m is smaller than half "
                             f"the chord {0.5 * d:.9g} m")
        h = math.sqrt(max(r * r - 0.25 * d * d, 0.0))
        left = np.array([-chord[1], chord[0]]) / d
        side = 1.0 if (st.motion == 3) == (r > 0.0) else -1.0
        return 0.5 * (start[:2] + end[:2]) + side * h * left
    if "I" not in values and "J" not in values:
        raise GcodeError(f"G-code line {lineno}: arc needs a centre (I/J) or a radius (R)")
    c = start[:2] + np.array([values.get("I", 0.0), values.get("J", 0.0)]) * st.unit
    r0 = float(np.hypot(*(start[:2] - c)))
    r1 = float(np.hypot(*(end[:2] - c)))
    if abs(r0 - r1) > 1e-6 * max(1.0, r0):
        raise GcodeError(f"G-code line {lineno}: arc start radius {r0:.9g} m and end radius "
                         f"{r1:.9g} m differ")
    if d > 0.0:  # move the centre onto the chord's perpendicular bisector
        u = chord / d
        mid = 0.5 * (start[:2] + end[:2])
        c = c - np.dot(c - mid, u) * u
    return c


def _arc(st: _State, values: dict[str, float], end: FloatArray, lineno: int) -> None:
    c = _arc_center(st, values, end, lineno)
    start = st.pos
    radius = float(np.hypot(*(start[:2] - c)))
    if radius == 0.0:
        raise GcodeError(f"G-code line {lineno}: arc radius is zero")
    a0 = math.atan2(start[1] - c[1], start[0] - c[0])
    a1 = math.atan2(end[1] - c[1], end[0] - c[0])
    ccw = st.motion == 3
    sweep = (a1 - a0) % (2.0 * math.pi) if ccw else -((a0 - a1) % (2.0 * math.pi))
    if sweep == 0.0:
        sweep = 2.0 * math.pi if st.motion == 3 else -2.0 * math.pi
    e1 = np.array([math.cos(a0), math.sin(a0), 0.0])
    e2 = np.cross(_EZ, e1)
    center = np.array([c[0], c[1], start[2]])
    lengths, rows = split_helix(center, e1, e2, radius, sweep, float(end[2] - start[2]))
    st.add(HELIX, lengths, rows, lineno)


def _move(st: _State, values: dict[str, float], lineno: int) -> None:
    has_axes = any(k in values for k in "XYZ")
    has_arc = any(k in values for k in "IJR")
    if not has_axes and not has_arc:
        return
    if st.motion is None:
        raise GcodeError(f"G-code line {lineno}: coordinates without a motion mode (G0-G3)")
    if has_arc and st.motion not in (2, 3):
        raise GcodeError(f"G-code line {lineno}: I/J/R words need G2 or G3")
    end = _target(st, values)
    if st.motion in (0, 1):
        if not np.array_equal(end, st.pos):
            length, row = line_row(st.pos, end)
            st.add(LINE, [length], [row], lineno)
    else:
        if not has_arc:
            raise GcodeError(f"G-code line {lineno}: arc needs a centre (I/J) or a radius (R)")
        _arc(st, values, end, lineno)
    st.pos = end


def from_gcode(text: str, *, start: ArrayLike = (0.0, 0.0, 0.0)) -> GcodePath:
    """Read a G-code program into a path (see the module documentation for the dialect).

    Args:
        text: The program.
        start: Machine position before the first move, m (2-D or 3-D; default origin).

    Returns:
        A :class:`GcodePath` (3-D if a Z word appears or ``start`` has a non-zero z, else
        2-D) with
        ``segment_feedrates`` (m/s), ``segment_lines`` and ``rapid`` per table segment.

    Raises:
        ValueError: naming the line number, for any unsupported or inconsistent line; or if
            the program has no motion.
    """
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")
    p0 = as_finite_array(start, "start", ndim=1)
    if p0.shape[0] not in (2, 3):
        raise ValueError(f"start must be a 2-D or 3-D point, got shape {p0.shape}")
    st = _State(pos=np.pad(p0, (0, 3 - p0.shape[0])))
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = _strip(raw, lineno)
        if not line:
            continue
        groups, values, mcodes = _classify(_tokens(line, lineno), lineno)
        _apply_modes(st, groups, values, lineno)
        _move(st, values, lineno)
        if any(m in _END_M for m in mcodes):
            break
    if not st.rows:
        raise ValueError("the G-code program has no motion")
    dim = 3 if st.saw_z or (p0.shape[0] == 3 and p0[2] != 0.0) else 2
    table = make_table(st.kinds, st.lengths, np.array(st.rows), dim)
    return GcodePath(table, "gcode", st.feeds, st.lines, st.rapid)
