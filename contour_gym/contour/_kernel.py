"""Compiled contour error estimators behind one dispatch (the CCC's input each tick).

Every estimator maps the tool position (in path coordinates, offset removed) and what a
real controller knows at tick k (the path, the reference arc length ``s``, path speed ``v``
and acceleration ``a`` of the interpolator, and ``hist``: a ring buffer of the reference arc lengths of the
previous ticks, read with :func:`history_at`) to ``(eps, c0, c1, c2)``: the signed (2-D) or
unsigned (3-D) contour error and the coupling gains C with ``eps_vec = C eps`` pointing from
the tool toward the path (see :mod:`contour_gym.ccc`).
"""

from __future__ import annotations

import math

import numba

from contour_gym.paths._geom import eval_path, nearest_window

EST_GROUND_TRUTH = 0
N_EST_P = 8  # estimator options (same for every member)
N_HIST = 128  # past reference arc lengths kept per member (ring buffer)


@numba.njit(cache=True)
def history_push(hist, s):  # type: ignore[no-untyped-def]
    """Append arc length ``s`` to the ring buffer ``hist`` (hist[0] = head, hist[1:] = ring)."""
    head = int(hist[0]) + 1
    if head >= N_HIST:
        head = 0
    hist[0] = head
    hist[1 + head] = s


@numba.njit(cache=True)
def history_at(hist, i):  # type: ignore[no-untyped-def]
    """Reference arc length ``i + 1`` ticks ago (0 <= i < N_HIST); 0 before the start."""
    j = int(hist[0]) - i
    if j < 0:
        j += N_HIST
    return hist[1 + j]


@numba.njit(cache=True)
def error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty):  # type: ignore[no-untyped-def]
    """Signed/unsigned contour error and coupling gains from a foot point and its tangent."""
    vx, vy, vz = qx - p0, qy - p1, qz - p2
    if dim == 2:
        tn = math.hypot(tx, ty)
        nx, ny = -ty / tn, tx / tn  # left normal
        return -(vx * nx + vy * ny), -nx, -ny, 0.0
    eps = math.sqrt(vx * vx + vy * vy + vz * vz)
    if eps < 1e-300:
        return 0.0, 0.0, 0.0, 0.0
    return eps, vx / eps, vy / eps, vz / eps


@numba.njit(cache=True)
def ground_truth(kind, s0, data, bound, dim, p0, p1, p2, s):  # type: ignore[no-untyped-def]
    """Exact contour error, foot searched near the reference arc length ``s``.

    The window is ``s +- (4 d0 + 1e-9)`` with ``d0 = |p - r(s)|``: the foot lies within
    ``2 d0`` of ``r``, and along a smooth path or a corner of up to 90 degrees that chord
    bounds the arc length by ``4 d0``. At a self-intersection it keeps the traversed branch.

    Returns:
        ``(eps, c0, c1, c2, s_foot)``.
    """
    rx, ry, rz, _, _, _, _, _, _ = eval_path(kind, s0, data, s)
    w = 4.0 * math.sqrt((p0 - rx) ** 2 + (p1 - ry) ** 2 + (p2 - rz) ** 2) + 1e-9
    sf, _ = nearest_window(kind, s0, data, bound, p0, p1, p2, s - w, s + w)
    qx, qy, qz, tx, ty, _, _, _, _ = eval_path(kind, s0, data, sf)
    eps, c0, c1, c2 = error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty)
    return eps, c0, c1, c2, sf


@numba.njit(cache=True)
def estimate(est_kind, est_p, kind, s0, data, bound, dim, p0, p1, p2, s, v, a, hist, ts):  # type: ignore[no-untyped-def]
    """Dispatch to the estimator ``est_kind``; returns ``(eps, c0, c1, c2)``."""
    eps, c0, c1, c2, _ = ground_truth(kind, s0, data, bound, dim, p0, p1, p2, s)
    return eps, c0, c1, c2
