"""The G-code reader's modal state and output, and the blocks' non-motion words.

:class:`_State` holds the modes a block leaves for the next (units, distance mode, plane, work
system, tool length, path control, feed) and the segments read so far (:class:`_Out`); the
functions here apply a block's units, feed, tool, dwell and mode words to it in RS274 order
(motion: :mod:`contour_gym.paths._gcode_motion`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from contour_gym.paths._gcode_words import GcodeError, _Block, _whole
from contour_gym.paths._table import FloatArray

_UNIT = {20: 0.0254, 21: 0.001}


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
                                 "or pass default_feed)")
            out.feeds.append(math.nan if rapid else self.feed)
            out.lines.append(lineno)
            out.rapid.append(rapid)
            out.low.append(low)
            out.stops.append(False)
            out.blend.append(self.blend)
            out.control.append(self.control)
            out.dwell.append(out.pending_dwell if k == 0 else 0.0)
        out.pending_dwell = 0.0


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
