"""The G-code reader's motion: lines, G53/G28 positioning, and arcs and helices in a plane.

A block's axis words become a target point (absolute or incremental, in the active work system)
and the motion mode turns it into LINE or HELIX segments appended to the reader's output
(:meth:`contour_gym.paths._gcode_state._State.emit`). Arcs take their centre from I/J/K
(incremental or absolute) or from R.
"""

from __future__ import annotations

import math

import numpy as np

from contour_gym.paths._gcode_state import _State
from contour_gym.paths._gcode_words import _Block
from contour_gym.paths._geom import HELIX, LINE
from contour_gym.paths._table import FloatArray, line_row, split_helix

_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
_CUT_TOL = 1e-9  # m: programmed Z this far above cut_z still counts as cutting


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
