"""The branch a machine is on: a path's turning, a search tree, and the true nearest point.

**The true contour error** (one definition, used by the servo loop's truth, the exact-search
estimator, every estimator's fallback, :meth:`contour_gym.paths.Path.nearest` with a hint and
:meth:`~contour_gym.paths.Path.track`): the machine's position ``p`` is measured against its
*branch* of the path, the stretch between where it was (its foot point at the previous tick)
and where its reference is, extended at both ends for as long as the path turns, in total and
corners included, less than 180 degrees beyond that stretch. The foot point is the branch's
point nearest ``p``; the contour error is the distance to it (signed in 2-D: positive left of
the direction of travel).

Why this and not the nearest point of the whole path: a piece of path that turns less than 180
degrees cannot cross or come back to itself (its tangents all lie in one open half-space, so
it advances monotonically along their mean), so on a path that comes near itself only across
turns of less than 180 degrees (every corner short of a reversal, every arc short of a half
circle, from the stretch) the branch's nearest point *is* the whole path's. Where the path
crosses itself or comes back near itself after turning 180 degrees or more (a figure eight's
centre, a star's crossings, a slot's opposite wall, zig-zag legs two apart, a second lap), the
branch is the one being traversed, decided by where the machine was and where its reference
is: no leg the machine has left can hold it, since the stretch always reaches the reference.

A table's ``bound`` array carries what the search needs
(:func:`contour_gym.paths._table.build_bound`), ``NB`` columns:

* rows ``0 .. n-1``, one per segment: its bounding sphere (centre xyz, radius), the turning
  accumulated from the path start to the segment start (``B_TS``, its start corner included),
  the turning within it (``B_TIN``; exact for lines, arcs and helices, by quadrature for
  quintic spans, spread linearly along them), the corner at its start (``B_CORNER``; on a
  closed path, segment 0's is the corner where the end meets the start) and, from
  ``B_CLEAR``, the *clearance* of each of its ``N_CELLS`` cells (equal parts): a lower bound of
  the distance from the cell's points to the path beyond ``CHORD_TURN`` of turning of them;
* rows ``n .. 3n-2``, a binary tree over the segments in pre-order: each node's sphere
  (enclosing its children's), its segment range ``[B_LO, B_HI)`` and ``B_SKIP``, the node
  after its subtree; the root row holds ``B_CLOSED`` (1 for a closed path).

Usually the nearest point is certain to lie within ``4 d`` of arc of the previous foot point
(``d`` the machine's distance from it): when the path there turns less than ``CHORD_TURN``
(so its chord is at least half its arc) and the cell's clearance exceeds ``2 d``
(:func:`_local_window`); then that small window alone is searched. Else the branch is
searched: the segment of the previous foot first (its distance bounds the rest), then the
tree, where a subtree whose sphere stays farther than the best distance so far, or whose
segments all lie outside the branch, is skipped whole.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contour_gym._callee import callee
from contour_gym.paths._geom import (
    CLOSED_TOL,
    HELIX,
    LINE,
    TIE_D2,
    eval_path,
    eval_segment,
    find_segment,
    nearest_window,
    search_segment,
)

N_CELLS = 8  # clearance cells per segment (equal parts of its length)
NB = 8 + N_CELLS  # columns of a table's bound rows
B_TS, B_TIN, B_CORNER = 4, 5, 6  # segment rows: turning at the start and within, start corner
B_CLEAR = 8  # segment rows: the clearance of each of its cells, N_CELLS columns from here
B_LO, B_HI, B_SKIP, B_CLOSED = 4, 5, 6, 7  # tree rows; B_CLOSED in the root row only
HALF_TURN = math.pi  # a branch extends until the path has turned this much beyond the stretch
# within this much turning of a point the path's chord is at least half its arc (cos 60 deg)
CHORD_TURN = 2.0 * math.pi / 3.0
# the clearance looks this far in turning: a half turn beyond a stretch that turns SPAN_TURN
SPAN_TURN = 0.5 * math.pi
BAND_TURN = HALF_TURN + SPAN_TURN
_CLEAR_TURN = math.pi / 12.0  # clearance samples: at most this much turning apart
_CLEAR_SAMPLES = 2  # clearance samples: at least this many intervals per cell
_TURN_SAMPLES = 32  # quadrature points of a quintic span's turning


# ---------------------------------------------------------------------------------- building
@callee
def _unit(r):
    norm = math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
    if norm == 0.0:
        return 0.0, 0.0, 0.0
    return r[3] / norm, r[4] / norm, r[5] / norm


@callee
def _angle(ax, ay, az, bx, by, bz):
    """Angle between two unit vectors (atan2 of |a x b| and a . b: exact near 0 and pi)."""
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    return math.atan2(math.sqrt(cx * cx + cy * cy + cz * cz), ax * bx + ay * by + az * bz)


@callee
def _corner(kind, s0, data, i, j):
    """Turn from the end of segment ``i`` to the start of segment ``j``, rad in [0, pi]."""
    ax, ay, az = _unit(eval_segment(kind, data, i, s0[i + 1] - s0[i]))
    bx, by, bz = _unit(eval_segment(kind, data, j, 0.0))
    return _angle(ax, ay, az, bx, by, bz)


@callee
def _turning_in(kind, s0, data, i):
    """Total turning of the unit tangent along segment ``i``, rad.

    A line turns 0; an arc or helix (unit speed) ``|P''| L = R w^2 L``; a quintic span
    ``integral |P' x P''| / |P'|^2 dt`` by the midpoint rule on ``_TURN_SAMPLES`` points.
    """
    seg_len = s0[i + 1] - s0[i]
    if kind[i] == LINE:
        return 0.0
    if kind[i] == HELIX:
        return abs(data[i, 12] * data[i, 13] * data[i, 13]) * seg_len
    h = seg_len / _TURN_SAMPLES
    total = 0.0
    for q in range(_TURN_SAMPLES):
        r = eval_segment(kind, data, i, (q + 0.5) * h)
        cx = r[4] * r[8] - r[5] * r[7]
        cy = r[5] * r[6] - r[3] * r[8]
        cz = r[3] * r[7] - r[4] * r[6]
        sp2 = r[3] * r[3] + r[4] * r[4] + r[5] * r[5]
        if sp2 > 0.0:
            total += math.sqrt(cx * cx + cy * cy + cz * cz) / sp2 * h
    return total


@callee
def _merge(out, k, a, b):
    """Row ``k`` := the smallest sphere holding the spheres of rows ``a`` and ``b``."""
    dx, dy, dz = out[b, 0] - out[a, 0], out[b, 1] - out[a, 1], out[b, 2] - out[a, 2]
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    ra, rb = out[a, 3], out[b, 3]
    if d + rb <= ra:
        src, rad, f = a, ra, 0.0
    elif d + ra <= rb:
        src, rad, f = b, rb, 0.0
    else:
        src, rad = a, 0.5 * (d + ra + rb)
        f = (rad - ra) / d
    out[k, 0] = out[src, 0] + f * dx
    out[k, 1] = out[src, 1] + f * dy
    out[k, 2] = out[src, 2] + f * dz
    scale = abs(out[k, 0]) + abs(out[k, 1]) + abs(out[k, 2]) + rad
    out[k, 3] = rad * (1.0 + 1e-12) + 1e-15 * scale  # rounding never leaves a child outside


@callee
def _build_tree(out, n):
    """The pre-order tree over segments ``0 .. n-1`` in rows ``n ..`` (module doc).

    A node of ``m`` segments spans ``2m - 1`` rows: its left child follows it, its right child
    follows the left subtree. Ranges are set top down, spheres bottom up (children come after
    their parent in pre-order).
    """
    out[n, B_LO], out[n, B_HI] = 0.0, float(n)
    for k in range(2 * n - 1):
        row = n + k
        lo, hi = int(out[row, B_LO]), int(out[row, B_HI])
        out[row, B_SKIP] = float(k + 2 * (hi - lo) - 1)
        if hi - lo > 1:
            mid = (lo + hi) // 2
            left, right = row + 1, row + 2 * (mid - lo)
            out[left, B_LO], out[left, B_HI] = float(lo), float(mid)
            out[right, B_LO], out[right, B_HI] = float(mid), float(hi)
    for k in range(2 * n - 2, -1, -1):
        row = n + k
        lo, hi = int(out[row, B_LO]), int(out[row, B_HI])
        if hi - lo == 1:
            for c in range(4):  # element by element: a slice copy compiles its error paths
                out[row, c] = out[lo, c]
        else:
            mid = (lo + hi) // 2
            _merge(out, row, row + 1, row + 2 * (mid - lo))


@numba.njit(cache=True)
def build_rows(kind, s0, data, spheres):
    """A table's ``bound`` rows (module doc) but the clearances, from the spheres ``(n, 4)``."""
    n = kind.shape[0]
    out = np.zeros((3 * n - 1, NB))
    closed = _is_closed(kind, s0, data)
    total = 0.0
    for i in range(n):
        for c in range(4):  # element by element: a slice copy compiles its error paths
            out[i, c] = spheres[i, c]
        corner = _corner(kind, s0, data, (i - 1) % n, i)  # i = 0: the end to the start
        if i > 0:
            out[i, B_CORNER] = corner
            total += corner
        elif closed:
            out[i, B_CORNER] = corner
        out[i, B_TS] = total
        out[i, B_TIN] = _turning_in(kind, s0, data, i)
        total += out[i, B_TIN]
    _build_tree(out, n)
    out[n, B_CLOSED] = 1.0 if closed else 0.0
    return out


@callee
def _is_closed(kind, s0, data):
    """Whether the path ends where it starts (within ``CLOSED_TOL``)."""
    n = kind.shape[0]
    start = eval_path(kind, s0, data, 0.0)
    end = eval_path(kind, s0, data, s0[n])
    gap = math.sqrt((start[0] - end[0]) ** 2 + (start[1] - end[1]) ** 2 + (start[2] - end[2]) ** 2)
    return gap <= CLOSED_TOL


@numba.njit(cache=True)
def fill_clearances(kind, s0, data, bound, out):
    """Every cell's clearance (:func:`_clearance`) into ``out`` (n, ``N_CELLS``)."""
    closed = is_closed_table(bound, kind.shape[0])
    for i in range(kind.shape[0]):
        for cell in range(N_CELLS):
            out[i, cell] = _clearance(kind, s0, data, bound, i, cell, closed)


@callee
def _nearest_between(kind, s0, data, bound, px, py, pz, closed, lo, hi):
    """Squared distance from ``p`` to the path's unwrapped range ``[lo, hi]``.

    ``inf`` for an empty range or a single point (``hi <= lo``: where turning away begins at
    the path's end, nothing turns away).
    """
    if hi <= lo:
        return np.inf
    windows = branch_windows(s0[s0.shape[0] - 1], closed, lo, hi)
    seed = nearest_leaf(kind, s0, bound, px, py, pz, windows)
    return search_tree(kind, s0, data, bound, px, py, pz, windows, seed, windows[0], np.inf)[1]


@callee
def _clearance(kind, s0, data, bound, i, cell, closed):
    """A lower bound of how near a cell's points come to the path turned away from them.

    Cell ``cell`` of segment ``i`` is its ``cell``-th of ``N_CELLS`` equal parts. For a point
    x, the path *turned away* is what lies between ``CHORD_TURN`` and ``BAND_TURN`` of turning
    of x (either way): any branch holding x, from a stretch turning at most ``SPAN_TURN``,
    lies within ``BAND_TURN``, and the rest of it within ``CHORD_TURN``, where the chord
    bounds the arc. The cell is cut into intervals ``[x0, x1]`` (at least ``_CLEAR_SAMPLES``,
    each turning at most ``_CLEAR_TURN``): what every point of one turns away from lies in
    ``[lo_band(x0), lo(x1)]`` and ``[hi(x0), hi_band(x1)]``, whose distance from ``x0`` (exact
    search) less ``x1 - x0`` bounds theirs. ``inf``: nothing turns away.
    """
    part = (s0[i + 1] - s0[i]) / N_CELLS
    a = s0[i] + cell * part
    m = max(_CLEAR_SAMPLES, int(math.ceil(bound[i, B_TIN] / N_CELLS / _CLEAR_TURN)))
    out = np.inf
    for k in range(m):
        x0, x1 = a + part * k / m, a + part * (k + 1) / m
        lo, hi = branch_range(s0, bound, closed, x1, x1, CHORD_TURN)[0], branch_range(
            s0, bound, closed, x0, x0, CHORD_TURN)[1]
        lo_band = branch_range(s0, bound, closed, x0, x0, BAND_TURN)[0]
        hi_band = branch_range(s0, bound, closed, x1, x1, BAND_TURN)[1]
        px, py, pz = eval_path(kind, s0, data, x0)[:3]
        d2 = min(_nearest_between(kind, s0, data, bound, px, py, pz, closed, lo_band, lo),
                 _nearest_between(kind, s0, data, bound, px, py, pz, closed, hi, hi_band))
        out = min(out, math.sqrt(d2) - (x1 - x0))
    return max(out, 0.0)


# ---------------------------------------------------------------------------------- turning
@numba.njit(cache=True, inline="always")
def is_closed_table(bound, n):
    """Whether the path of ``n`` segments is closed (its ``bound`` root row)."""
    return bound[n, B_CLOSED] != 0.0


@callee(forceinline=True)
def _turn_on(s0, bound, i, r, left):
    """Turning from the lap's start to ``r`` on segment ``i`` (if ``left``: before its corner)."""
    if left and r <= s0[i] and i > 0:
        return bound[i - 1, B_TS] + bound[i - 1, B_TIN]
    seg_len = s0[i + 1] - s0[i]
    f = min(max((r - s0[i]) / seg_len, 0.0), 1.0) if seg_len > 0.0 else 0.0
    return bound[i, B_TS] + bound[i, B_TIN] * f


@callee(forceinline=True)
def _turn_in_lap(s0, bound, r, left):
    """Turning from the lap's start to ``r`` in [0, L]; at a joint the left limit if ``left``."""
    return _turn_on(s0, bound, find_segment(s0, r), r, left)


@callee(forceinline=True)
def _turn_from(s0, bound, j, r, left):
    """:func:`_turn_in_lap` at ``r`` in [0, L], its segment found by walking from segment ``j``."""
    n = s0.shape[0] - 1
    i = j
    while i > 0 and r < s0[i]:
        i -= 1
    while i < n - 1 and r >= s0[i + 1]:
        i += 1
    return _turn_on(s0, bound, i, r, left)


@callee(forceinline=True)
def _turn(s0, bound, s, left, closed):
    """Turning ``T(s)`` from the path start (unwrapped laps on a closed path)."""
    n = s0.shape[0] - 1
    length = s0[n]
    if not closed:
        return _turn_in_lap(s0, bound, min(max(s, 0.0), length), left)
    period = bound[n - 1, B_TS] + bound[n - 1, B_TIN] + bound[0, B_CORNER]
    k = math.floor(s / length)
    r = s - k * length
    if r <= 0.0 and left:
        return k * period - bound[0, B_CORNER]
    return k * period + _turn_in_lap(s0, bound, r, left)


@callee(forceinline=True)
def _first_end_above(s0, bound, u):
    """First segment whose turning at its end (before the next corner) exceeds ``u``."""
    lo, hi = 0, s0.shape[0] - 2
    while lo < hi:
        mid = (lo + hi) >> 1
        if bound[mid, B_TS] + bound[mid, B_TIN] > u:
            hi = mid
        else:
            lo = mid + 1
    return lo


@callee(forceinline=True)
def _last_start_below(s0, bound, u):
    """Last segment whose turning at its start (its start corner included) is below ``u``."""
    lo, hi = 0, s0.shape[0] - 2
    while lo < hi:
        mid = (lo + hi + 1) >> 1
        if bound[mid, B_TS] < u:
            lo = mid
        else:
            hi = mid - 1
    return lo


@callee(forceinline=True)
def _inf_above(s0, bound, u):
    """Smallest ``r`` in one lap with ``T(r) > u``, for ``0 <= u < T(L-)``."""
    i = _first_end_above(s0, bound, u)
    if bound[i, B_TS] > u:
        return s0[i]
    return s0[i] + (u - bound[i, B_TS]) / bound[i, B_TIN] * (s0[i + 1] - s0[i])


@callee(forceinline=True)
def _sup_below(s0, bound, u):
    """Largest ``r`` in one lap with ``T(r-) < u``, for ``0 < u <= T(L-)``."""
    i = _last_start_below(s0, bound, u)
    end = bound[i, B_TS] + bound[i, B_TIN]
    if end < u:
        return s0[i + 1]
    return s0[i] + (u - bound[i, B_TS]) / bound[i, B_TIN] * (s0[i + 1] - s0[i])


@callee(forceinline=True)
def _lower_end(s0, bound, closed, t_end, target, a):
    """Smallest arc length (unwrapped, at most a lap before ``a``) where ``T > target``."""
    length = s0[s0.shape[0] - 1]
    if not closed:
        return _inf_above(s0, bound, target) if target >= 0.0 else 0.0
    period = t_end + bound[0, B_CORNER]
    k = math.floor(a / length)
    u = target - k * period  # in a's lap, T runs from 0 (its start) to t_end
    if u >= 0.0:
        return k * length + _inf_above(s0, bound, u)
    u += period  # the lap before: T runs to t_end, then the closing corner to the next lap
    if u >= t_end:
        return k * length
    return (k - 1.0) * length + _inf_above(s0, bound, max(u, 0.0))


@callee(forceinline=True)
def _upper_end(s0, bound, closed, t_end, target, b):
    """Largest arc length (unwrapped, at most a lap after ``b``) where ``T(left) < target``."""
    length = s0[s0.shape[0] - 1]
    if not closed:
        return _sup_below(s0, bound, target) if target <= t_end else length
    period = t_end + bound[0, B_CORNER]
    k = math.floor(b / length)
    u = target - k * period
    if u <= t_end:
        return k * length + _sup_below(s0, bound, u)
    u -= period
    if u <= 0.0:
        return (k + 1.0) * length
    return (k + 1.0) * length + _sup_below(s0, bound, min(u, t_end))


@callee(forceinline=True)
def branch_range(s0, bound, closed, a, b, angle):
    """The arc lengths within ``angle`` of turning of the stretch ``[a, b]`` (the branch).

    ``lo`` is the smallest arc length from which the path up to ``a`` turns less than
    ``angle``, ``hi`` the largest up to which it turns less than that from ``b`` (turning at an
    end point does not count: a reversal's vertex is in, the leg beyond it is out). On a
    closed path ``a``, ``b``, ``lo`` and ``hi`` are unwrapped (laps continue past 0 and L); on
    an open one they lie in [0, L].
    """
    n = s0.shape[0] - 1
    length = s0[n]
    t_end = bound[n - 1, B_TS] + bound[n - 1, B_TIN]
    if not closed and t_end < angle:
        return 0.0, length
    lo = _lower_end(s0, bound, closed, t_end, _turn(s0, bound, a, True, closed) - angle, a)
    hi = _upper_end(s0, bound, closed, t_end, _turn(s0, bound, b, False, closed) + angle, b)
    return min(lo, a), max(hi, b)


# ---------------------------------------------------------------------------------- the search
@callee(forceinline=True)
def _leaf(n, j):
    """Pre-order index of segment ``j``'s leaf in the tree over ``n`` segments."""
    k, lo, hi = 0, 0, n
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if j < mid:
            k, hi = k + 1, mid
        else:
            k, lo = k + 2 * (mid - lo), mid
    return k


@callee(forceinline=True)
def branch_windows(length, closed, lo, hi):
    """The unwrapped range ``[lo, hi]`` as windows ``(lo, hi)`` in [0, L], three pairs.

    A pair with ``hi < lo`` is empty. On a closed path a range across 0 or L is cut in two,
    the part in the lap of ``[0, L]`` first; a range of a lap or more is the whole path.
    """
    if hi - lo >= length:
        return 0.0, length, 1.0, 0.0, 1.0, 0.0
    if not closed:
        return max(lo, 0.0), min(hi, length), 1.0, 0.0, 1.0, 0.0
    k = math.floor(lo / length)
    a, b = lo - k * length, hi - k * length  # a in [0, L), b < a + L
    if b <= length:
        return a, b, 1.0, 0.0, 1.0, 0.0
    if k < 0:
        return 0.0, b - length, a, length, 1.0, 0.0
    return a, length, 0.0, b - length, 1.0, 0.0


@callee
def search_tree(kind, s0, data, bound, px, py, pz, windows, seed, best_s, best_d2):
    """Nearest point with arc length in ``windows`` (up to 3 ``(lo, hi)`` in [0, L]).

    Segment ``seed`` is searched first, in every window that holds it; then the tree over
    each window, whose subtrees are skipped when their sphere cannot beat the best distance or
    their segments lie outside the window. Ties (``TIE_D2``) keep the point farthest along.
    Returns ``(s_foot, dist2)`` (``best_s, best_d2`` when nothing in the windows beats them).
    """
    n = kind.shape[0]
    leaf = _leaf(n, seed)
    # phases 0-2: the seed's leaf in windows 0-2; phases 3-5: the tree over windows 0-2
    for phase in range(6):
        w = phase % 3
        s_lo, s_hi = windows[2 * w], windows[2 * w + 1]
        if s_hi < s_lo:
            continue
        i_lo, i_hi = _segment_range(s0, s_lo, s_hi)
        if phase < 3:
            if not i_lo <= seed <= i_hi:
                continue
            k, end = leaf, leaf + 1
        else:
            k, end = 0, 2 * n - 1
        while k < end:
            row = n + k
            lo, hi = int(bound[row, B_LO]), int(bound[row, B_HI])
            skip = int(bound[row, B_SKIP])
            if hi <= i_lo or lo > i_hi or (phase >= 3 and k == leaf):
                k = skip
                continue
            if _sphere_gap_beyond(bound, row, px, py, pz, best_d2):
                k = skip
                continue
            if hi - lo == 1:
                best_s, best_d2 = search_segment(kind, s0, data, bound, lo, px, py, pz, s_lo,
                                                 s_hi, best_s, best_d2)
            k += 1
    return best_s, best_d2


@callee(forceinline=True)
def _segment_range(s0, s_lo, s_hi):
    """First and last segment holding arc lengths of ``[s_lo, s_hi]``."""
    i_lo = find_segment(s0, s_lo)
    i_hi = find_segment(s0, s_hi)
    if i_hi > i_lo and s0[i_hi] >= s_hi:
        i_hi -= 1
    return i_lo, i_hi


@callee(forceinline=True)
def _sphere_gap_beyond(bound, row, px, py, pz, best_d2):
    """Whether row ``row``'s sphere stays farther from ``p`` than ``sqrt(best_d2)`` (a tie)."""
    lb = _sphere_gap(bound, row, px, py, pz)
    return lb > 0.0 and lb * lb > best_d2 + TIE_D2


@callee(forceinline=True)
def unwrap_near(s, ref, length, closed):
    """``s`` moved by whole laps to within half a lap of ``ref`` on a closed path."""
    if closed:
        if s - ref > 0.5 * length:
            s -= length * math.ceil((s - ref) / length - 0.5)
        elif ref - s > 0.5 * length:
            s += length * math.ceil((ref - s) / length - 0.5)
    return s


@callee(forceinline=True)
def _sphere_gap(bound, row, px, py, pz):
    dx, dy, dz = px - bound[row, 0], py - bound[row, 1], pz - bound[row, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz) - bound[row, 3]


@callee(forceinline=True)
def nearest_leaf(kind, s0, bound, px, py, pz, windows):
    """A segment of ``windows`` near ``p``: down the tree, into the child nearer by sphere.

    Not always the nearest segment, but near enough that its distance prunes the search.
    """
    n = kind.shape[0]
    a0, b0 = _segment_range(s0, windows[0], windows[1]) if windows[1] >= windows[0] else (n, -1)
    a1, b1 = _segment_range(s0, windows[2], windows[3]) if windows[3] >= windows[2] else (n, -1)
    k, lo, hi = 0, 0, n
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        left, right = k + 1, k + 2 * (mid - lo)
        in_left = (mid > a0 and lo <= b0) or (mid > a1 and lo <= b1)
        in_right = (hi > a0 and mid <= b0) or (hi > a1 and mid <= b1)
        if in_left and in_right:
            go_left = (_sphere_gap(bound, n + left, px, py, pz)
                       <= _sphere_gap(bound, n + right, px, py, pz))
        else:
            go_left = in_left
        if go_left:
            k, hi = left, mid
        else:
            k, lo = right, mid
    return lo


@callee(forceinline=True)
def _local_window(s0, bound, px, py, pz, s_from, qx, qy, qz, s_to, closed):
    """The window around ``s_from`` that holds the branch's nearest point, if it is certain.

    ``q = P(s_from)``. With ``d = |p - q|``, any point nearer ``p`` than d lies within ``2 d``
    of q. Within ``CHORD_TURN`` of turning of ``s_from`` the chord is at least half the arc, so
    such a point lies within ``w = 4 d`` of arc. The rest of the branch lies beyond
    ``CHORD_TURN`` but within ``BAND_TURN`` of ``s_from`` when the stretch to ``s_to`` turns at
    most ``SPAN_TURN``, where the clearance of the cell holding ``s_from`` (``B_CLEAR``) keeps
    every point that far away. So when that clearance is at least ``2 d``, the window
    ``[s_from - w, s_from + w]`` turns less than ``CHORD_TURN`` from ``s_from`` (so lies in the
    branch) and the stretch at most ``SPAN_TURN``, the nearest point is in that window.
    Returns ``(certain, lo, hi)``.
    """
    n = s0.shape[0] - 1
    length = s0[n]
    j = find_segment(s0, min(max(s_from, 0.0), length))
    d = math.sqrt((px - qx) ** 2 + (py - qy) ** 2 + (pz - qz) ** 2)
    w = 4.0 * d + 1e-9
    lo, hi = s_from - w, s_from + w
    if not closed:
        lo, hi = max(lo, 0.0), min(hi, length)
    a, b = s0[j], s0[j + 1]
    cell = min(max(int((s_from - a) / (b - a) * N_CELLS), 0), N_CELLS - 1) if b > a else 0
    if not bound[j, B_CLEAR + cell] >= 2.0 * d + 1e-9:
        return False, lo, hi
    t = unwrap_near(s_to, s_from, length, closed) if closed else s_to
    if a < min(lo, t) and max(hi, t) < b:  # inside one segment: it turns evenly
        rate = bound[j, B_TIN] / (b - a)
        return rate * w <= CHORD_TURN and rate * abs(t - s_from) <= SPAN_TURN, lo, hi
    if min(lo, t) < 0.0 or max(hi, t) > length:  # across the end of a closed path
        return False, lo, hi
    here, here_left = _turn_from(s0, bound, j, s_from, False), _turn_from(s0, bound, j, s_from,
                                                                          True)
    ahead = _turn_from(s0, bound, j, hi, True) - here
    behind = here_left - _turn_from(s0, bound, j, lo, False)
    if t >= s_from:
        span = _turn_from(s0, bound, j, t, False) - here_left
    else:
        span = here - _turn_from(s0, bound, j, t, True)
    return ahead <= CHORD_TURN and behind <= CHORD_TURN and span <= SPAN_TURN, lo, hi


@callee
def branch_nearest(kind, s0, data, bound, px, py, pz, s_from, s_to):
    """The true nearest point (module doc) of the branch from ``s_from`` to ``s_to``.

    ``s_from`` is where the machine was (its previous foot point), ``s_to`` where its
    reference is; both in [0, L]. Returns ``(s_foot, dist2)`` (:func:`branch_nearest_from`).
    """
    qx, qy, qz = eval_path(kind, s0, data, s_from)[:3]
    return branch_nearest_from(kind, s0, data, bound, px, py, pz, s_from, s_to, qx, qy, qz)


@callee(forceinline=True)
def branch_nearest_from(kind, s0, data, bound, px, py, pz, s_from, s_to, qx, qy, qz):
    """:func:`branch_nearest` given ``q = P(s_from)`` (the loop keeps its foot points).

    Usually the nearest point is certain to lie in a small window around ``s_from``
    (:func:`_local_window`), searched alone; else the branch is searched
    (:func:`search_branch`).
    """
    n = kind.shape[0]
    closed = is_closed_table(bound, n)
    certain, lo, hi = _local_window(s0, bound, px, py, pz, s_from, qx, qy, qz, s_to, closed)
    if certain:
        return nearest_in(kind, s0, data, bound, px, py, pz, closed, lo, hi)
    return search_branch(kind, s0, data, bound, px, py, pz, s_from, s_to)


@callee
def search_branch(kind, s0, data, bound, px, py, pz, s_from, s_to):
    """The nearest point of the branch from ``s_from`` to ``s_to``, by searching all of it.

    The search starts on ``s_from``'s segment (given the same as ``s_to``, the reference
    alone: on a segment near ``p``, :func:`nearest_leaf`).
    """
    n = kind.shape[0]
    length = s0[n]
    closed = is_closed_table(bound, n)
    a = unwrap_near(s_from, s_to, length, closed)
    lo, hi = branch_range(s0, bound, closed, min(a, s_to), max(a, s_to), HALF_TURN)
    windows = branch_windows(length, closed, lo, hi)
    if s_from != s_to:
        seed = find_segment(s0, min(max(s_from, 0.0), length))
    else:
        seed = nearest_leaf(kind, s0, bound, px, py, pz, windows)
    return search_tree(kind, s0, data, bound, px, py, pz, windows, seed, windows[0], np.inf)


@callee
def nearest_in(kind, s0, data, bound, px, py, pz, closed, lo, hi):
    """Nearest point with arc length in ``[lo, hi]``, wrapped on a closed path.

    :func:`~contour_gym.paths._geom.nearest_window` over each part (one call site): a window
    across 0 or L of a closed path is searched in two parts, the part in ``[0, L]`` first.
    """
    length = s0[s0.shape[0] - 1]
    windows = branch_windows(length, closed, lo, hi)
    sf, d2 = windows[0], np.inf
    for k in range(2):
        a, b = windows[2 * k], windows[2 * k + 1]
        if b < a:
            continue
        s2, e2 = nearest_window(kind, s0, data, bound, px, py, pz, a, b)
        if k == 0 or e2 < d2:
            sf, d2 = s2, e2
    return sf, d2


@callee
def branch_has_nearer(kind, s0, data, bound, px, py, pz, s, bar):
    """Whether the reference ``s``'s branch holds a point nearer ``p`` than ``sqrt(bar)``.

    Searches the certain window (:func:`_local_window`) where there is one, else the branch;
    subtrees farther than ``sqrt(bar)`` are skipped whole.
    """
    n = kind.shape[0]
    length = s0[n]
    closed = is_closed_table(bound, n)
    qx, qy, qz = eval_path(kind, s0, data, s)[:3]
    certain, lo, hi = _local_window(s0, bound, px, py, pz, s, qx, qy, qz, s, closed)
    if not certain:
        lo, hi = branch_range(s0, bound, closed, s, s, HALF_TURN)
    windows = branch_windows(length, closed, lo, hi)
    _, best = search_tree(kind, s0, data, bound, px, py, pz, windows, find_segment(s0, s),
                          -1.0, bar)
    return best < bar


@callee
def nearest_global(kind, s0, data, bound, px, py, pz):
    """Exact nearest point over the whole path: ``(s_foot, dist2)``.

    The search starts on a segment near ``p`` (:func:`nearest_leaf`), then searches the tree.
    """
    n = kind.shape[0]
    windows = (0.0, s0[n], 1.0, 0.0, 1.0, 0.0)
    seed = nearest_leaf(kind, s0, bound, px, py, pz, windows)
    return search_tree(kind, s0, data, bound, px, py, pz, windows, seed, 0.0, np.inf)
