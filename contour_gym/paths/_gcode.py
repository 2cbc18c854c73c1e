"""A strict G-code reader for the dialects real milling programs use (RS274/LinuxCNC, GRBL, Fanuc).

Every code below is either honoured or rejected with a :class:`GcodeError` (a ValueError)
naming the 1-based text line and the word; nothing is silently skipped.

Honoured:

* Motion: ``G0`` rapid, ``G1`` feed, ``G2``/``G3`` clockwise/counter-clockwise arcs in the
  active plane, viewed from the positive end of the plane's normal axis: ``G17`` XY (centre
  words ``I J``, normal Z), ``G18`` XZ (``I K``, normal Y), ``G19`` YZ (``J K``, normal X).
  A move along the normal axis during an arc makes a helix. Arc centres are incremental from
  the arc start (``G91.1``, default) or absolute program coordinates (``G90.1``, which then
  needs both centre words); ``R`` gives the radius instead (negative R: the arc longer than
  half a turn). ``I J``/``I K``/``J K`` with the end on the start is a full circle.
* ``G20``/``G21`` inch/mm (default mm), ``G90``/``G91`` absolute/incremental (default absolute),
  ``G94`` units-per-minute feed (default), ``F`` feedrate (> 0), ``N`` line numbers.
* ``G53``: the block's X Y Z are machine coordinates (no work offset, no tool length); the move
  is always rapid positioning, whatever G0/G1 is modal (G2/G3 and G91 are rejected with it).
* ``G28``: rapid to the intermediate point given by the axis words (G90/G91 as modal), then
  rapid to the reference point, taken as the machine origin, on those axes (Fanuc
  ``G91 G28 Z0.``); G28 needs axis words. ``G30`` is rejected (its point is machine data).
* ``G54``-``G59``, ``G59.1``-``G59.3`` work offsets (default G54): zero unless given through
  ``work_offsets`` (metres); an active system missing from a given mapping is an error.
* ``G43 H<n>`` tool length offset: Z shifted up by ``tool_lengths[n]`` (metres; zero when no
  mapping is given; ``H0`` is no tool, zero); ``G43`` without H uses the tool loaded by the last
  ``T<n> M6``. ``G49`` cancels.
* ``G4`` dwell: ``G4 P<seconds>`` (LinuxCNC, GRBL; **P is seconds**, not Fanuc milliseconds) or
  Fanuc ``G4 X<seconds>``. A dwell block holds no other axis or arc words.
* Path control, stored per segment: ``G64`` continuous (default) with the controller's default
  tolerance, ``G64 P<tol>`` continuous with path tolerance tol (program units; ``P0`` means no
  tolerance given, as in LinuxCNC; ``Q`` is accepted and ignored), ``G61`` exact stop at every
  block end (Fanuc meaning) and ``G61.1`` exact path: no blending, a stop only where the
  tangent jumps. LinuxCNC swaps the last two (its G61 is exact path, G61.1 exact stop); a
  LinuxCNC program's G61 sections therefore read as the stricter exact stop.
* Accepted and ignored: ``G40`` (cutter compensation off), ``G80`` (canned cycle cancel; it does
  not cancel G0-G3, as on Fanuc), ``S``, ``T`` (remembered for G43), coolant ``M7 M8 M9``,
  ``M1`` (optional stop, switch off). ``M0`` (program stop), ``M6`` (tool change) and spindle
  codes ``M3 M4 M5 M19`` only bring the motion to rest (see ``exact_stop``), without time.
* ``M2``/``M30`` end the program after the block's motion: nothing after them runs and later
  lines are not read. A ``%`` line before the first block opens the program; a later ``%``
  line ends it. A program number line (``O1001``, ``O0001 (NAME)``) before the first block
  starts the program; it must stand alone on its line.
* Comments ``( ... )`` and ``; ...``; a leading ``/`` (block delete, switch off: the block runs).

Rejected, naming the word: expressions ``[...]``, parameters and macro variables ``#``,
O-word subroutines and control flow (``O100 sub``, ``O100 call``, ``endsub``, ``if``,
``while`` ...; a second program number, i.e. a subprogram), ``M98``/``M99`` subroutine calls,
``G65``-``G67`` macro calls, canned cycles (``G73 G74 G76 G81``-``G89``), ``G41``/``G42``
cutter compensation, ``G43.1``/``G43.2``, ``G93`` inverse-time and ``G95`` per-revolution feed,
``G10``, ``G30``, ``G52``, ``G92`` offsets, every other G or M code, every other letter
(A B C U V W D L ...), P/Q/H words outside G4/G64/G43, K in G17 (J in G18, I in G19), a word
given twice, two codes of one modal group on one line, and malformed numbers or comments.

Choices: the machine starts at ``start`` (machine coordinates, default origin). The path is in
machine coordinates: program coordinates + active work offset + (0, 0, tool length). It is 3-D
when a Z word appears, an arc lies in the XZ or YZ plane, or ``start`` has a non-zero z; else
2-D. Zero-length moves are skipped. An arc whose start and end radii differ by more than
1e-6 m (or 1e-6 relative for radii over 1 m) is an error; a smaller mismatch is absorbed by
moving the centre onto the perpendicular bisector of the chord. The order of execution inside a
block is RS274's: units, F, T, M6, spindle, dwell, modes (plane, offsets, path control,
distance), motion, then M0/M2/M30.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array, finite, positive
from contour_gym.paths._geom import HELIX, LINE, segment_ends
from contour_gym.paths._path import CORNER_TOL, Path
from contour_gym.paths._table import PathTable, helix_row, line_row, make_table, split_helix

FloatArray = NDArray[np.float64]

_WORD = re.compile(r"\s*([A-Za-z])\s*([+-]?(?:\d+\.?\d*|\.\d+))", re.ASCII)  # ASCII digits only
_O_WORD = re.compile(r"O\s*(\d+|<[^>]*>)\s*(.*)$", re.IGNORECASE | re.ASCII)
_MACRO = re.compile(r"[A-Za-z]?\s*#\s*(?:<[^>]*>|\d+)?", re.ASCII)
_EXPR = re.compile(r"[A-Za-z]*\s*\[[^\]]*\]?")
_UNIT = {20: 0.0254, 21: 0.001}
_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
WORK_SYSTEMS = ("G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3")
"""The work coordinate systems a program may select (keys of ``from_gcode``'s ``work_offsets``)."""
_G_GROUP: dict[float, str] = {
    0.0: "motion", 1.0: "motion", 2.0: "motion", 3.0: "motion",
    4.0: "non-modal", 28.0: "non-modal", 53.0: "non-modal",
    17.0: "plane", 18.0: "plane", 19.0: "plane", 20.0: "units", 21.0: "units",
    90.0: "distance", 91.0: "distance", 90.1: "arc distance", 91.1: "arc distance",
    43.0: "tool length", 49.0: "tool length", 61.0: "path control", 61.1: "path control",
    64.0: "path control", 40.0: "cutter compensation", 80.0: "canned cycle", 94.0: "feed mode",
    **{float(name[1:]): "coordinate system" for name in WORK_SYSTEMS},
}
_G_NOOP = {40.0, 80.0, 94.0}
_G_REJECT: dict[float, str] = {
    93.0: "inverse-time feed", 95.0: "feed per revolution",
    **dict.fromkeys((41.0, 42.0, 41.1, 42.1), "cutter radius compensation"),
    **dict.fromkeys((43.1, 43.2), "dynamic tool length offset; use G43 H and tool_lengths"),
    **dict.fromkeys((73.0, 74.0, 76.0, *map(float, range(81, 90))), "canned cycle"),
    **dict.fromkeys((30.0, 28.1, 30.1), "reference points are machine data"),
    **dict.fromkeys((10.0, 52.0, 92.0, 92.1, 92.2, 92.3),
                    "offsets set by the program; pass work_offsets and tool_lengths"),
    **dict.fromkeys((65.0, 66.0, 66.1, 67.0), "macro call"),
}
_M_GROUP = {0: "stop", 1: "stop", 2: "stop", 30: "stop", 3: "spindle", 4: "spindle",
            5: "spindle", 19: "spindle", 6: "tool change", 7: "coolant", 8: "coolant",
            9: "coolant"}
_M_REJECT = {97: "local subroutine call", 98: "subroutine call", 99: "subroutine return"}
_VALUE_WORDS = set("XYZIJKRFPQH")
_CUT_TOL = 1e-9  # m: programmed Z this far above cut_z still counts as cutting
_XY_EPS = 1e-9  # m: moves with less X-Y length are Z-only on an X-Y machine
_PATH_CONTROL = (61.0, 61.1, 64.0)


class GcodeError(ValueError):
    """A G-code line that cannot be run: a ValueError naming the line number and the word.

    Attributes:
        line: 1-based text line of the program.
        word: The offending word (``"G93"``, ``"M98"``, ``"X[1+2]"``, ...) or text.
    """

    def __init__(self, line: int, word: str, message: str) -> None:
        super().__init__(f"G-code line {line}: {message}")
        self.line = line
        self.word = word
        self.message = message

    def __reduce__(self) -> tuple[Any, ...]:
        return (GcodeError, (self.line, self.word, self.message))


def _frozen(value: Any, dtype: Any, n: int, name: str) -> NDArray[Any]:
    arr = np.array(value, dtype=dtype)
    if arr.shape != (n,):
        raise ValueError(f"{name} must have one value per segment ({n}), got shape {arr.shape}")
    arr.flags.writeable = False
    return arr


class GcodePath(Path):
    """A path read from G-code (machine coordinates), with per-segment program data.

    Every array has one value per table segment; a helix cut into pieces repeats its block's
    data on each piece (only the last piece can hold an ``exact_stop``, only the first a
    ``dwell_before``). Data describing a junction belong to the segment ending there.

    Attributes:
        segment_feedrates: Programmed feedrate, m/s; NaN for rapid moves and before the first F.
        segment_lines: 1-based text line of the block.
        rapid: True for rapid positioning (G0, G53, G28).
        cutting: True for feed moves that cut: every feed move of a 2-D program; on a 3-D
            program a feed move whose programmed (work-coordinate) Z stays at or below
            ``cut_z`` (within 1 nm) over the whole move. Plunges, ramps from above and retracts
            are feed moves that do not cut.
        exact_stop: True where the motion must be at rest at the END of the segment: the last
            segment; G61 block ends; a dwell follows (``dwell_before`` > 0 on the next
            segment, or a G4 of any length); a change between rapid and feed motion; an M0,
            M6 or spindle code (M3 M4 M5 M19) follows; G28's intermediate point; under G61.1
            a junction where the unit tangent jumps by more than 1e-8.
        blend_tolerance: G64 P path tolerance, m; NaN under G64 without P (the controller's
            default); 0.0 under G61.1 and G61 (no blending).
        path_control: The active path-control code as a number: 64.0, 61.0 or 61.1.
        dwell_before: Seconds to wait at the START of the segment (G4 before it).
        dwell_after_end: Seconds to wait after the last segment (a G4 after the last motion).
    """

    __slots__ = ("_feed", "_lines", "_rapid", "_cutting", "_stops", "_exact", "_blend",
                 "_control", "_dwell", "_dwell_end")
    _feed: FloatArray
    _lines: NDArray[np.int64]
    _rapid: NDArray[np.bool_]
    _cutting: NDArray[np.bool_]
    _stops: NDArray[np.bool_]
    _exact: NDArray[np.bool_]
    _blend: FloatArray
    _control: FloatArray
    _dwell: FloatArray
    _dwell_end: float

    def __init__(self, table: PathTable, name: str, feedrates: ArrayLike, lines: ArrayLike,
                 rapid: ArrayLike, *, cutting: ArrayLike | None = None,
                 exact_stop: ArrayLike | None = None, blend_tolerance: ArrayLike | None = None,
                 path_control: ArrayLike | None = None, dwell_before: ArrayLike | None = None,
                 dwell_after_end: float = 0.0) -> None:
        """Wrap a table with its per-segment program data (each (n_segments,)).

        Args:
            table: The compiled segments.
            name: A label.
            feedrates: Feedrates, m/s (NaN or > 0).
            lines: Text line numbers.
            rapid: Rapid-move flags.
            cutting: Cutting flags (default: the feed moves).
            exact_stop: Stops asked for by the program (default none); the stops implied by the
                other data (see the class attributes) are added.
            blend_tolerance: Tolerances, m (NaN or >= 0; default NaN).
            path_control: 64.0, 61.0 or 61.1 per segment (default 64.0).
            dwell_before: Seconds >= 0 (default 0).
            dwell_after_end: Seconds >= 0.
        """
        super().__init__(table, name)
        n = table.n_segments
        rap = _frozen(rapid, np.bool_, n, "rapid")
        arrays = {
            "_feed": _frozen(feedrates, np.float64, n, "feedrates"),
            "_lines": _frozen(lines, np.int64, n, "lines"),
            "_rapid": rap,
            "_cutting": _frozen(~rap if cutting is None else cutting, np.bool_, n, "cutting"),
            "_stops": _frozen(np.zeros(n) if exact_stop is None else exact_stop, np.bool_, n,
                              "exact_stop"),
            "_blend": _frozen(np.full(n, math.nan) if blend_tolerance is None
                              else blend_tolerance, np.float64, n, "blend_tolerance"),
            "_control": _frozen(np.full(n, 64.0) if path_control is None else path_control,
                                np.float64, n, "path_control"),
            "_dwell": _frozen(np.zeros(n) if dwell_before is None else dwell_before,
                              np.float64, n, "dwell_before"),
        }
        _check_segment_data(arrays)
        for attr, arr in arrays.items():
            object.__setattr__(self, attr, arr)
        object.__setattr__(self, "_dwell_end", _non_negative(dwell_after_end, "dwell_after_end"))
        object.__setattr__(self, "_exact", self._implied_stops())

    def _mandatory_stops(self) -> NDArray[np.bool_]:
        # the stops no path-control mode lifts: asked for (M codes, G28), dwells, rapid <-> feed
        stops = self._stops.copy()
        stops[-1] = True
        stops[:-1] |= self._dwell[1:] > 0.0
        stops[:-1] |= self._rapid[:-1] != self._rapid[1:]
        return stops

    def _implied_stops(self) -> NDArray[np.bool_]:
        stops = self._mandatory_stops()
        block_end = np.ones_like(stops)
        block_end[:-1] = self._lines[:-1] != self._lines[1:]
        stops |= (self._control == 61.0) & block_end
        if np.any(self._control[:-1] == 61.1):
            t = self.table
            ends = segment_ends(t.kind, t.s0, t.data)
            jump = np.linalg.norm(ends[1:, 0, 3:] - ends[:-1, 1, 3:], axis=1) > CORNER_TOL
            stops[:-1] |= (self._control[:-1] == 61.1) & jump
        stops.flags.writeable = False
        return stops

    def __reduce__(self) -> tuple[Any, ...]:
        return (_restore, (self.table, self.name, self._feed, self._lines, self._rapid,
                           self._cutting, self._stops, self._blend, self._control, self._dwell,
                           self._dwell_end))

    @property
    def segment_feedrates(self) -> FloatArray:
        """Feedrate per table segment, m/s (NaN for rapids and before the first F)."""
        return self._feed

    @property
    def segment_lines(self) -> NDArray[np.int64]:
        """G-code text line number (1-based) per table segment."""
        return self._lines

    @property
    def rapid(self) -> NDArray[np.bool_]:
        """True for segments from rapid positioning (G0, G53, G28)."""
        return self._rapid

    @property
    def cutting(self) -> NDArray[np.bool_]:
        """True for segments that cut (see the class documentation for the rule)."""
        return self._cutting

    @property
    def exact_stop(self) -> NDArray[np.bool_]:
        """True where the motion must be at rest at the end of the segment."""
        return self._exact

    @property
    def mandatory_stops(self) -> NDArray[np.bool_]:
        """``exact_stop`` less the stops of G61/G61.1: those any path-control mode keeps.

        The last segment, M0/M6/spindle codes, G28, dwells, changes between rapid and feed.
        """
        out = self._mandatory_stops()
        out.flags.writeable = False
        return out

    @property
    def blend_tolerance(self) -> FloatArray:
        """Path tolerance at the end of each segment, m (NaN: controller default; 0: none)."""
        return self._blend

    @property
    def path_control(self) -> FloatArray:
        """Path-control mode per segment: 64.0 (G64), 61.0 (G61) or 61.1 (G61.1)."""
        return self._control

    @property
    def dwell_before(self) -> FloatArray:
        """Seconds to wait at the start of each segment."""
        return self._dwell

    @property
    def dwell_after_end(self) -> float:
        """Seconds to wait after the last segment."""
        return self._dwell_end

    def _rebuilt(self, table: PathTable) -> Path:
        return self._with_table(table, self._keep())

    def _keep(self) -> NDArray[np.int64]:
        return np.arange(self.table.n_segments)

    def _with_table(self, table: PathTable, src: NDArray[np.int64],
                    feed: ArrayLike | None = None, stops: ArrayLike | None = None,
                    dwell: ArrayLike | None = None, dwell_end: float | None = None) -> GcodePath:
        """A GcodePath on ``table`` whose segment k takes its data from segment ``src[k]``."""
        return GcodePath(
            table, self.name, self._feed[src] if feed is None else feed, self._lines[src],
            self._rapid[src], cutting=self._cutting[src],
            exact_stop=self._stops[src] if stops is None else stops,
            blend_tolerance=self._blend[src], path_control=self._control[src],
            dwell_before=self._dwell[src] if dwell is None else dwell,
            dwell_after_end=self._dwell_end if dwell_end is None else dwell_end)

    def for_machine(self, dim: int, *, rapid_rate: float, z: float = 0.0) -> GcodePath:
        """The same program on a machine drawing ``dim``-D contours (axes X, Y[, Z] by name).

        * 3-D program on a 2-D (X-Y) machine: Z is dropped. Segments with less than 1 nm of X-Y
          length (Z-only moves: plunges, retracts) leave the geometry; their time ``|dz| / rate``
          (rate = ``rapid_rate`` for rapids, the programmed F for feed moves; acceleration is
          ignored) is added, with their own dwells, to ``dwell_before`` of the next kept segment
          or to ``dwell_after_end``, and the kept segment before them ends in an exact stop.
          Helices become plain X-Y arcs. A feed move with X-Y and Z motion keeps its duration:
          its feedrate becomes ``F * xy_length / xyz_length``; a rapid with X-Y and Z motion
          keeps only its X-Y part (rapids have no programmed speed). ``cutting`` keeps the value
          computed from the program's Z. Arcs in the XZ or YZ plane cannot run: GcodeError.
        * 2-D program on a 3-D machine: the contour at constant height ``z``.
        * Same dimension: this path.

        Args:
            dim: 2 or 3.
            rapid_rate: Rapid traverse speed, m/s (> 0), for Z-only rapids.
            z: Height of a 2-D program on a 3-D machine, m (machine coordinates).

        Returns:
            The mapped :class:`GcodePath`.

        Raises:
            GcodeError: an XZ/YZ arc on an X-Y machine, or a Z-only feed move without F.
            ValueError: bad arguments, or no X-Y motion left.
        """
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim!r}")
        rate = positive(rapid_rate, "rapid_rate")
        height = finite(z, "z")
        if dim == self.dim:
            return self
        if dim == 3:
            t = self.table
            data = t.data.copy()
            data[:, 2] = height  # LINE start, HELIX centre and POLY5 constant term: z
            return self._with_table(make_table(t.kind, np.diff(t.s0), data, 3), self._keep())
        return _flatten(self, rate)


def _restore(table: PathTable, name: str, feed: FloatArray, lines: NDArray[np.int64],
             rapid: NDArray[np.bool_], cutting: NDArray[np.bool_], stops: NDArray[np.bool_],
             blend: FloatArray, control: FloatArray, dwell: FloatArray,
             dwell_end: float) -> GcodePath:
    """Unpickle a :class:`GcodePath`."""
    return GcodePath(table, name, feed, lines, rapid, cutting=cutting, exact_stop=stops,
                     blend_tolerance=blend, path_control=control, dwell_before=dwell,
                     dwell_after_end=dwell_end)


def _non_negative(value: Any, name: str) -> float:
    out = finite(value, name)
    if out < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return out


def _check_segment_data(arrays: dict[str, NDArray[Any]]) -> None:
    feed, blend, control, dwell = (arrays[k] for k in ("_feed", "_blend", "_control", "_dwell"))
    if np.any(np.isinf(feed)) or np.any(feed <= 0.0):
        raise ValueError("feedrates must be NaN or finite and > 0")
    if np.any(np.isinf(blend)) or np.any(blend < 0.0):
        raise ValueError("blend_tolerance must be NaN or finite and >= 0")
    if not np.all(np.isin(control, _PATH_CONTROL)):
        raise ValueError(f"path_control values must be in {_PATH_CONTROL}")
    if not np.all(np.isfinite(dwell)) or np.any(dwell < 0.0):
        raise ValueError("dwell_before must be finite and >= 0")


# 3-D program on an X-Y machine ----------------------------------------------------------------


@dataclass
class _Flat:
    first: int  # first and last source segment (an arc's pieces merge into one)
    last: int
    kind: int
    length: float
    feed: float
    dwell: float
    stop: bool
    sweep: float = 0.0


def _xy_and_z(path: GcodePath, i: int) -> tuple[float, float]:
    """X-Y length and |dz| of segment i (plane check for arcs)."""
    t = path.table
    row = t.data[i]
    length = float(t.s0[i + 1] - t.s0[i])
    if t.kind[i] == LINE:
        return length * math.hypot(row[3], row[4]), length * abs(row[5])
    if t.kind[i] != HELIX:
        raise ValueError("only LINE and HELIX segments can be mapped onto an X-Y machine")
    axis = np.abs(row[9:12])
    if abs(axis[2] - 1.0) > 1e-9:
        code = "G18" if abs(axis[1] - 1.0) <= 1e-9 else "G19" if abs(axis[0] - 1.0) <= 1e-9 \
            else "arc"
        plane = {"G18": "the XZ plane (G18)", "G19": "the YZ plane (G19)"}.get(code,
                                                                              "a tilted plane")
        raise GcodeError(int(path.segment_lines[i]), code,
                         f"an arc in {plane} cannot run on an X-Y machine")
    return row[12] * abs(row[13]) * length, abs(row[14]) * length


def _z_time(path: GcodePath, i: int, dz: float, rate: float) -> float:
    if path.rapid[i]:
        return dz / rate
    feed = float(path.segment_feedrates[i])
    if math.isnan(feed):
        raise GcodeError(int(path.segment_lines[i]), "F", "a Z-only feed move without a "
                         "feedrate (no F word before it) cannot become dwell time on an X-Y "
                         "machine")
    return dz / feed


def _flat_items(path: GcodePath, rate: float) -> tuple[list[_Flat], float]:
    """The segments kept on an X-Y machine, and the time left after the last one."""
    t = path.table
    lines = path.segment_lines
    items: list[_Flat] = []
    pending = 0.0
    for i in range(t.n_segments):
        pending += float(path.dwell_before[i])
        xy, dz = _xy_and_z(path, i)
        if xy <= _XY_EPS:
            pending += _z_time(path, i, dz, rate)
            if items:
                items[-1].stop = True
            continue
        length = float(t.s0[i + 1] - t.s0[i])
        sweep = float(t.data[i, 13]) * length
        prev = items[-1] if items else None
        if (prev is not None and prev.kind == HELIX == t.kind[i] and pending == 0.0
                and prev.last == i - 1 and lines[prev.last] == lines[i]):
            prev.last, prev.length, prev.sweep = i, prev.length + xy, prev.sweep + sweep
            continue
        feed = float(path.segment_feedrates[i]) * xy / length
        items.append(_Flat(i, i, int(t.kind[i]), xy, feed, pending, False, sweep))
        pending = 0.0
    return items, pending


def _flat_row(path: GcodePath, item: _Flat) -> tuple[float, FloatArray]:
    row = path.table.data[item.first]
    if item.kind == LINE:
        start = np.array([row[0], row[1], 0.0])
        direction = np.array([row[3], row[4], 0.0])
        return line_row(start, start + item.length * direction / np.linalg.norm(direction))
    centre = np.array([row[0], row[1], 0.0])
    e1 = np.array([row[3], row[4], 0.0])
    e2 = np.array([row[6], row[7], 0.0])
    return helix_row(centre, e1, e2, float(row[12]), item.sweep, 0.0)


def _flatten(path: GcodePath, rate: float) -> GcodePath:
    items, pending = _flat_items(path, rate)
    if not items:
        raise ValueError("the G-code program has no X-Y motion to run on an X-Y machine")
    rows = [_flat_row(path, item) for item in items]
    table = make_table([it.kind for it in items], [r[0] for r in rows],
                       np.array([r[1] for r in rows]), 2)
    src = np.array([it.last for it in items], dtype=np.int64)
    stops = path._stops[src] | np.array([it.stop for it in items])
    return path._with_table(table, src, feed=[it.feed for it in items], stops=stops,
                            dwell=[it.dwell for it in items],
                            dwell_end=path.dwell_after_end + pending)


# reading ----------------------------------------------------------------------------------------


@dataclass
class _Block:
    lineno: int
    g: dict[str, float] = field(default_factory=dict)
    values: dict[str, float] = field(default_factory=dict)
    m: dict[str, int] = field(default_factory=dict)
    tool: int | None = None

    def error(self, word: str, message: str) -> GcodeError:
        return GcodeError(self.lineno, word, message)


@dataclass
class _Out:
    """Segments read so far, with their per-segment data."""

    kinds: list[int] = field(default_factory=list)
    lengths: list[float] = field(default_factory=list)
    rows: list[FloatArray] = field(default_factory=list)
    feeds: list[float] = field(default_factory=list)
    lines: list[int] = field(default_factory=list)
    rapid: list[bool] = field(default_factory=list)
    low: list[bool] = field(default_factory=list)  # programmed Z at or below cut_z throughout
    stops: list[bool] = field(default_factory=list)
    blend: list[float] = field(default_factory=list)
    control: list[float] = field(default_factory=list)
    dwell: list[float] = field(default_factory=list)
    pending_dwell: float = 0.0

    def stop_here(self) -> None:
        """The motion is at rest at the end of the last segment so far."""
        if self.stops:
            self.stops[-1] = True


@dataclass
class _State:
    pos: FloatArray
    offsets: dict[str, FloatArray] | None
    tools: dict[int, float] | None
    cut_z: float
    out: _Out = field(default_factory=_Out)
    motion: int | None = None
    unit: float = 0.001
    incremental: bool = False
    arc_absolute: bool = False
    plane: int = 17
    feed: float = math.nan
    system: str = "G54"
    tool_length: float = 0.0
    control: float = 64.0
    blend: float = math.nan
    tool_selected: int | None = None
    tool_loaded: int | None = None
    saw_z: bool = False
    off_plane: bool = False
    started: bool = False  # a block has run
    opened: bool = False  # a % line opened the program
    numbered: bool = False  # a program number line started the program

    def origin(self, lineno: int) -> FloatArray:
        """Machine position of the program origin: work offset + (0, 0, tool length)."""
        if self.offsets is None:
            off = np.zeros(3)
        elif self.system in self.offsets:
            off = self.offsets[self.system].copy()
        else:
            raise GcodeError(lineno, self.system, f"work offset {self.system} (active) is not "
                             "given in work_offsets")
        off[2] += self.tool_length
        return off

    def emit(self, kind: int, lengths: list[float], rows: list[FloatArray], lineno: int,
             rapid: bool, low: bool) -> None:
        out = self.out
        for k, (length, row) in enumerate(zip(lengths, rows, strict=True)):
            out.kinds.append(kind)
            out.lengths.append(length)
            out.rows.append(row)
            if not rapid and self.feed != self.feed:  # NaN: no F word yet
                raise GcodeError(lineno, "F", "a feed move before any F word (program an F, "
                                 "or pass default_feed)")  # fmt: skip
            out.feeds.append(math.nan if rapid else self.feed)
            out.lines.append(lineno)
            out.rapid.append(rapid)
            out.low.append(low)
            out.stops.append(False)
            out.blend.append(self.blend)
            out.control.append(self.control)
            out.dwell.append(out.pending_dwell if k == 0 else 0.0)
        out.pending_dwell = 0.0


def _strip(raw: str, lineno: int) -> str:
    """The line without comments and block delete (``;`` inside parentheses is comment text)."""
    out = []
    depth = 0
    for ch in raw:
        if ch == ";" and not depth:
            break
        if ch == "(":
            if depth:
                raise GcodeError(lineno, raw.strip(), f"nested comment: {raw.strip()!r}")
            depth = 1
        elif ch == ")":
            if not depth:
                raise GcodeError(lineno, raw.strip(), f"unmatched ')': {raw.strip()!r}")
            depth = 0
        elif not depth:
            out.append(ch)
    if depth:
        raise GcodeError(lineno, raw.strip(), f"unclosed comment: {raw.strip()!r}")
    line = "".join(out).strip()
    if line.startswith("/"):
        line = line[1:].strip()
    return line


def _reject_macros(line: str, lineno: int) -> None:
    found = [(line.find(char), pattern, what) for char, pattern, what in (
        ("#", _MACRO, "macro variables and parameters (#)"),
        ("[", _EXPR, "expressions in brackets"))]
    found = [f for f in found if f[0] >= 0]
    if found:
        at, pattern, what = min(found, key=lambda f: f[0])
        m = pattern.search(line, max(at - 1, 0))
        word = m.group(0).strip() if m else line[at:]
        raise GcodeError(lineno, word, f"{word!r}: {what} are not supported")


def _program_number(st: _State, line: str, lineno: int) -> None:
    m = _O_WORD.match(line)
    if m is None:
        raise GcodeError(lineno, line, f"cannot read {line!r}")
    number, rest = m.group(1), m.group(2).strip()
    word = f"O{number}"
    keyword = re.match(r"[A-Za-z]+", rest)
    if keyword is not None and not _WORD.match(rest):
        raise GcodeError(lineno, f"{word} {keyword.group(0)}",
                         f"'{word} {keyword.group(0)}': O-word subroutines and control flow "
                         "are not supported")
    if number.startswith("<"):
        raise GcodeError(lineno, word, f"named O-word {word} is not supported")
    if rest:
        raise GcodeError(lineno, word, f"program number {word} must stand alone on its line")
    if st.started or st.numbered:
        raise GcodeError(lineno, word, f"program number {word} inside the program (a second "
                         "program or a subprogram) is not supported")
    st.numbered = True


def _tokens(line: str, lineno: int) -> list[tuple[str, float]]:
    words = []
    pos = 0
    while pos < len(line):
        m = _WORD.match(line, pos)
        if m is None:
            rest = line[pos:].strip()
            if not rest:
                break
            raise GcodeError(lineno, rest, f"cannot read {rest!r}")
        words.append((m.group(1).upper(), float(m.group(2))))
        pos = m.end()
    return words


def _add_g(blk: _Block, num: float) -> None:
    word = f"G{num:g}"
    if num in _G_REJECT:
        raise blk.error(word, f"unsupported code {word} ({_G_REJECT[num]})")
    group = _G_GROUP.get(num)
    if group is None:
        raise blk.error(word, f"unsupported code {word}")
    if num in _G_NOOP:
        return
    if group in blk.g:
        raise blk.error(word, f"two {group} codes on one line (G{blk.g[group]:g}, {word})")
    blk.g[group] = num


def _add_m(blk: _Block, num: float) -> None:
    word = f"M{num:g}"
    if num in _M_REJECT:
        raise blk.error(word, f"unsupported code {word} ({_M_REJECT[int(num)]})")
    group = _M_GROUP.get(int(num)) if num == int(num) else None
    if group is None:
        raise blk.error(word, f"unsupported code {word}")
    if group in blk.m and group != "coolant":
        raise blk.error(word, f"two {group} codes on one line (M{blk.m[group]}, {word})")
    blk.m[group] = int(num)


def _classify(words: list[tuple[str, float]], lineno: int) -> _Block:
    """Sort a block's words into G codes by group, value words, M codes and T; reject the rest."""
    blk = _Block(lineno)
    for letter, num in words:
        if letter == "G":
            _add_g(blk, num)
        elif letter == "M":
            _add_m(blk, num)
        elif letter in _VALUE_WORDS:
            if letter in blk.values:
                raise blk.error(letter, f"word {letter} given twice")
            blk.values[letter] = num
        elif letter == "T":
            blk.tool = _whole(blk, "T", num)
        elif letter not in "NS":
            raise blk.error(f"{letter}{num:g}", f"unsupported word {letter}{num:g}")
    _check_words(blk)
    return blk


def _whole(blk: _Block, letter: str, num: float) -> int:
    if num != int(num) or num < 0:
        raise blk.error(f"{letter}{num:g}", f"{letter}{num:g} must be a whole number >= 0")
    return int(num)


def _check_words(blk: _Block) -> None:
    v, g = blk.values, blk.g
    dwell, g64 = g.get("non-modal") == 4.0, g.get("path control") == 64.0
    if "P" in v and dwell == g64:
        what = "is ambiguous with both G4 and G64 on one line" if dwell else \
            "needs G4 (dwell) or G64 (path tolerance)"
        raise blk.error(f"P{v['P']:g}", f"P{v['P']:g} {what}")
    if "Q" in v and not g64:
        raise blk.error(f"Q{v['Q']:g}", f"Q{v['Q']:g} needs G64")
    if "H" in v and g.get("tool length") != 43.0:
        raise blk.error(f"H{v['H']:g}", f"H{v['H']:g} needs G43")
    if "F" in v and v["F"] <= 0.0:
        raise blk.error(f"F{v['F']:g}", f"feedrate must be > 0, got F{v['F']:g}")


def _units_feed_tools(st: _State, blk: _Block) -> None:
    if "units" in blk.g:
        st.unit = _UNIT[int(blk.g["units"])]
    if "F" in blk.values:
        st.feed = blk.values["F"] * st.unit / 60.0
    if blk.tool is not None:
        st.tool_selected = blk.tool
    if "tool change" in blk.m:
        st.tool_loaded = st.tool_selected
        st.out.stop_here()
    if "spindle" in blk.m:
        st.out.stop_here()


def _dwell(st: _State, blk: _Block) -> None:
    if blk.g.get("non-modal") != 4.0:
        return
    v = blk.values
    if "P" in v and "X" in v:
        raise blk.error(f"X{v['X']:g}", f"G4 takes its time from P or X, not both "
                        f"(X{v['X']:g})")
    word = "P" if "P" in v else "X"
    if word not in v:
        raise blk.error("G4", "G4 (dwell) needs P<seconds> (or Fanuc X<seconds>)")
    seconds = v.pop(word)
    extra = [f"{k}{v[k]:g}" for k in "XYZIJKR" if k in v]
    if extra:
        raise blk.error(extra[0], f"G4 (dwell) takes no {extra[0]} word")
    if seconds < 0.0:
        raise blk.error(f"{word}{seconds:g}", f"dwell time must be >= 0, got {word}{seconds:g}")
    st.out.pending_dwell += seconds
    st.out.stop_here()


def _tool_length(st: _State, blk: _Block) -> None:
    if blk.g["tool length"] == 49.0:
        st.tool_length = 0.0
        return
    if "H" in blk.values:
        h = _whole(blk, "H", blk.values["H"])
    elif st.tool_loaded is not None:
        h = st.tool_loaded
    else:
        raise blk.error("G43", "G43 without H needs a tool loaded by T<n> M6")
    if h == 0 or st.tools is None:
        st.tool_length = 0.0
    elif h in st.tools:
        st.tool_length = st.tools[h]
    else:
        raise blk.error(f"H{h}", f"no tool length for H{h} in tool_lengths")


def _path_control(st: _State, blk: _Block) -> None:
    code = blk.g["path control"]
    st.control = code
    if code != 64.0:
        st.blend = 0.0
        return
    tol = blk.values.get("P", 0.0)
    if tol < 0.0:
        raise blk.error(f"P{tol:g}", f"G64 path tolerance must be >= 0, got P{tol:g}")
    st.blend = tol * st.unit if tol > 0.0 else math.nan


def _modes(st: _State, blk: _Block) -> None:
    g = blk.g
    if "plane" in g:
        st.plane = int(g["plane"])
    if "coordinate system" in g:
        st.system = f"G{g['coordinate system']:g}"
    if "tool length" in g:
        _tool_length(st, blk)
    if "path control" in g:
        _path_control(st, blk)
    if "distance" in g:
        st.incremental = g["distance"] == 91.0
    if "arc distance" in g:
        st.arc_absolute = g["arc distance"] == 90.1
    if "motion" in g:
        st.motion = int(g["motion"])


def _target(st: _State, values: dict[str, float], origin: FloatArray) -> FloatArray:
    end = st.pos.copy()
    for axis, letter in enumerate("XYZ"):
        if letter in values:
            v = values[letter] * st.unit
            end[axis] = end[axis] + v if st.incremental else v + origin[axis]
            st.saw_z = st.saw_z or letter == "Z"
    return end


def _line(st: _State, end: FloatArray, lineno: int, rapid: bool, origin: FloatArray) -> None:
    if not np.array_equal(end, st.pos):
        length, row = line_row(st.pos, end)
        low = max(st.pos[2], end[2]) - origin[2] <= st.cut_z + _CUT_TOL
        st.emit(LINE, [length], [row], lineno, rapid, low)
    st.pos = end


def _positioning(st: _State, blk: _Block) -> None:
    """G53 (machine coordinates) and G28 (via a point to the machine origin): rapid moves."""
    code = blk.g["non-modal"]
    word = f"G{code:g}"
    v = blk.values
    axes = [k for k in "XYZ" if k in v]
    extra = [f"{k}{v[k]:g}" for k in "IJKR" if k in v]
    if extra:
        raise blk.error(extra[0], f"{word} takes no {extra[0]} word")
    if not axes:
        raise blk.error(word, f"{word} needs axis words")
    origin = st.origin(blk.lineno)
    if code == 53.0:
        if st.incremental:
            raise blk.error(word, "G53 cannot be used in incremental mode (G91)")
        if st.motion in (2, 3):
            raise blk.error(word, f"G53 needs G0 or G1, not G{st.motion}")
        end = st.pos.copy()
        for k in axes:
            end["XYZ".index(k)] = v[k] * st.unit
        st.saw_z = st.saw_z or "Z" in axes
        _line(st, end, blk.lineno, True, origin)
        return
    _line(st, _target(st, v, origin), blk.lineno, True, origin)
    st.out.stop_here()
    end = st.pos.copy()
    for k in axes:
        end["XYZ".index(k)] = 0.0
    _line(st, end, blk.lineno, True, origin)


def _motion(st: _State, blk: _Block) -> None:
    if blk.g.get("non-modal") in (53.0, 28.0):
        _positioning(st, blk)
        return
    v = blk.values
    has_axes = any(k in v for k in "XYZ")
    arc_words = [k for k in "IJKR" if k in v]
    if not has_axes and not arc_words:
        return
    if st.motion is None:
        word = next(f"{k}{v[k]:g}" for k in "XYZIJKR" if k in v)
        raise blk.error(word, f"coordinates without a motion mode (G0-G3): {word}")
    if arc_words and st.motion not in (2, 3):
        raise blk.error(arc_words[0], f"I/J/K/R words need G2 or G3 ({arc_words[0]} with "
                        f"G{st.motion})")
    origin = st.origin(blk.lineno)
    end = _target(st, v, origin)
    if st.motion in (0, 1):
        _line(st, end, blk.lineno, st.motion == 0, origin)
    else:
        if not arc_words:
            raise blk.error(f"G{st.motion}", f"arc needs a centre "
                            f"({_centre_letters(st.plane)}) or a radius (R)")
        _arc(st, blk, end, origin)
        st.pos = end


def _centre_letters(plane: int) -> str:
    ia, ib, _ = _PLANES[plane]
    return f"{'IJK'[ia]}/{'IJK'[ib]}" if ia < ib else f"{'IJK'[ib]}/{'IJK'[ia]}"


def _r_centre(blk: _Block, r: float, start: FloatArray, end: FloatArray, ccw: bool
              ) -> FloatArray:
    chord = end - start
    d = float(np.hypot(*chord))
    if d == 0.0:
        raise blk.error("R", "an R-form arc cannot be a full circle")
    if abs(r) < 0.5 * d - 1e-6 * max(1.0, abs(r)):
        raise blk.error("R", f"radius {abs(r):.9g} m is smaller than half the chord "
                        f"{0.5 * d:.9g} m")
    h = math.sqrt(max(r * r - 0.25 * d * d, 0.0))
    left = np.array([-chord[1], chord[0]]) / d
    side = 1.0 if ccw == (r > 0.0) else -1.0
    return 0.5 * (start + end) + side * h * left


def _arc_centre(st: _State, blk: _Block, end3: FloatArray, origin: FloatArray) -> FloatArray:
    """Arc centre in the plane coordinates (first, second axis of the active plane)."""
    ia, ib, ic = _PLANES[st.plane]
    v = blk.values
    la, lb, normal = "IJK"[ia], "IJK"[ib], "IJK"[ic]
    if normal in v:
        raise blk.error(normal, f"{normal} word is not used by arcs in the G{st.plane} plane")
    start, end = st.pos[[ia, ib]], end3[[ia, ib]]
    if "R" in v:
        if la in v or lb in v:
            raise blk.error(f"R{v['R']:g}", f"give either {_centre_letters(st.plane)} or R, "
                            f"not both (R{v['R']:g})")
        return _r_centre(blk, v["R"] * st.unit, start, end, st.motion == 3)
    if st.arc_absolute:
        missing = [k for k in (la, lb) if k not in v]
        if missing:
            raise blk.error(missing[0], f"G90.1 (absolute arc centre) needs both "
                            f"{_centre_letters(st.plane)}")
        c = np.array([v[la] * st.unit + origin[ia], v[lb] * st.unit + origin[ib]])
    else:
        c = start + np.array([v.get(la, 0.0), v.get(lb, 0.0)]) * st.unit
    r0 = float(np.hypot(*(start - c)))
    r1 = float(np.hypot(*(end - c)))
    if abs(r0 - r1) > 1e-6 * max(1.0, r0):
        raise blk.error(f"{la}/{lb}", f"arc start radius {r0:.9g} m and end radius {r1:.9g} m "
                        "differ")
    chord = end - start
    d = float(np.hypot(*chord))
    if d > 0.0:  # move the centre onto the chord's perpendicular bisector
        u = chord / d
        c = c - np.dot(c - 0.5 * (start + end), u) * u
    return c


def _arc_top(centre: FloatArray, e1: FloatArray, e2: FloatArray, radius: float,
             sweep: float) -> float:
    """Highest z of a plain arc (its rise is along a horizontal axis or zero)."""
    amp = math.hypot(e1[2], e2[2])
    if amp == 0.0:
        return -math.inf
    phi = math.atan2(e2[2], e1[2]) % (2.0 * math.pi)
    reach = phi if sweep > 0.0 else (2.0 * math.pi - phi) % (2.0 * math.pi)
    return centre[2] + radius * amp if reach <= abs(sweep) else -math.inf


def _arc(st: _State, blk: _Block, end: FloatArray, origin: FloatArray) -> None:
    ia, ib, ic = _PLANES[st.plane]
    c = _arc_centre(st, blk, end, origin)
    start = st.pos
    radius = float(np.hypot(start[ia] - c[0], start[ib] - c[1]))
    if radius == 0.0:
        raise blk.error(f"G{st.motion}", "arc radius is zero")
    a0 = math.atan2(start[ib] - c[1], start[ia] - c[0])
    a1 = math.atan2(end[ib] - c[1], end[ia] - c[0])
    ccw = st.motion == 3
    sweep = (a1 - a0) % (2.0 * math.pi) if ccw else -((a0 - a1) % (2.0 * math.pi))
    if sweep == 0.0:
        sweep = 2.0 * math.pi if ccw else -2.0 * math.pi
    e1 = np.zeros(3)
    e1[ia], e1[ib] = math.cos(a0), math.sin(a0)
    normal = np.zeros(3)
    normal[ic] = 1.0
    e2 = np.cross(normal, e1)
    centre = start.copy()
    centre[ia], centre[ib] = c
    lengths, rows = split_helix(centre, e1, e2, radius, sweep, float(end[ic] - start[ic]))
    top = max(start[2], end[2], _arc_top(centre, e1, e2, radius, sweep))
    st.off_plane = st.off_plane or st.plane != 17
    st.emit(HELIX, lengths, rows, blk.lineno, False, top - origin[2] <= st.cut_z + _CUT_TOL)


def _run_block(st: _State, blk: _Block) -> bool:
    """Execute one block in RS274 order; True if it ends the program."""
    _units_feed_tools(st, blk)
    _dwell(st, blk)
    _modes(st, blk)
    _motion(st, blk)
    if blk.m.get("stop") == 0:
        st.out.stop_here()
    return blk.m.get("stop") in (2, 30)


def _read_line(st: _State, raw: str, lineno: int) -> bool:
    """Read one text line; True if the program ends there."""
    line = _strip(raw, lineno)
    if not line:
        return False
    if line == "%":
        if st.started or st.opened:
            return True
        st.opened = True
        return False
    if line[0] in "Oo":
        _program_number(st, line, lineno)
        return False
    _reject_macros(line, lineno)
    st.started = True
    return _run_block(st, _classify(_tokens(line, lineno), lineno))


def _work_offsets(value: Mapping[str, ArrayLike] | None) -> dict[str, FloatArray] | None:
    if value is None:
        return None
    if not isinstance(value, Mapping):
        raise ValueError(f"work_offsets must be a mapping, got {type(value).__name__}")
    out: dict[str, FloatArray] = {}
    for key, off in value.items():
        name = str(key).strip().upper()
        if name not in WORK_SYSTEMS:
            raise ValueError(f"work_offsets key {key!r} is not one of {', '.join(WORK_SYSTEMS)}")
        arr = as_finite_array(off, f"work_offsets[{key!r}]", ndim=1)
        if arr.shape[0] not in (2, 3):
            raise ValueError(f"work_offsets[{key!r}] must be (x, y) or (x, y, z), m")
        out[name] = np.pad(arr, (0, 3 - arr.shape[0]))
    return out


def _tool_lengths(value: Mapping[int, float] | None) -> dict[int, float] | None:
    if value is None:
        return None
    if not isinstance(value, Mapping):
        raise ValueError(f"tool_lengths must be a mapping, got {type(value).__name__}")
    out: dict[int, float] = {}
    for key, length in value.items():
        if isinstance(key, bool) or not isinstance(key, (int, np.integer)) or key <= 0:
            raise ValueError(f"tool_lengths key {key!r} must be a tool number >= 1 (H0 means "
                             "no tool)")
        out[int(key)] = finite(length, f"tool_lengths[{key!r}]")
    return out


def from_gcode(text: str, *, start: ArrayLike = (0.0, 0.0, 0.0),
               work_offsets: Mapping[str, ArrayLike] | None = None,
               tool_lengths: Mapping[int, float] | None = None,
               cut_z: float = 0.0, default_feed: float | None = None) -> GcodePath:
    """Read a G-code program into a path (see the module documentation for the dialect).

    Args:
        text: The program.
        start: Machine position before the first move, m (2-D or 3-D; default origin).
        work_offsets: Machine position of each work coordinate system's origin, m, as
            ``{"G54": (x, y, z), "G55": (x, y), ...}`` (a missing z is 0). None: all zero.
            With a mapping, using a system it lacks (including the default G54) is an error.
        tool_lengths: Tool length per H number, m (``{1: 0.1}``): G43 H1 moves the programmed
            Z up by 0.1 m. None: all zero.
        cut_z: Programmed (work-coordinate) Z, m, at or below which a feed move of a 3-D
            program cuts (default 0: the work surface). Not used for 2-D programs, where every
            feed move cuts.
        default_feed: Feedrate, m/s, of the feed moves before the program's first F word.
            None (default): such a move is an error naming its line (a controller would not
            guess a feed either).

    Returns:
        A :class:`GcodePath` in machine coordinates, 3-D if a Z word appears, an arc lies in
        the XZ or YZ plane, or ``start`` has a non-zero z; else 2-D.

    Raises:
        GcodeError: naming the line and word, for any unsupported or inconsistent line.
        ValueError: for bad arguments, or if the program has no motion.
    """
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")
    p0 = as_finite_array(start, "start", ndim=1)
    if p0.shape[0] not in (2, 3):
        raise ValueError(f"start must be a 2-D or 3-D point, got shape {p0.shape}")
    st = _State(pos=np.pad(p0, (0, 3 - p0.shape[0])), offsets=_work_offsets(work_offsets),
                tools=_tool_lengths(tool_lengths), cut_z=finite(cut_z, "cut_z"))
    if default_feed is not None:
        st.feed = positive(default_feed, "default_feed")
    for lineno, raw in enumerate(text.splitlines(), start=1):
        if _read_line(st, raw, lineno):
            break
    out = st.out
    if not out.rows:
        raise ValueError("the G-code program has no motion")
    dim = 3 if st.saw_z or st.off_plane or (p0.shape[0] == 3 and p0[2] != 0.0) else 2
    cutting = [not r and (dim == 2 or low) for r, low in zip(out.rapid, out.low, strict=True)]
    table = make_table(out.kinds, out.lengths, np.array(out.rows), dim)
    return GcodePath(table, "gcode", out.feeds, out.lines, out.rapid, cutting=cutting,
                     exact_stop=out.stops, blend_tolerance=out.blend, path_control=out.control,
                     dwell_before=out.dwell, dwell_after_end=out.pending_dwell)
