"""GcodePath: a path read from G-code, with its per-segment program data.

Feedrates, line numbers, rapid and cutting flags, stops, blend tolerances, path-control modes
and dwells ride along with the geometry (:class:`GcodePath`), and
:meth:`GcodePath.for_machine` maps a program onto a machine of another dimension (a 3-D program
on an X-Y machine keeps the time of its Z-only moves as dwells).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import finite, positive
from contour_gym.paths._batch import segment_ends
from contour_gym.paths._gcode_words import GcodeError
from contour_gym.paths._geom import HELIX, LINE
from contour_gym.paths._path import CORNER_TOL, Path
from contour_gym.paths._table import FloatArray, PathTable, helix_row, line_row, make_table

_XY_EPS = 1e-9  # m: moves with less X-Y length are Z-only on an X-Y machine
_PATH_CONTROL = (61.0, 61.1, 64.0)


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

    def with_feedrates(self, feedrates: ArrayLike) -> GcodePath:
        """This program with other per-segment feedrates (m/s; rapids' entries are kept)."""
        feed = np.array(self._feed)
        given = np.asarray(feedrates, dtype=np.float64)
        if given.shape != feed.shape:
            raise ValueError(f"need {feed.size} feedrates (one per segment), got {given.shape}")
        feed[~self._rapid] = given[~self._rapid]
        return self._with_table(self.table, np.arange(feed.size), feed=feed)

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
