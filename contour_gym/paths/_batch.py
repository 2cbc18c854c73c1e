"""The path engine's batch functions, called from Python (cached; :mod:`contour_gym.jit`).

Each runs one of :mod:`contour_gym.paths._geom`'s functions over many points, or builds a
table's per-segment data (bounding spheres, segment ends).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contour_gym._callee import callee
from contour_gym.paths._branch import branch_nearest, branch_nearest_from, nearest_global
from contour_gym.paths._geom import (
    _BOUND_SAMPLES,
    HELIX,
    LINE,
    _norm3,
    eval_path,
    eval_segment,
    side_2d,
    unit_tangent,
)


@numba.njit(cache=True)
def eval_many(kind, s0, data, s, out):
    """:func:`eval_path` at every ``s[k]`` into ``out[k, 0:9]``."""
    for k in range(s.shape[0]):
        r = eval_path(kind, s0, data, s[k])
        for j in range(9):
            out[k, j] = r[j]


@callee(forceinline=True)
def _foot_d2(kind, s0, data, sf, px, py, pz):
    # |P(sf) - p|^2 as the servo loop takes it (from the evaluated foot point), so that the
    # Python API's distances equal the loop's bit for bit
    x, y, z = eval_path(kind, s0, data, sf)[:3]
    vx, vy, vz = x - px, y - py, z - pz
    return vx * vx + vy * vy + vz * vz


@numba.njit(cache=True)
def nearest_many(kind, s0, data, bound, pts, out_s, out_d2):
    """Nearest point (:func:`nearest_global`) for every row of ``pts`` (N, 3)."""
    for k in range(pts.shape[0]):
        px, py, pz = pts[k, 0], pts[k, 1], pts[k, 2]
        sf, _ = nearest_global(kind, s0, data, bound, px, py, pz)
        out_s[k], out_d2[k] = sf, _foot_d2(kind, s0, data, sf, px, py, pz)


@numba.njit(cache=True)
def nearest_many_hinted(kind, s0, data, bound, pts, s_from, s_to, out_s, out_d2):
    """The branch's nearest point (:func:`~contour_gym.paths._branch.branch_nearest`) per row.

    Row ``k`` of ``pts`` (N, 3) on the branch from ``s_from[k]`` to ``s_to[k]``.
    """
    for k in range(pts.shape[0]):
        px, py, pz = pts[k, 0], pts[k, 1], pts[k, 2]
        sf, _ = branch_nearest(kind, s0, data, bound, px, py, pz, s_from[k], s_to[k])
        out_s[k], out_d2[k] = sf, _foot_d2(kind, s0, data, sf, px, py, pz)


@numba.njit(cache=True)
def track_many(kind, s0, data, bound, pts, s_ref, s_start, out_s, out_d2):
    """The true foot point along a trajectory: row ``k`` on the branch from foot ``k - 1``.

    Point ``k`` of ``pts`` (N, 3) with its reference at ``s_ref[k]``; the foot before the first
    point is at ``s_start``. As the servo loop tracks the machine's foot, tick by tick.
    """
    prev = s_start
    qx, qy, qz = eval_path(kind, s0, data, s_start)[:3]
    for k in range(pts.shape[0]):
        px, py, pz = pts[k, 0], pts[k, 1], pts[k, 2]
        prev, _ = branch_nearest_from(kind, s0, data, bound, px, py, pz, prev, s_ref[k], qx, qy,
                                      qz)
        qx, qy, qz = eval_path(kind, s0, data, prev)[:3]
        vx, vy, vz = qx - px, qy - py, qz - pz
        out_s[k], out_d2[k] = prev, vx * vx + vy * vy + vz * vz


@numba.njit(cache=True)
def side_many(kind, s0, data, closed, s, pts, out):
    """:func:`side_2d` for every foot ``s[k]`` and point ``pts[k]``."""
    for k in range(s.shape[0]):
        out[k] = side_2d(kind, s0, data, closed, s[k], pts[k, 0], pts[k, 1])


@callee
def _accel_bound(kind, data, i, seg_len):
    """Upper bound of |P''| over the segment."""
    k = kind[i]
    if k == LINE:
        return 0.0
    if k == HELIX:
        return data[i, 12] * data[i, 13] * data[i, 13]
    a = 0.0
    for j in range(2, 6):
        a += j * (j - 1) * _norm3(data, i, 3 * j) * seg_len ** (j - 2)
    return a


@numba.njit(cache=True)
def compute_bounds(kind, s0, data):
    """Bounding sphere (centre xyz, radius) of every segment, (n, 4).

    Samples each segment at ``_BOUND_SAMPLES + 1`` points; a curve piece between samples
    ``h`` apart lies within ``h^2 max|P''| / 8`` of their chord, which is added to the radius.
    """
    n = kind.shape[0]
    out = np.empty((n, 4))
    m = _BOUND_SAMPLES
    pts = np.empty((m + 1, 3))
    for i in range(n):
        seg_len = s0[i + 1] - s0[i]
        for q in range(m + 1):
            r = eval_segment(kind, data, i, seg_len * q / m)
            pts[q, 0] = r[0]
            pts[q, 1] = r[1]
            pts[q, 2] = r[2]
        cx = 0.5 * (pts[:, 0].min() + pts[:, 0].max())
        cy = 0.5 * (pts[:, 1].min() + pts[:, 1].max())
        cz = 0.5 * (pts[:, 2].min() + pts[:, 2].max())
        rad = 0.0
        for q in range(m + 1):
            rad = max(rad, math.sqrt((pts[q, 0] - cx) ** 2 + (pts[q, 1] - cy) ** 2
                                     + (pts[q, 2] - cz) ** 2))
        h = seg_len / m
        scale = abs(cx) + abs(cy) + abs(cz) + rad
        out[i, 0] = cx
        out[i, 1] = cy
        out[i, 2] = cz
        out[i, 3] = rad + h * h * _accel_bound(kind, data, i, seg_len) / 8.0 + 1e-14 * scale + 1e-15
    return out


@numba.njit(cache=True)
def segment_ends(kind, s0, data):
    """Point and unit tangent at the start and end of every segment, (n, 2, 6)."""
    n = kind.shape[0]
    out = np.empty((n, 2, 6))
    for i in range(n):
        for e in range(2):
            t = 0.0 if e == 0 else s0[i + 1] - s0[i]
            r = eval_segment(kind, data, i, t)
            ux, uy, uz = unit_tangent(kind, data, i, t)
            out[i, e, 0] = r[0]
            out[i, e, 1] = r[1]
            out[i, e, 2] = r[2]
            out[i, e, 3] = ux
            out[i, e, 4] = uy
            out[i, e, 5] = uz
    return out


@numba.njit(cache=True)
def chebyshev_many(coef, piece, x, out):
    """Chebyshev series ``coef[piece[k]]`` ((deg + 1, dim <= 3)) at ``x[k]`` into ``out[k]``.

    Clenshaw's recurrence ``b_j = 2 x b_(j+1) - b_(j+2) + c_j``, term by term as numpy would
    evaluate it (the same numbers), the coordinates' recurrences side by side (independent:
    1.8x faster than one after the other). The free-form curves' fitting
    (:mod:`~contour_gym.paths._freeform`) evaluates their interpolants at ~10^5 points a path.
    """
    n = coef.shape[1]
    dim = coef.shape[2]
    for k in range(x.shape[0]):
        p = piece[k]
        xk = x[k]
        x2 = 2.0 * xk
        b1x = b2x = b1y = b2y = b1z = b2z = 0.0
        for j in range(n - 1, 0, -1):
            tx = x2 * b1x - b2x + coef[p, j, 0]
            b2x, b1x = b1x, tx
            if dim > 1:
                ty = x2 * b1y - b2y + coef[p, j, 1]
                b2y, b1y = b1y, ty
            if dim > 2:
                tz = x2 * b1z - b2z + coef[p, j, 2]
                b2z, b1z = b1z, tz
        out[k, 0] = xk * b1x - b2x + coef[p, 0, 0]
        if dim > 1:
            out[k, 1] = xk * b1y - b2y + coef[p, 0, 1]
        if dim > 2:
            out[k, 2] = xk * b1z - b2z + coef[p, 0, 2]
