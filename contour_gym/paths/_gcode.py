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

import re
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

from contour_gym._validate import as_finite_array, finite, positive
from contour_gym.paths._gcode_motion import _motion
from contour_gym.paths._gcode_path import GcodePath
from contour_gym.paths._gcode_path import _restore as _restore  # pickles made before the split
from contour_gym.paths._gcode_state import _dwell, _modes, _State, _units_feed_tools
from contour_gym.paths._gcode_words import (
    _O_WORD,
    _WORD,
    WORK_SYSTEMS,
    GcodeError,
    _Block,
    _classify,
    _reject_macros,
    _strip,
    _tokens,
)
from contour_gym.paths._table import FloatArray, make_table


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
               cut_z: float = 0.0, default_feed: float | None = None,
               name: str = "gcode") -> GcodePath:
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
        name: The path's name (e.g. the file's).

    Returns:
        A :class:`GcodePath` in machine coordinates, 3-D if a Z word appears, an arc lies in
        the XZ or YZ plane, or ``start`` has a non-zero z; else 2-D.

    Raises:
        GcodeError: naming the line and word, for any unsupported or inconsistent line.
        ValueError: for bad arguments, or if the program has no motion.
    """
    if not isinstance(text, str):
        raise ValueError(f"text must be a str, got {type(text).__name__}")
    text = text.removeprefix("\ufeff")  # a byte-order mark some editors write first
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
    return GcodePath(table, name, out.feeds, out.lines, out.rapid, cutting=cutting,
                     exact_stop=out.stops, blend_tolerance=out.blend, path_control=out.control,
                     dwell_before=out.dwell, dwell_after_end=out.pending_dwell)


__all__ = ["WORK_SYSTEMS", "GcodeError", "GcodePath", "from_gcode"]
