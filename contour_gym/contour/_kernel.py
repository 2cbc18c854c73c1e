"""Compiled contour error estimators behind one dispatch (the CCC's input each tick).

Every estimator maps the tool position (in path coordinates, offset removed) and what a
real controller knows at tick k (the path, the reference arc length ``s``, path speed ``v``
and acceleration ``a`` of the interpolator, and ``hist``: a ring buffer of the reference arc
lengths of the previous ticks, read with :func:`history_at`) to ``(eps, c0, c1, c2)``: the
signed (2-D) or unsigned (3-D) contour error and the coupling gains C with
``eps_vec = C eps`` pointing from the tool toward the path (see :mod:`contour_gym.ccc`).

The estimators themselves live in :mod:`contour_gym.contour._estimators`; each returns a
foot point and a tangent, or gives up. :func:`estimate` falls back to :func:`ground_truth`
when an estimator gives up or its foot point is implausible: farther from the tool than the
reference point itself (``|q - p| > |r - p|``, impossible for the true foot), or not finite.
None of the built-in estimators reads ``v``, ``a`` or ``ts``; they stay in the signature
for the loop kernel.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contour_gym.contour._estimators import (
    FAIL,
    est_angle,
    est_exact,
    est_frenet,
    est_iterative,
    est_tangent,
    est_two_circle,
    est_window,
)
from contour_gym.contour._history import N_HIST, history_at, history_push
from contour_gym.paths._geom import (
    eval_path,
    find_segment,
    nearest_window_wrapped,
    side_2d,
)

EST_GROUND_TRUTH = 0
EST_EXACT = 1
EST_TWO_CIRCLE = 2
EST_TANGENT = 3
EST_FRENET = 4
EST_ANGLE = 5
EST_WINDOW = 6
EST_ITERATIVE = 7
N_EST_P = 8  # estimator options (same for every member)
CLOSED_TOL = 1e-9  # as contour_gym.paths.Path: start and end this close make a closed path

__all__ = [
    "N_HIST",
    "N_EST_P",
    "error_from_foot",
    "estimate",
    "estimate_flagged",
    "estimate_many",
    "ground_truth",
    "history_at",
    "history_push",
]


@numba.njit(cache=True, inline="always")
def error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty):  # type: ignore[no-untyped-def]
    """Signed/unsigned contour error and coupling gains from a foot point and its tangent.

    2-D: the component of ``q - p`` along the normal of the tangent (exact for a true foot
    point; for an estimated one it drops the error's first-order tangential part). 3-D:
    ``eps = |q - p|``, ``C = (q - p)/eps``.
    """
    vx, vy, vz = qx - p0, qy - p1, qz - p2
    if dim == 2:
        tn = math.sqrt(tx * tx + ty * ty)
        nx, ny = -ty / tn, tx / tn  # left normal
        return -(vx * nx + vy * ny), -nx, -ny, 0.0
    eps = math.sqrt(vx * vx + vy * vy + vz * vz)
    if eps < 1e-300:
        return 0.0, 0.0, 0.0, 0.0
    return eps, vx / eps, vy / eps, vz / eps


@numba.njit(cache=True, inline="always")
def _exact_error_2d(kind, s0, data, p0, p1, qx, qy, tx, ty, sf):  # type: ignore[no-untyped-def]
    """2-D error of an exact foot q: ``|q - p|`` signed (+ left of travel), ``C = (q - p)/eps``.

    ``|q - p|`` rather than the normal component: the two differ where ``q - p`` is not normal
    to the path, i.e. at a corner vertex, an end point, or the search window's edge. On a
    segment boundary the side is taken against the corner bisector, like
    :meth:`contour_gym.paths.Path.nearest`, so the two agree.
    """
    total = s0[s0.shape[0] - 1]
    vx, vy = qx - p0, qy - p1
    if sf == s0[find_segment(s0, sf)] or sf >= total:
        closed = False
        if sf <= 0.0 or sf >= total:
            ax, ay, az, _, _, _, _, _, _ = eval_path(kind, s0, data, 0.0)
            bx, by, bz, _, _, _, _, _, _ = eval_path(kind, s0, data, total)
            closed = math.sqrt((ax - bx) ** 2 + (ay - by) ** 2 + (az - bz) ** 2) <= CLOSED_TOL
        sign = side_2d(kind, s0, data, closed, sf, p0, p1)
    else:
        sign = -1.0 if tx * vy - ty * vx > 0.0 else 1.0  # q - p to the left: p is right
    eps = sign * math.sqrt(vx * vx + vy * vy)
    if eps == 0.0:
        return error_from_foot(2, p0, p1, 0.0, qx, qy, 0.0, tx, ty)
    return eps, vx / eps, vy / eps, 0.0


@numba.njit(cache=True, inline="always")
def ground_truth(kind, s0, data, bound, dim, p0, p1, p2, s):  # type: ignore[no-untyped-def]
    """Exact contour error, foot searched near the reference arc length ``s``.

    The window is ``s +- (4 d0 + 1e-9)`` with ``d0 = |p - r(s)|``: the foot lies within
    ``2 d0`` of ``r``, and along a smooth path or a corner of up to 90 degrees that chord
    bounds the arc length by ``4 d0``. At a self-intersection it keeps the traversed branch.
    The error is ``|q - p|`` (signed in 2-D, see :func:`_exact_error_2d`), equal to
    :meth:`contour_gym.paths.Path.nearest` with the reference as hint.

    Returns:
        ``(eps, c0, c1, c2, s_foot)``.
    """
    rx, ry, rz, _, _, _, _, _, _ = eval_path(kind, s0, data, s)
    return ground_truth_from(kind, s0, data, bound, dim, p0, p1, p2, s, rx, ry, rz)


@numba.njit(cache=True, inline="always")
def ground_truth_from(kind, s0, data, bound, dim, p0, p1, p2, s, rx, ry, rz):  # type: ignore[no-untyped-def]
    """:func:`ground_truth` given the reference point ``r(s)`` the caller already has."""
    w = 4.0 * math.sqrt((p0 - rx) ** 2 + (p1 - ry) ** 2 + (p2 - rz) ** 2) + 1e-9
    sf, _ = nearest_window_wrapped(kind, s0, data, bound, p0, p1, p2, s - w, s + w)
    qx, qy, qz, tx, ty, _, _, _, _ = eval_path(kind, s0, data, sf)
    if dim == 2:
        eps, c0, c1, c2 = _exact_error_2d(kind, s0, data, p0, p1, qx, qy, tx, ty, sf)
    else:
        eps, c0, c1, c2 = error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty)
    return eps, c0, c1, c2, sf


@numba.njit(cache=True)
def _foot(est_kind, est_p, kind, s0, data, bound, p0, p1, p2, s, hist):  # type: ignore[no-untyped-def]
    """The estimator ``est_kind``'s ``(ok, q, tangent, e2)`` (see :mod:`._estimators`)."""
    if est_kind == EST_EXACT:
        return est_exact(kind, s0, data, p0, p1, p2, s)
    elif est_kind == EST_TWO_CIRCLE:
        return est_two_circle(kind, s0, data, p0, p1, p2, s, hist)
    elif est_kind == EST_TANGENT:
        return est_tangent(est_p[0], kind, s0, data, p0, p1, p2, s)
    elif est_kind == EST_FRENET:
        return est_frenet(int(est_p[0]), est_p[1], kind, s0, data, p0, p1, p2, s)
    elif est_kind == EST_ANGLE:
        return est_angle(int(est_p[0]), est_p[1], kind, s0, data, p0, p1, p2, s, hist)
    elif est_kind == EST_WINDOW:
        return est_window(int(est_p[0]), kind, s0, data, p0, p1, p2, s, hist)
    elif est_kind == EST_ITERATIVE:
        return est_iterative(
            int(est_p[0]), int(est_p[1]), est_p[2], kind, s0, data, bound, p0, p1, p2, s
        )
    return FAIL


@numba.njit(cache=True)
def estimate_flagged(est_kind, est_p, kind, s0, data, bound, dim, p0, p1, p2, s, v, a, hist, ts):  # type: ignore[no-untyped-def]
    """:func:`estimate` plus a flag: True when it fell back to :func:`ground_truth`."""
    if est_kind != EST_GROUND_TRUTH:
        ok, qx, qy, qz, tx, ty, tz, e2 = _foot(
            est_kind, est_p, kind, s0, data, bound, p0, p1, p2, s, hist
        )
        if ok:
            d2 = (qx - p0) ** 2 + (qy - p1) ** 2 + (qz - p2) ** 2
            tt = tx * tx + ty * ty + (tz * tz if dim == 3 else 0.0)
            plausible = e2 < 0.0 or d2 <= e2 * (1.0 + 1e-9) + 1e-30
            if plausible and tt > 0.0 and math.isfinite(tt + d2):
                eps, c0, c1, c2 = error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty)
                return eps, c0, c1, c2, False
    eps, c0, c1, c2, _ = ground_truth(kind, s0, data, bound, dim, p0, p1, p2, s)
    return eps, c0, c1, c2, est_kind != EST_GROUND_TRUTH


@numba.njit(cache=True)
def estimate(est_kind, est_p, kind, s0, data, bound, dim, p0, p1, p2, s, v, a, hist, ts):  # type: ignore[no-untyped-def]
    """Dispatch to the estimator ``est_kind``; returns ``(eps, c0, c1, c2)``."""
    eps, c0, c1, c2, _ = estimate_flagged(
        est_kind, est_p, kind, s0, data, bound, dim, p0, p1, p2, s, v, a, hist, ts
    )
    return eps, c0, c1, c2


@numba.njit(cache=True)
def _fill_history(hist, s, s_hist, ds, mode):  # type: ignore[no-untyped-def]
    """Fill one member's ring buffer from the given past.

    Mode 1: the ``s_hist`` row, most recent first, its oldest value held beyond it; mode 2:
    a constant step ``ds`` back from ``s`` (not below 0); mode 0: the reference at rest.
    """
    hist[0] = 0.0
    n = s_hist.shape[0]
    for i in range(N_HIST):
        if mode == 1:
            v = s_hist[min(i, n - 1)]
        elif mode == 2:
            v = max(s - (i + 1) * ds, 0.0)
        else:
            v = s
        hist[1 + (N_HIST - i) % N_HIST] = v  # head 0: history_at(i) reads hist[1 + (-i mod N)]


@numba.njit(cache=True)
def _row_finite(row):  # type: ignore[no-untyped-def]
    ok = True
    for x in row:
        ok = ok and math.isfinite(x)
    return ok


@numba.njit(cache=True)
def estimate_many(est_kind, est_p, kind, s0, data, bound, pos, s, s_hist, ds, mode, out, fell):  # type: ignore[no-untyped-def]
    """:func:`estimate_flagged` for every member: ``out[b] = (eps, c0, c1, c2)``, ``fell[b]``.

    ``pos`` (B, dim) tool positions in path coordinates; ``s`` (B,) or (1,) references;
    ``s_hist`` (B or 1, n) previous references, most recent first (mode 1), or ``ds``
    (B,) or (1,) a constant interpolation step (mode 2); mode 0: the reference at rest.

    Returns:
        -1, or the first member whose input is not finite (its row is then not computed).
    """
    dim = pos.shape[1]
    hist = np.zeros(N_HIST + 1)
    for b in range(pos.shape[0]):
        sb = s[b if s.shape[0] > 1 else 0]
        hrow = s_hist[b if s_hist.shape[0] > 1 else 0]
        db = ds[b if ds.shape[0] > 1 else 0]
        if not (
            _row_finite(pos[b])
            and math.isfinite(sb)
            and math.isfinite(db)
            and (mode != 1 or _row_finite(hrow))
        ):
            return b
        _fill_history(hist, sb, hrow, db, mode)
        p2 = pos[b, 2] if dim == 3 else 0.0
        eps, c0, c1, c2, fb = estimate_flagged(
            est_kind,
            est_p,
            kind,
            s0,
            data,
            bound,
            dim,
            pos[b, 0],
            pos[b, 1],
            p2,
            sb,
            0.0,
            0.0,
            hist,
            1.0,
        )
        out[b, 0], out[b, 1], out[b, 2], out[b, 3] = eps, c0, c1, c2
        fell[b] = fb
    return -1
