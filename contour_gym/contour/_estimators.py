"""The compiled contour error estimators, one small function each.

Every estimator returns ``(ok, qx, qy, qz, tx, ty, tz, e2)``: its estimate of the foot point
q (the point of the path nearest the tool) and a tangent direction there, or ``ok = False``
when it cannot find a foot point; the dispatch in :mod:`contour_gym.contour._kernel` then
falls back to the exact search. ``e2`` is ``|r - p|^2`` (r the reference point) for the
dispatch's plausibility check ``|q - p| <= |r - p|``, or -1 where the construction already
guarantees it (projections on a line or circle through r, certified feet). The dispatch
turns (q, tangent) into the contour error and coupling gains
(:func:`contour_gym.contour._kernel.error_from_foot`).

Inputs are what a real controller has at tick k: the path table, the tool position
``p = (p0, p1, p2)`` in path coordinates, the reference arc length ``s`` and the ring buffer
``hist`` of the previous references (:mod:`contour_gym.contour._history`). Interpolation
point ``j`` is the reference ``j`` ticks ago (:func:`~contour_gym.contour._history.ref_arc`).

The functions are not cached: they compile with the loop kernel that calls them, where LLVM
inlines them (:mod:`contour_gym.jit`).

Some of the papers' equations were lost in text extraction; each docstring names the paper
(``000`` .. ``004``, cited by title in docs/references.md), the equations and what was
reconstructed.
"""

from __future__ import annotations

import math

import numba

from contour_gym._callee import callee
from contour_gym._schema import Param, Schema
from contour_gym._validate import positive
from contour_gym.contour._history import N_HIST, eval_path_memo, history_at, ref_arc
from contour_gym.contour.base import ContourEstimator, int_in, one_of, register_estimator
from contour_gym.paths._branch import branch_has_nearer
from contour_gym.paths._geom import HELIX, LINE, eval_path, find_segment

FAIL = (False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
TRUSTED = -1.0  # e2 of a foot that needs no plausibility check
J_AHEAD = -2  # newest interpolation point searched: two steps ahead of the reference
J_OLDEST = N_HIST - 1  # oldest interpolation point kept
_COLLINEAR = 1e-10  # sin of the turn below which three points are taken as a line
_MIN_CHORD = 1e-10  # shortest chord (m) that still defines a direction


@numba.njit
def line_foot(p0, p1, p2, ax, ay, az, ux, uy, uz):
    """Foot of p on the line through a with direction u (|u| > 0)."""
    t = ((p0 - ax) * ux + (p1 - ay) * uy + (p2 - az) * uz) / (ux * ux + uy * uy + uz * uz)
    return ax + t * ux, ay + t * uy, az + t * uz


@numba.njit
def far_off(p0, p1, p2, rx, ry, rz, tx, ty, tz, kx, ky, kz, max_turn):
    """True when the tracking error spans more than ``max_turn`` rad of the path's turning.

    ``kappa |e| > max_turn`` with kappa the curvature at the reference: a tangent line or
    Taylor expansion at the reference says nothing about the path that far away.
    """
    cx = ty * kz - tz * ky
    cy = tz * kx - tx * kz
    cz = tx * ky - ty * kx
    sp = math.sqrt(tx * tx + ty * ty + tz * tz)
    kappa = math.sqrt(cx * cx + cy * cy + cz * cz) / (sp * sp * sp)
    e = math.sqrt((rx - p0) ** 2 + (ry - p1) ** 2 + (rz - p2) ** 2)
    return kappa * e > max_turn


@callee
def est_exact(kind, s0, data, p0, p1, p2, s):
    """000 eqs. (1)-(3): exact contour error of a line or an arc (foot on the reference's segment).

    Reconstructed: eq. (1) ``eps = -e_x sin(theta) + e_y cos(theta)`` (the distance from P to
    the line through R at angle theta), eqs. (2)-(3) ``eps = r - ||P - O||``
    ``= r - sqrt((x_p - x_o)^2 + (y_p - y_o)^2)``; as foot points: the projection of P on the
    line, and ``O + r (P - O)/||P - O||`` on the circle (in the arc's plane in 3-D). The line
    or circle is the one carrying the reference's segment (000 takes one line or arc; at a
    corner between segments this is the paper's breakdown). Fails (falls back to the exact
    search) on free-form (POLY5) and helix segments and with the tool at the arc's centre.
    """
    total = s0[s0.shape[0] - 1]
    i = find_segment(s0, min(max(s, 0.0), total))
    if kind[i] == LINE:
        ux, uy, uz = data[i, 3], data[i, 4], data[i, 5]
        qx, qy, qz = line_foot(p0, p1, p2, data[i, 0], data[i, 1], data[i, 2], ux, uy, uz)
        return True, qx, qy, qz, ux, uy, uz, TRUSTED
    if kind[i] != HELIX or data[i, 14] != 0.0:
        return FAIL
    vx, vy, vz = p0 - data[i, 0], p1 - data[i, 1], p2 - data[i, 2]
    x = vx * data[i, 3] + vy * data[i, 4] + vz * data[i, 5]
    y = vx * data[i, 6] + vy * data[i, 7] + vz * data[i, 8]
    rho = math.hypot(x, y)
    if rho == 0.0:
        return FAIL
    c, sn = x / rho, y / rho
    sgn = 1.0 if data[i, 13] > 0.0 else -1.0
    ux = c * data[i, 3] + sn * data[i, 6]  # unit radial direction of p, in the arc's plane
    uy = c * data[i, 4] + sn * data[i, 7]
    uz = c * data[i, 5] + sn * data[i, 8]
    vx = sgn * (c * data[i, 6] - sn * data[i, 3])  # tangent, in the direction of travel
    vy = sgn * (c * data[i, 7] - sn * data[i, 4])
    vz = sgn * (c * data[i, 8] - sn * data[i, 5])
    r = data[i, 12]
    return (True, data[i, 0] + r * ux, data[i, 1] + r * uy, data[i, 2] + r * uz, vx, vy, vz,
            TRUSTED)


@callee
def est_tangent(max_turn, kind, s0, data, p0, p1, p2, s):
    """001 section 2 (Yeh & Hsu): the foot on the tangent line at the reference.

    Reconstructed (001's eqs. (1)-(6) were lost; Yeh & Hsu 2002's standard form): with the
    tracking error ``e = r - p`` and the unit tangent ``t`` at the reference r, the
    estimated contour error vector is ``eps_hat = e - (e . t) t`` (the shortest vector from
    p to the tangent line), the normalised vector ``eps_hat / |eps_hat|`` gives the coupling
    gains, and ``eps = |eps_hat|``. Works in 2-D and 3-D. Its error grows like
    ``kappa (e . t)^2 / 2``; falls back to the exact search when ``kappa |e| > max_turn``.
    """
    rx, ry, rz, tx, ty, tz, kx, ky, kz = eval_path(kind, s0, data, s)
    if far_off(p0, p1, p2, rx, ry, rz, tx, ty, tz, kx, ky, kz, max_turn):
        return FAIL
    qx, qy, qz = line_foot(p0, p1, p2, rx, ry, rz, tx, ty, tz)
    return True, qx, qy, qz, tx, ty, tz, TRUSTED


@callee
def est_frenet(order, max_turn, kind, s0, data, p0, p1, p2, s):
    """002 section 4.1 eqs. (19)-(22): Frenet-frame estimate with the delay time.

    ``e = P_d - P_a`` is written in the Frenet frame ``t = P'_d/|P'_d|``, ``n``, ``b`` (eqs.
    (20)-(21)); the delay time is ``t_d = e_t / |P'_d|`` (eq. 22) and the estimated foot point
    is ``P_e = P_d(t - t_d)``, ``eps_hat = P_e - P_a`` (eq. 19), by Taylor expansion.
    Reconstructed: the expansion is taken in arc length, where ``|dP_d/dt| t_d = e_t`` gives
    the shift ``ds = e_t / |P'(s)|`` exactly: ``P_e = P - P' ds + P'' ds^2 / 2`` (``order`` 2,
    default; ``order`` 1 is the paper's first-order ``L = V_d t_d``). The time-domain
    expansion's extra ``a t_d^2 / 2`` (interpolator acceleration) term is dropped: it moves
    P_e along the path, away from the foot. The estimate therefore needs neither the
    feedrate nor the acceleration and is defined at rest. Falls back to the exact search
    when ``kappa |e| > max_turn`` (outside the expansion's range).
    """
    rx, ry, rz, tx, ty, tz, kx, ky, kz = eval_path(kind, s0, data, s)
    if far_off(p0, p1, p2, rx, ry, rz, tx, ty, tz, kx, ky, kz, max_turn):
        return FAIL
    ds = ((rx - p0) * tx + (ry - p1) * ty + (rz - p2) * tz) / (tx * tx + ty * ty + tz * tz)
    h = 0.5 * ds * ds if order >= 2 else 0.0
    g = ds if order >= 2 else 0.0
    e2 = (rx - p0) ** 2 + (ry - p1) ** 2 + (rz - p2) ** 2
    return (True, rx - tx * ds + kx * h, ry - ty * ds + ky * h, rz - tz * ds + kz * h,
            tx - kx * g, ty - ky * g, tz - kz * g, e2)


@callee
def est_angle(lag, max_turn, kind, s0, data, p0, p1, p2, s, hist):
    """003 section 3 eqs. (16)-(21): linear contour angle from the previous and current command.

    The contour is taken as the line through the previous command point D' and the current
    one D at the angle theta (eq. 16); with ``e_x = x_d - x``, ``e_y = y_d - y`` (eq. 17) the
    contour error is ``eps = e_x sin(theta) - e_y cos(theta)`` (eqs. 18-19) and its axis
    components ``eps_x = eps sin(theta)``, ``eps_y = -eps cos(theta)`` (eqs. 20-21).
    Reconstructed: eq. (16) folds theta into [0, pi) (``atan`` of the slope, plus pi when
    negative) and eq. (21) lost its minus sign (the text: eps_x and eps_y have opposite signs
    for theta in (0, pi/2)). The vector ``(eps_x, eps_y)`` is the tracking error's component
    normal to the chord D'D, which is what is computed here (in 3-D too); the scalar follows
    the library's convention (left of travel positive), which equals 003's up to the sign
    that its folded theta attaches to the direction of travel. D' is the reference ``lag``
    ticks ago; at rest (D' = D) older points are used, and with no distinct point in the
    buffer the estimator falls back to the exact search, as it does when
    ``kappa |e| > max_turn``.
    """
    # both points remembered in the member's row: the loop's reference and the other
    # contours ask for the same ones this tick
    rx, ry, rz, tx, ty, tz, kx, ky, kz = eval_path_memo(kind, s0, data, s, hist)
    if far_off(p0, p1, p2, rx, ry, rz, tx, ty, tz, kx, ky, kz, max_turn):
        return FAIL
    for j in range(lag, N_HIST + 1):
        arc = ref_arc(hist, s, j)
        if arc == s:  # the reference at rest here: no chord (and no path evaluation to see it)
            continue
        ax, ay, az, _, _, _, _, _, _ = eval_path_memo(kind, s0, data, arc, hist)
        ux, uy, uz = rx - ax, ry - ay, rz - az
        if ux * ux + uy * uy + uz * uz > _MIN_CHORD * _MIN_CHORD:
            qx, qy, qz = line_foot(p0, p1, p2, rx, ry, rz, ux, uy, uz)
            return True, qx, qy, qz, ux, uy, uz, TRUSTED
    return FAIL


@callee
def ref_point(kind, s0, data, hist, s, j):
    """Interpolation point ``j`` (see :func:`~contour_gym.contour._history.ref_arc`)."""
    x, y, z, _, _, _, _, _, _ = eval_path(kind, s0, data, ref_arc(hist, s, j))
    return x, y, z


@callee
def lag_steps(kind, s0, data, hist, s, p0, p1, p2):
    """First guess of the nearest interpolation point, and ``|r - p|^2``.

    The guess is ``round(e_t / ds)``: the tracking error along the tangent at the reference
    measured in last interpolation steps ``ds`` (0 at rest), clamped to the buffer.
    """
    rx, ry, rz, tx, ty, tz, _, _, _ = eval_path(kind, s0, data, s)
    e2 = (rx - p0) ** 2 + (ry - p1) ** 2 + (rz - p2) ** 2
    step = s - history_at(hist, 0)
    if not step > 0.0:
        return 0, e2
    et = ((rx - p0) * tx + (ry - p1) * ty + (rz - p2) * tz) / math.sqrt(tx * tx + ty * ty + tz * tz)
    j = et / step
    if not j < J_OLDEST:
        return J_OLDEST, e2
    return max(int(round(j)), J_AHEAD), e2


@callee
def nearest_quad(kind, s0, data, hist, s, p0, p1, p2, j):
    """Four interpolation points ``j-1, j, j+1, j+2`` around the one nearest p (index j).

    Starting from ``j``, the four slide one step at a time toward the nearer neighbour of
    point j until j is no farther than both (a local minimum: 000's stop condition), each
    step evaluating one new point. Returns ``(ok, A, B, C, D)`` (12 coordinates, A newest);
    ``ok`` is False when the minimum would lie beyond the buffer (the tool lags by more
    than it holds or leads by more than one step).
    """
    j = min(max(j, J_AHEAD + 1), J_OLDEST - 2)
    ax, ay, az = ref_point(kind, s0, data, hist, s, j - 1)
    bx, by, bz = ref_point(kind, s0, data, hist, s, j)
    cx, cy, cz = ref_point(kind, s0, data, hist, s, j + 1)
    dx, dy, dz = ref_point(kind, s0, data, hist, s, j + 2)
    da = (ax - p0) ** 2 + (ay - p1) ** 2 + (az - p2) ** 2
    db = (bx - p0) ** 2 + (by - p1) ** 2 + (bz - p2) ** 2
    dc = (cx - p0) ** 2 + (cy - p1) ** 2 + (cz - p2) ** 2
    ok = True
    for _ in range(N_HIST):
        if dc < db:  # the nearest lies further back
            if j >= J_OLDEST - 2:
                ok = False
                break
            j += 1
            ax, ay, az, bx, by, bz, cx, cy, cz = bx, by, bz, cx, cy, cz, dx, dy, dz
            dx, dy, dz = ref_point(kind, s0, data, hist, s, j + 2)
            da, db, dc = db, dc, (cx - p0) ** 2 + (cy - p1) ** 2 + (cz - p2) ** 2
        elif da < db:  # the nearest lies ahead
            if j <= J_AHEAD + 1:
                ok = False
                break
            j -= 1
            bx, by, bz, cx, cy, cz, dx, dy, dz = ax, ay, az, bx, by, bz, cx, cy, cz
            ax, ay, az = ref_point(kind, s0, data, hist, s, j - 1)
            da, db, dc = (ax - p0) ** 2 + (ay - p1) ** 2 + (az - p2) ** 2, da, db
        else:
            break
    return ok, ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz


@callee
def circle_foot(ax, ay, az, bx, by, bz, cx, cy, cz, p0, p1, p2):
    """Nearest point of p on the circle through A (newest), B, C; the line if they are collinear.

    Returns ``(ok, qx, qy, qz, tx, ty, tz)`` with the tangent pointing from C toward A. In
    3-D, p is first projected on the circle's plane. Fails for coincident points or p on
    the circle's axis.
    """
    ux, uy, uz = ax - bx, ay - by, az - bz
    wx, wy, wz = cx - bx, cy - by, cz - bz
    nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
    u2, w2 = ux * ux + uy * uy + uz * uz, wx * wx + wy * wy + wz * wz
    n2 = nx * nx + ny * ny + nz * nz
    dx, dy, dz = ax - cx, ay - cy, az - cz
    if not (u2 > 0.0 and w2 > 0.0):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if n2 <= _COLLINEAR * _COLLINEAR * u2 * w2:
        qx, qy, qz = line_foot(p0, p1, p2, cx, cy, cz, dx, dy, dz)
        return True, qx, qy, qz, dx, dy, dz
    # circumcentre relative to B: ((|u|^2 w - |w|^2 u) x n) / (2 |n|^2)
    gx, gy, gz = u2 * wx - w2 * ux, u2 * wy - w2 * uy, u2 * wz - w2 * uz
    ox = bx + (gy * nz - gz * ny) / (2.0 * n2)
    oy = by + (gz * nx - gx * nz) / (2.0 * n2)
    oz = bz + (gx * ny - gy * nx) / (2.0 * n2)
    r = math.sqrt((bx - ox) ** 2 + (by - oy) ** 2 + (bz - oz) ** 2)
    nn = math.sqrt(n2)
    mx, my, mz = nx / nn, ny / nn, nz / nn
    vx, vy, vz = p0 - ox, p1 - oy, p2 - oz
    vn = vx * mx + vy * my + vz * mz
    vx, vy, vz = vx - vn * mx, vy - vn * my, vz - vn * mz
    rho = math.sqrt(vx * vx + vy * vy + vz * vz)
    if not rho > 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    vx, vy, vz = vx / rho, vy / rho, vz / rho
    tx, ty, tz = my * vz - mz * vy, mz * vx - mx * vz, mx * vy - my * vx
    if tx * dx + ty * dy + tz * dz < 0.0:
        tx, ty, tz = -tx, -ty, -tz
    return True, ox + r * vx, oy + r * vy, oz + r * vz, tx, ty, tz


@callee
def est_two_circle(kind, s0, data, p0, p1, p2, s, hist):
    """000 "free curve contour error estimation": two circles through interpolation points.

    ``R_eps``, the interpolation point nearest P, is found by tracing back from the command
    point R while the distance to P decreases (000's stop condition, lost in extraction, is
    reconstructed as ``|P - R_{k-1}| >= |P - R_k|``). The trace starts at the tangential lag
    measured in interpolation steps (see :func:`lag_steps`) instead of at R itself: the same
    point when the distance is unimodal along the history, in a few evaluations instead of
    one per tick of lag (:func:`nearest_quad`). Circle 1 passes through ``R_eps+1, R_eps,
    R_eps-1``, circle 2 through ``R_eps, R_eps-1, R_eps-2`` (eqs. 4-7: centre and radius from
    the three points, written here as the circumcentre); the distance vector from P to
    circle i is ``(r_i - |P - O_i|) (P - O_i)/|P - O_i|`` (eq. 8 and the next, reconstructed),
    and the two vectors are averaged (reconstructed: "the two contour error vectors" are
    combined; the mean is the symmetric choice). Three collinear points give their line
    (exact on straight paths). Generalised to 3-D by taking each circle in its own plane.

    Breaks down at corners: circles through points on both sides of a vertex are tiny, and
    with a lag past the corner the trace can stop at the other leg's local minimum. Falls
    back to the exact search when the minimum lies beyond the 128-tick buffer, when points
    coincide (reference at rest), and when the foot is implausible (see module doc).
    """
    j0, e2 = lag_steps(kind, s0, data, hist, s, p0, p1, p2)
    ok, ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz = nearest_quad(
        kind, s0, data, hist, s, p0, p1, p2, j0)
    if not ok:
        return FAIL
    f1 = circle_foot(ax, ay, az, bx, by, bz, cx, cy, cz, p0, p1, p2)
    f2 = circle_foot(bx, by, bz, cx, cy, cz, dx, dy, dz, p0, p1, p2)
    if not (f1[0] and f2[0]):
        return FAIL
    t1 = math.sqrt(f1[4] ** 2 + f1[5] ** 2 + f1[6] ** 2)
    t2 = math.sqrt(f2[4] ** 2 + f2[5] ** 2 + f2[6] ** 2)
    return (True, 0.5 * (f1[1] + f2[1]), 0.5 * (f1[2] + f2[2]), 0.5 * (f1[3] + f2[3]),
            f1[4] / t1 + f2[4] / t2, f1[5] / t1 + f2[5] / t2, f1[6] / t1 + f2[6] / t2, e2)


@callee
def window_scan(kind, s0, data, hist, s, p0, p1, p2, lo, hi):
    """Nearest interpolation point in ``[lo, hi]`` with its two neighbours, in one pass.

    Returns ``(j, B, dn, N, do, O)``: index and point of the nearest, then the squared
    distance and point of its newer (j - 1) and older (j + 1) neighbour (inf when outside
    the window).
    """
    inf = math.inf
    j = lo
    bx, by, bz = ref_point(kind, s0, data, hist, s, lo)
    db = (bx - p0) ** 2 + (by - p1) ** 2 + (bz - p2) ** 2
    px, py, pz, dp = bx, by, bz, db  # previous point of the scan
    nx, ny, nz, dn = 0.0, 0.0, 0.0, inf
    ox, oy, oz, do = 0.0, 0.0, 0.0, inf
    for k in range(lo + 1, hi + 1):
        x, y, z = ref_point(kind, s0, data, hist, s, k)
        d = (x - p0) ** 2 + (y - p1) ** 2 + (z - p2) ** 2
        if d < db:
            j, bx, by, bz, db = k, x, y, z, d
            nx, ny, nz, dn = px, py, pz, dp
            do = inf
        elif k == j + 1:
            ox, oy, oz, do = x, y, z, d
        px, py, pz, dp = x, y, z, d
    return j, bx, by, bz, dn, nx, ny, nz, do, ox, oy, oz


@callee
def est_window(half0, kind, s0, data, p0, p1, p2, s, hist):
    """004 section 2.2: variable-size window; the two reference points closest to the tool.

    004 uses the contour error model of its ref. [5] only in words: "the variable size window
    is used to find two closest points between previous reference points and the current
    tool position; with these two points the contour error follows from the geometrical
    relationship". Reconstructed: a window of interpolation points centred on the tangential
    lag in steps (:func:`lag_steps`), of half-width ``half0`` (default 1), is doubled until
    its nearest point is interior (the variable size); the two closest points are that
    point and the nearer of its neighbours, and the foot is the projection of the tool on
    the line through them. Breaks down at corners (the chord cuts the vertex; a lag past the corner
    can pick the other leg). Falls back to the exact search when the nearest point lies at
    an end of the 128-tick buffer, the two points coincide (reference at rest), or the foot
    is implausible (see module doc).
    """
    centre, e2 = lag_steps(kind, s0, data, hist, s, p0, p1, p2)
    half = half0
    while True:
        lo, hi = max(J_AHEAD, centre - half), min(J_OLDEST, centre + half)
        j, bx, by, bz, dn, nx, ny, nz, do, ox, oy, oz = window_scan(
            kind, s0, data, hist, s, p0, p1, p2, lo, hi)
        if (j > lo or lo == J_AHEAD) and (j < hi or hi == J_OLDEST):
            break
        half *= 2
    if j in (J_AHEAD, J_OLDEST):
        return FAIL
    if dn < do:  # chord from the older to the newer of the two points
        ax, ay, az, cx, cy, cz = nx, ny, nz, bx, by, bz
    else:
        ax, ay, az, cx, cy, cz = bx, by, bz, ox, oy, oz
    ux, uy, uz = ax - cx, ay - cy, az - cz
    if not ux * ux + uy * uy + uz * uz > _MIN_CHORD * _MIN_CHORD:
        return FAIL
    qx, qy, qz = line_foot(p0, p1, p2, cx, cy, cz, ux, uy, uz)
    return True, qx, qy, qz, ux, uy, uz, e2


@callee
def newton_step(p0, p1, p2, x, y, z, tx, ty, tz, kx, ky, kz):
    """Newton step on ``g(s) = (P - p) . P'`` (the foot is a root); ``g'`` kept >= |P'|^2/10."""
    ex, ey, ez = x - p0, y - p1, z - p2
    sp2 = tx * tx + ty * ty + tz * tz
    g = ex * tx + ey * ty + ez * tz
    gp = max(sp2 + ex * kx + ey * ky + ez * kz, 0.1 * sp2)
    return -g / gp


@callee
def circle_step(p0, p1, p2, x, y, z, tx, ty, tz, kx, ky, kz):
    """Step to the projection of p on the osculating circle at the current point."""
    sp = math.sqrt(tx * tx + ty * ty + tz * tz)
    ux, uy, uz = tx / sp, ty / sp, tz / sp
    kt = kx * ux + ky * uy + kz * uz
    nx, ny, nz = (kx - kt * ux) / (sp * sp), (ky - kt * uy) / (sp * sp), (kz - kt * uz) / (sp * sp)
    kappa = math.sqrt(nx * nx + ny * ny + nz * nz)
    vx, vy, vz = p0 - x, p1 - y, p2 - z
    a = vx * ux + vy * uy + vz * uz
    if kappa < 1e-12:
        return a / sp
    b = (vx * nx + vy * ny + vz * nz) / kappa
    return math.atan2(a * kappa, 1.0 - b * kappa) / (kappa * sp)


@callee
def certified(kind, s0, data, bound, p0, p1, p2, sig, s, pt, tol):
    """Foot and tangent at ``sig`` if it is the exact search's foot (to ``tol``); else FAIL.

    ``pt`` is :func:`~contour_gym.paths._geom.eval_path` at ``sig``, an iterate within about
    ``tol`` (m) of a root of ``g``. The exact search
    (:func:`contour_gym.contour._kernel.ground_truth`) takes the nearest point of the
    reference's branch (:mod:`contour_gym.paths._branch`); the branch is searched for a point
    nearer than ``|P(sig) - p| - tol``, which neither the root ``sig`` approximates nor any
    point within ``tol`` of as near can be (:func:`~contour_gym.paths._branch.branch_has_nearer`:
    usually a small window around the reference is certain to hold any such point).
    """
    x, y, z, tx, ty, tz, _, _, _ = pt
    d = math.sqrt((x - p0) ** 2 + (y - p1) ** 2 + (z - p2) ** 2)
    if not math.isfinite(d):
        return FAIL
    if branch_has_nearer(kind, s0, data, bound, p0, p1, p2, s, max(d - tol, 0.0) ** 2):
        return FAIL
    return True, x, y, z, tx, ty, tz, TRUSTED


@callee
def est_iterative(n_iter, method, tol, kind, s0, data, bound, p0, p1, p2, s):
    """Beyond the papers: real-time nearest-point iteration started at the reference.

    At most ``n_iter`` steps of Newton's method on ``g(s) = (P(s) - p) . P'(s) = 0``
    (``method`` 0) or of projection on the osculating circle (``method`` 1, exact in one step
    on an arc), kept inside the window ``s +- (4 |p - r| + 1e-9)``. Converged when a step is
    at most ``tol`` (m). The result is then certified as the nearest point of the reference's
    branch to ``tol`` (:func:`certified`), so it is the exact search's answer. Falls back to
    the exact search when it has not converged or cannot be certified: the iterate held at
    the window's or the path's end short of the foot, a local maximum, the other side's
    local foot at a corner, or another branch of the path nearer the tool.
    """
    total = s0[s0.shape[0] - 1]
    rx, ry, rz, _, _, _, _, _, _ = eval_path(kind, s0, data, s)
    w = 4.0 * math.sqrt((p0 - rx) ** 2 + (p1 - ry) ** 2 + (p2 - rz) ** 2) + 1e-9
    lo, hi = max(s - w, 0.0), min(s + w, total)
    sig = min(max(s, lo), hi)
    for _ in range(n_iter):
        pt = eval_path(kind, s0, data, sig)
        x, y, z, tx, ty, tz, kx, ky, kz = pt
        if method == 0:
            step = newton_step(p0, p1, p2, x, y, z, tx, ty, tz, kx, ky, kz)
        else:
            step = circle_step(p0, p1, p2, x, y, z, tx, ty, tz, kx, ky, kz)
        if abs(step) <= tol:  # the foot is within tol of sig: keep the evaluated point
            return certified(kind, s0, data, bound, p0, p1, p2, sig, s, pt, tol)
        sig = min(max(sig + step, lo), hi)
    return FAIL


# ---------------------------------------------------------------------------- registration
# Every estimator as a ContourEstimator with the uniform foot signature
# foot(p, kind, s0, data, bound, p0, p1, p2, s, hist) (contour_gym.contour.base). The adapters
# are called, not inlined: each compiles once and every loop kernel that uses it shares it.

DEFAULT_MAX_TURN = 1.0  # rad: kappa |e| beyond which linearisations at the reference give up
_MAX_TURN = Param(DEFAULT_MAX_TURN, positive, "fall back when kappa |e| > max_turn, rad")


def _lines_and_arcs(path):
    table = path.table
    ok = (table.kind == LINE) | ((table.kind == HELIX) & (table.data[:, 14] == 0.0))
    if not bool(ok.all()):
        raise ValueError(f"estimator 'exact' needs a path made of lines and arcs; {path.name!r} "
                         "has free-form or helix segments (use 'iterative' or 'ground_truth')")


@callee
def foot_exact(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_exact`."""
    return est_exact(kind, s0, data, p0, p1, p2, s)


@callee
def foot_two_circle(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_two_circle`."""
    return est_two_circle(kind, s0, data, p0, p1, p2, s, hist)


TANGENT = Schema("tangent", max_turn=_MAX_TURN)
_TC = TANGENT.col


@callee
def foot_tangent(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_tangent`."""
    return est_tangent(p[_TC.max_turn], kind, s0, data, p0, p1, p2, s)


FRENET = Schema("frenet", order=Param(2, int_in(1, 2), "Taylor order"), max_turn=_MAX_TURN)
_FC = FRENET.col


@callee
def foot_frenet(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_frenet`."""
    c = _FC
    return est_frenet(int(p[c.order]), p[c.max_turn], kind, s0, data, p0, p1, p2, s)


ANGLE = Schema("angle", lag=Param(1, int_in(1, N_HIST), "ticks back to D'"), max_turn=_MAX_TURN)
_AC = ANGLE.col


@callee
def foot_angle(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_angle`."""
    c = _AC
    return est_angle(int(p[c.lag]), p[c.max_turn], kind, s0, data, p0, p1, p2, s, hist)


WINDOW = Schema("window", half_width=Param(1, int_in(1, N_HIST), "starting half-width"))
_WC = WINDOW.col


@callee
def foot_window(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_window`."""
    return est_window(int(p[_WC.half_width]), kind, s0, data, p0, p1, p2, s, hist)


ITERATIVE = Schema(
    "iterative",
    n_iter=Param(4, int_in(1, 50), "step budget"),
    method=Param(1, one_of({"newton": 0, "circle": 1}), "newton or circle"),
    tol=Param(1e-9, positive, "convergence step, m"),
)
_IC = ITERATIVE.col


@callee
def foot_iterative(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Adapter of :func:`est_iterative`."""
    c = _IC
    return est_iterative(
        int(p[c.n_iter]), int(p[c.method]), p[c.tol], kind, s0, data, bound, p0, p1, p2, s
    )


for _est in (
    ContourEstimator("ground_truth", Schema("ground_truth"),
                     doc="exact nearest point on the branch the tool is on"),
    ContourEstimator("exact", Schema("exact"), foot_exact, path_check=_lines_and_arcs,
                     doc="000 eqs. 1-3: distance to the reference's line or arc"),
    ContourEstimator("two_circle", Schema("two_circle"), foot_two_circle, needs_history=True,
                     doc="000: two circles through interpolation points near the tool"),
    ContourEstimator("tangent", TANGENT, foot_tangent,
                     doc="001 (Yeh & Hsu): foot on the tangent line at the reference"),
    ContourEstimator("frenet", FRENET, foot_frenet,
                     doc="002 eqs. 19-22: Frenet frame, delay time, Taylor expansion"),
    ContourEstimator("angle", ANGLE, foot_angle, needs_history=True,
                     doc="003 eqs. 16-21: line through previous and current command"),
    ContourEstimator("window", WINDOW, foot_window, needs_history=True,
                     doc="004 sec. 2.2: variable window, two closest reference points"),
    ContourEstimator("iterative", ITERATIVE, foot_iterative,
                     doc="Newton / osculating-circle iteration from the reference"),
):
    register_estimator(_est)
