"""Compiled contour error: the exact search (ground truth) and the estimators' common finish.

Every estimator (:mod:`contour_gym.contour._estimators`, registered in
:data:`contour_gym.contour.ESTIMATORS`) maps the tool position and what a real controller knows
at tick k to a foot point and a tangent, or gives up. :func:`resolve` turns that into
``(eps, c0, c1, c2)``: the signed (2-D) or unsigned (3-D) contour error and the coupling gains C
with ``eps_vec = C eps`` pointing from the tool toward the path (see :mod:`contour_gym.ccc`),
falling back to :func:`ground_truth` when the estimator gave up or its foot point is
implausible: farther from the tool than the reference point itself (``|q - p| > |r - p|``,
impossible for the true foot), or not finite.

The exact search is the true contour error's one definition
(:mod:`contour_gym.paths._branch`): the nearest point of the branch from where the machine
was to where its reference is, extended until the path turns 180 degrees beyond it.
"""

from __future__ import annotations

import math

import numba

from contour_gym._callee import callee
from contour_gym.contour._history import N_HIST, history_at, history_push
from contour_gym.paths._branch import branch_nearest_from, is_closed_table
from contour_gym.paths._geom import eval_path, find_segment, side_2d

__all__ = [
    "N_HIST",
    "error_from_foot",
    "ground_truth",
    "ground_truth_from",
    "history_at",
    "history_push",
    "resolve",
]


@numba.njit(cache=True, inline="always")
def error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty):
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
def _exact_error_2d(kind, s0, data, bound, p0, p1, qx, qy, tx, ty, sf):
    """2-D error of an exact foot q: ``|q - p|`` signed (+ left of travel), ``C = (q - p)/eps``.

    ``|q - p|`` rather than the normal component: the two differ where ``q - p`` is not normal
    to the path, i.e. at a corner vertex or an end point. On a segment boundary the side is
    taken against the corner bisector, like :meth:`contour_gym.paths.Path.nearest`, so the
    two agree.
    """
    n = s0.shape[0] - 1
    total = s0[n]
    vx, vy = qx - p0, qy - p1
    if sf == s0[find_segment(s0, sf)] or sf >= total:
        closed = (sf <= 0.0 or sf >= total) and is_closed_table(bound, n)
        sign = side_2d(kind, s0, data, closed, sf, p0, p1)
    else:
        sign = -1.0 if tx * vy - ty * vx > 0.0 else 1.0  # q - p to the left: p is right
    eps = sign * math.sqrt(vx * vx + vy * vy)
    if eps == 0.0:
        return error_from_foot(2, p0, p1, 0.0, qx, qy, 0.0, tx, ty)
    return eps, vx / eps, vy / eps, 0.0


@numba.njit(cache=True, inline="always")
def ground_truth(kind, s0, data, bound, dim, p0, p1, p2, s):
    """Exact contour error on the branch of the reference arc length ``s``.

    What a controller that knows only its reference can compute exactly: the nearest point of
    the path within a half turn of the reference (:mod:`contour_gym.paths._branch`), equal to
    :meth:`contour_gym.paths.Path.nearest` with ``s`` as hint. The error is ``|q - p|``
    (signed in 2-D, see :func:`_exact_error_2d`).

    Returns:
        ``(eps, c0, c1, c2, s_foot)``.
    """
    rx, ry, rz, _, _, _, _, _, _ = eval_path(kind, s0, data, s)
    eps, c0, c1, c2, sf, _, _, _ = ground_truth_from(
        kind, s0, data, bound, dim, p0, p1, p2, s, rx, ry, rz, s
    )
    return eps, c0, c1, c2, sf


@callee
def ground_truth_from(kind, s0, data, bound, dim, p0, p1, p2, s_from, qx, qy, qz, s_to):
    """The true contour error of ``p`` on the branch from ``s_from`` to ``s_to``.

    ``s_from`` is where the machine's foot point was (the previous tick's, at ``q``), ``s_to``
    where its reference is: the definition of :mod:`contour_gym.paths._branch`. Returns
    ``(eps, c0, c1, c2, s_foot, qx, qy, qz)`` (the new foot point).

    Called, never ``inline="always"`` (numba's inlining made a kernel's compile 3x longer: the
    documentation's "Measurements and design notes"); not cached, so it compiles with the
    kernel that calls it and LLVM inlines it there (:mod:`contour_gym.jit`).
    """
    sf, _ = branch_nearest_from(kind, s0, data, bound, p0, p1, p2, s_from, s_to, qx, qy, qz)
    fx, fy, fz, tx, ty, _, _, _, _ = eval_path(kind, s0, data, sf)
    if dim == 2:
        eps, c0, c1, c2 = _exact_error_2d(kind, s0, data, bound, p0, p1, fx, fy, tx, ty, sf)
    else:
        eps, c0, c1, c2 = error_from_foot(dim, p0, p1, p2, fx, fy, fz, tx, ty)
    return eps, c0, c1, c2, sf, fx, fy, fz


@numba.njit(cache=True, inline="always")
def resolve(foot, kind, s0, data, bound, dim, p0, p1, p2, s):
    """``(eps, c0, c1, c2, fell)`` from an estimator's ``foot`` tuple (module docstring)."""
    ok, qx, qy, qz, tx, ty, tz, e2 = foot
    if ok:
        d2 = (qx - p0) ** 2 + (qy - p1) ** 2 + (qz - p2) ** 2
        tt = tx * tx + ty * ty + (tz * tz if dim == 3 else 0.0)
        plausible = e2 < 0.0 or d2 <= e2 * (1.0 + 1e-9) + 1e-30
        if plausible and tt > 0.0 and math.isfinite(tt + d2):
            eps, c0, c1, c2 = error_from_foot(dim, p0, p1, p2, qx, qy, qz, tx, ty)
            return eps, c0, c1, c2, False
    eps, c0, c1, c2, _ = ground_truth(kind, s0, data, bound, dim, p0, p1, p2, s)
    return eps, c0, c1, c2, True


@numba.njit(cache=True)
def _fill_history(hist, s, s_hist, ds, mode):
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
def _row_finite(row):
    ok = True
    for x in row:
        ok = ok and math.isfinite(x)
    return ok
