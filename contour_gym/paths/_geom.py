"""Compiled geometry engine: evaluation and exact nearest-point search on a :class:`PathTable`.

Every function takes the table arrays (``kind``, ``s0``, ``data``, ``bound``) as arguments, so the
batched loop kernel can call them from its own ``@numba.njit`` code. The hot functions
(:func:`find_segment`, :func:`eval_path`, :func:`nearest_window`, :func:`side_2d`) take and
return scalars and never allocate; the branch searches built on them are
:mod:`contour_gym.paths._branch`.

Table layout (one row per segment, local parameter ``t`` in ``[0, s0[i+1] - s0[i]]``):

* ``LINE`` (0): ``data[0:3]`` start, ``data[3:6]`` unit direction; ``P(t) = start + t dir``.
* ``HELIX`` (1): ``data[0:3]`` centre ``c``, ``data[3:6]`` unit ``e1`` (centre to start),
  ``data[6:9]`` unit ``e2``, ``data[9:12]`` axis ``a = e1 x e2``, ``data[12]`` radius ``R``,
  ``data[13]`` ``dphi/ds`` (signed, + = counter-clockwise about ``a``), ``data[14]`` axial
  rise per unit arc length; ``P(t) = c + R (cos(phi) e1 + sin(phi) e2) + data[14] t a`` with
  ``phi = data[13] t``. A plain arc has ``data[14] == 0``.
* ``POLY5`` (2): ``P(t) = sum_j c_j t^j`` with ``c_j = data[3j:3j+3]``, ``j = 0..5``.

2-D paths are stored with ``z = 0`` everywhere; callers pass ``pz = 0``.

Nearest point on one segment, with ``g(t) = (P - p).P'`` (half the derivative of the squared
distance) and ``g'(t) = |P'|^2 + (P - p).P''``:

* lines and plain arcs: closed form (projection; polar angle of p, else the nearer end);
* helices: g' changes sign only at known angles (see :func:`_nearest_helix`), so the segment is
  cut there into pieces where g is monotone, each holding at most one minimum;
* POLY5 spans: a sweep steps from each point u by ``|g'(u)| / G2`` with ``G2`` a bound on
  ``|g''|`` over the span, so g' keeps its sign on each step and g has at most one root there.
  Steps never go below ``2 _RMIN``; they get that small only next to a focal point (p near a
  centre of curvature), where the distance is flat and the search is slow (tens of us) but
  still returns the minimum distance.

On every monotone piece a root of g where it goes from - to + is found by Newton's method
safeguarded by bisection; the piece ends are candidates too, so several local minima inside one
segment are all compared.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contour_gym._callee import callee

LINE = 0
HELIX = 1
POLY5 = 2
NCOL = 18

CLOSED_TOL = 1e-9  # start and end closer than this (m): the path is closed
CORNER_TOL = 1e-8  # unit tangents differing by more than this: a corner
_RMIN = 2.5e-10  # smallest half-width of a search sub-interval, m
_NEWTON_TOL = 1e-14  # Newton step size at which the foot point is final, m
_BOUND_SAMPLES = 32  # sub-intervals per segment when building bounding spheres


@callee(forceinline=True)
def find_segment(s0, s):
    """Index of the segment containing arc length ``s`` (binary search, clamped to [0, n-1]).

    At a segment boundary the segment that starts there is returned. Typed once and inlined by
    LLVM (``forceinline``), as :func:`eval_path`.
    """
    n = s0.shape[0] - 1
    if not s > s0[0]:
        return 0
    if s >= s0[n - 1]:
        return n - 1
    lo = 0
    hi = n - 1
    while lo < hi:
        mid = (lo + hi + 1) >> 1
        if s0[mid] <= s:
            lo = mid
        else:
            hi = mid - 1
    return lo


@numba.njit(cache=True, inline="always")
def _poly_axis(data, i, j, t):
    """Value, first and second derivative of coordinate ``j`` of a POLY5 row at ``t``."""
    c1 = data[i, 3 + j]
    c2 = data[i, 6 + j]
    c3 = data[i, 9 + j]
    c4 = data[i, 12 + j]
    c5 = data[i, 15 + j]
    p = data[i, j] + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * c5))))
    d1 = c1 + t * (2.0 * c2 + t * (3.0 * c3 + t * (4.0 * c4 + t * 5.0 * c5)))
    d2 = 2.0 * c2 + t * (6.0 * c3 + t * (12.0 * c4 + t * 20.0 * c5))
    return p, d1, d2


@callee(forceinline=True)
def eval_segment(kind, data, i, t):
    """Point, dP/ds and d2P/ds2 of segment ``i`` at local arc length ``t`` (9 floats).

    Typed once and inlined by LLVM at every call site (``forceinline``), not by numba
    (:mod:`contour_gym.jit`).
    """
    k = kind[i]
    if k == LINE:
        ux = data[i, 3]
        uy = data[i, 4]
        uz = data[i, 5]
        return (data[i, 0] + t * ux, data[i, 1] + t * uy, data[i, 2] + t * uz,
                ux, uy, uz, 0.0, 0.0, 0.0)
    if k == HELIX:
        r = data[i, 12]
        w = data[i, 13]
        h = data[i, 14]
        phi = w * t
        c = math.cos(phi)
        s = math.sin(phi)
        ux = c * data[i, 3] + s * data[i, 6]
        uy = c * data[i, 4] + s * data[i, 7]
        uz = c * data[i, 5] + s * data[i, 8]
        vx = c * data[i, 6] - s * data[i, 3]
        vy = c * data[i, 7] - s * data[i, 4]
        vz = c * data[i, 8] - s * data[i, 5]
        ht = h * t
        rw = r * w
        rww = -rw * w
        return (data[i, 0] + r * ux + ht * data[i, 9],
                data[i, 1] + r * uy + ht * data[i, 10],
                data[i, 2] + r * uz + ht * data[i, 11],
                rw * vx + h * data[i, 9], rw * vy + h * data[i, 10], rw * vz + h * data[i, 11],
                rww * ux, rww * uy, rww * uz)
    px, tx, kx = _poly_axis(data, i, 0, t)
    py, ty, ky = _poly_axis(data, i, 1, t)
    pz, tz, kz = _poly_axis(data, i, 2, t)
    return px, py, pz, tx, ty, tz, kx, ky, kz


@numba.njit(forceinline=True)
def eval_path(kind, s0, data, s):
    """Point, dP/ds and d2P/ds2 at arc length ``s`` clamped to [0, L] (9 floats).

    At a corner the segment that starts there is used. NaN propagates. Typed once and inlined
    by LLVM at every call site (``forceinline``): the loop kernel calls it at many.
    """
    total = s0[s0.shape[0] - 1]
    if s < 0.0:
        s = 0.0
    elif s > total:
        s = total
    i = find_segment(s0, s)
    return eval_segment(kind, data, i, s - s0[i])


@numba.njit(cache=True, inline="always")
def _dist2_at(kind, data, i, t, px, py, pz):
    """Squared distance from p to segment ``i`` at ``t``, with g and g' (see module doc)."""
    x, y, z, tx, ty, tz, kx, ky, kz = eval_segment(kind, data, i, t)
    ex = x - px
    ey = y - py
    ez = z - pz
    g = ex * tx + ey * ty + ez * tz
    gp = tx * tx + ty * ty + tz * tz + ex * kx + ey * ky + ez * kz
    return ex * ex + ey * ey + ez * ez, g, gp


@numba.njit(cache=True, inline="always")
def _nearest_line(data, i, px, py, pz, ta, tb):
    ux = data[i, 3]
    uy = data[i, 4]
    uz = data[i, 5]
    t = (px - data[i, 0]) * ux + (py - data[i, 1]) * uy + (pz - data[i, 2]) * uz
    if t < ta:
        t = ta
    elif t > tb:
        t = tb
    ex = data[i, 0] + t * ux - px
    ey = data[i, 1] + t * uy - py
    ez = data[i, 2] + t * uz - pz
    return t, ex * ex + ey * ey + ez * ez


@numba.njit(cache=True, inline="always")
def _nearest_arc(kind, data, i, px, py, pz, ta, tb):
    """Closed form for a plain arc: the foot is at the polar angle of p, else an end."""
    qx = px - data[i, 0]
    qy = py - data[i, 1]
    qz = pz - data[i, 2]
    x = qx * data[i, 3] + qy * data[i, 4] + qz * data[i, 5]
    y = qx * data[i, 6] + qy * data[i, 7] + qz * data[i, 8]
    z = qx * data[i, 9] + qy * data[i, 10] + qz * data[i, 11]
    r = data[i, 12]
    w = data[i, 13]
    rho = math.sqrt(x * x + y * y)
    if rho == 0.0:
        return ta, r * r + z * z
    theta = math.atan2(y, x)
    fa = w * ta
    fb = w * tb
    lo = min(fa, fb)
    hi = max(fa, fb)
    two_pi = 2.0 * math.pi
    phi = theta + math.ceil((lo - theta) / two_pi) * two_pi
    if phi <= hi:
        t = phi / w
        t = min(max(t, ta), tb)
        d = rho - r
        return t, d * d + z * z
    da = _dist2_at(kind, data, i, ta, px, py, pz)[0]
    db = _dist2_at(kind, data, i, tb, px, py, pz)[0]
    if db < da:
        return tb, db
    return ta, da


# inlined by numba: called with constant columns, it would compile once per column
@numba.njit(cache=True, inline="always")
def _norm3(data, i, j):
    x = data[i, j]
    y = data[i, j + 1]
    z = data[i, j + 2]
    return math.sqrt(x * x + y * y + z * z)


@callee
def _g2_bound(data, i, seg_len, dmax):
    """Upper bound of |g''| = |3 P'.P'' + (P - p).P'''| over a POLY5 span, |P - p| <= dmax."""
    n1 = _norm3(data, i, 3)
    n2 = _norm3(data, i, 6)
    n3 = _norm3(data, i, 9)
    n4 = _norm3(data, i, 12)
    n5 = _norm3(data, i, 15)
    el = seg_len
    v = n1 + el * (2.0 * n2 + el * (3.0 * n3 + el * (4.0 * n4 + el * 5.0 * n5)))
    a = 2.0 * n2 + el * (6.0 * n3 + el * (12.0 * n4 + el * 20.0 * n5))
    j = 6.0 * n3 + el * (24.0 * n4 + el * 60.0 * n5)
    return 3.0 * v * a + dmax * j


@numba.njit(cache=True, inline="always")
def _g_at(kind, data, i, px, py, pz, local, t):
    """Squared distance, g and g' at ``t``.

    On segment ``i``, or (``local`` = (r, w, h, x, y, z), ``r > 0``) on a helix in its local
    frame.
    """
    if local[0] > 0.0:
        return _helix_f(local[0], local[1], local[2], local[3], local[4], local[5], t)
    return _dist2_at(kind, data, i, t, px, py, pz)


@callee
def _root(kind, data, i, px, py, pz, local, lo, hi, glo, ghi):
    """Root of g in (lo, hi) with g(lo) < 0 < g(hi): Newton safeguarded by bisection.

    The one root finder of the nearest-point search (POLY5 sweeps and helices). Returns the
    parameter (within ``_NEWTON_TOL`` of the root) and its squared distance.
    """
    t = lo - glo * (hi - lo) / (ghi - glo)
    if not lo < t < hi:
        t = 0.5 * (lo + hi)
    for _ in range(100):
        _, g, gp = _g_at(kind, data, i, px, py, pz, local, t)
        if g < 0.0:
            lo = t
        elif g > 0.0:
            hi = t
        else:
            break
        tn = t - g / gp if gp > 0.0 else 0.5 * (lo + hi)
        if not lo < tn < hi:
            tn = 0.5 * (lo + hi)
        step = abs(tn - t)
        t = tn
        if step <= _NEWTON_TOL or hi - lo <= _NEWTON_TOL:
            break
    return t, _g_at(kind, data, i, px, py, pz, local, t)[0]


_NO_LOCAL = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@callee
def _nearest_sweep(kind, data, i, px, py, pz, ta, tb, g2max):
    """Exact nearest point on a POLY5 span over local [ta, tb] (see the module doc).

    From each sub-interval start u the sweep steps ``w = |g'(u)| / g2max``: then g' keeps the
    sign of g'(u) on [u, u + w] since ``|g''| <= g2max``, so g has at most one root there.
    """
    best_d2, gu, gpu = _dist2_at(kind, data, i, ta, px, py, pz)
    best_t = ta
    u = ta
    while u < tb:
        w = 0.999 * abs(gpu) / g2max if g2max > 0.0 else np.inf
        v = u + max(w, 2.0 * _RMIN)
        if v >= tb or tb - v < _RMIN:
            v = tb
        d2v, gv, gpv = _dist2_at(kind, data, i, v, px, py, pz)
        if d2v < best_d2:
            best_d2 = d2v
            best_t = v
        if gu < 0.0 < gv:
            t, d2 = _root(kind, data, i, px, py, pz, _NO_LOCAL, u, v, gu, gv)
            if d2 < best_d2:
                best_d2 = d2
                best_t = t
        u = v
        gu = gv
        gpu = gpv
    return best_t, best_d2


@callee
def _helix_local(data, i, px, py, pz):
    """Coordinates of p in the helix frame (e1, e2, a) about its centre."""
    qx = px - data[i, 0]
    qy = py - data[i, 1]
    qz = pz - data[i, 2]
    x = qx * data[i, 3] + qy * data[i, 4] + qz * data[i, 5]
    y = qx * data[i, 6] + qy * data[i, 7] + qz * data[i, 8]
    z = qx * data[i, 9] + qy * data[i, 10] + qz * data[i, 11]
    return x, y, z


@callee
def _helix_f(r, w, h, x, y, z, t):
    """Squared distance, g and g' at t for a helix point in local coordinates (x, y, z)."""
    phi = w * t
    c = math.cos(phi)
    s = math.sin(phi)
    ex = r * c - x
    ey = r * s - y
    ez = h * t - z
    g = r * w * (x * s - y * c) + h * ez
    gp = r * w * w * (x * c + y * s) + h * h
    return ex * ex + ey * ey + ez * ez, g, gp


@callee
def _nearest_helix(kind, data, i, px, py, pz, ta, tb):
    """Exact nearest point on a helix segment over local [ta, tb].

    With ``psi = w t - theta`` (theta the polar angle of p), ``g = R w rho sin(psi) + h (h t - z)``
    and ``g' = R w^2 rho cos(psi) + h^2``: g' changes sign only where ``cos(psi) = -k``,
    ``k = h^2 / (R rho w^2)``. Between those angles g is monotone, so each piece holds at most one
    local minimum, found by safeguarded Newton when g goes from - to +.
    """
    r = data[i, 12]
    w = data[i, 13]
    h = data[i, 14]
    x, y, z = _helix_local(data, i, px, py, pz)
    best_d2, ga, _ = _helix_f(r, w, h, x, y, z, ta)
    best_t = ta
    d2b, gb, _ = _helix_f(r, w, h, x, y, z, tb)
    if d2b < best_d2:
        best_d2 = d2b
        best_t = tb
    rho = math.sqrt(x * x + y * y)
    kk = h * h / (r * rho * w * w) if rho > 0.0 else 2.0
    if kk >= 1.0:  # g' >= 0 everywhere: one minimum at most
        if ga < 0.0 < gb:
            t, d2 = _root(kind, data, i, px, py, pz, (r, w, h, x, y, z), ta, tb, ga, gb)
            if d2 < best_d2:
                best_d2 = d2
                best_t = t
        return best_t, best_d2
    alpha = math.acos(-kk)
    theta = math.atan2(y, x)
    two_pi = 2.0 * math.pi
    pa = w * ta - theta
    pb = w * tb - theta
    lo = min(pa, pb)
    hi = max(pa, pb)
    cur = lo
    while cur < hi:
        nxt = hi
        for off in (alpha, -alpha):
            b = off + two_pi * math.ceil((cur - off) / two_pi)
            if b <= cur:
                b += two_pi
            nxt = min(nxt, b)
        t1 = min(max((cur + theta) / w, ta), tb)
        t2 = min(max((nxt + theta) / w, ta), tb)
        if t2 < t1:
            t1, t2 = t2, t1
        _, g1, _ = _helix_f(r, w, h, x, y, z, t1)
        _, g2, _ = _helix_f(r, w, h, x, y, z, t2)
        if g1 < 0.0 < g2:
            t, d2 = _root(kind, data, i, px, py, pz, (r, w, h, x, y, z), t1, t2, g1, g2)
            if d2 < best_d2:
                best_d2 = d2
                best_t = t
        cur = nxt
    return best_t, best_d2


@numba.njit(cache=True, inline="always")
def nearest_segment(kind, data, bound, i, seg_len, px, py, pz, ta, tb):
    """Nearest point of segment ``i`` restricted to local ``t`` in [ta, tb]: (t, dist2)."""
    k = kind[i]
    if k == LINE:
        return _nearest_line(data, i, px, py, pz, ta, tb)
    if k == HELIX:
        if data[i, 14] == 0.0:
            return _nearest_arc(kind, data, i, px, py, pz, ta, tb)
        return _nearest_helix(kind, data, i, px, py, pz, ta, tb)
    dx = px - bound[i, 0]
    dy = py - bound[i, 1]
    dz = pz - bound[i, 2]
    dmax = math.sqrt(dx * dx + dy * dy + dz * dz) + bound[i, 3]
    g2max = _g2_bound(data, i, seg_len, dmax)
    return _nearest_sweep(kind, data, i, px, py, pz, ta, tb, g2max)


@numba.njit(cache=True, inline="always")
def _lower_bound(bound, j, px, py, pz):
    dx = px - bound[j, 0]
    dy = py - bound[j, 1]
    dz = pz - bound[j, 2]
    return math.sqrt(dx * dx + dy * dy + dz * dz) - bound[j, 3]


# Squared distances within this (1 pm squared) are a tie: the point farthest along the path
# wins. A part that retraces a line (a retract, then the return over it; a plunge after a
# rapid down the same line) has two equally near points, and a machine moves forward.
TIE_D2 = 1e-24


@numba.njit(cache=True, inline="always")
def search_segment(kind, s0, data, bound, j, px, py, pz, s_lo, s_hi, best_s, best_d2):
    """Segment ``j``'s nearest point in the window ``[s_lo, s_hi]``, if it beats the best.

    Returns the better of ``(s, dist2)`` and ``(best_s, best_d2)``: nearer by more than
    ``TIE_D2``, or as near and farther along the path.
    """
    a = s0[j]
    b = s0[j + 1]
    seg_len = b - a
    ta = max(s_lo, a) - a
    tb = min(s_hi, b) - a
    if tb < ta:
        tb = ta
    t, d2 = nearest_segment(kind, data, bound, j, seg_len, px, py, pz, ta, tb)
    s = b if t >= seg_len else a + t
    s = min(max(s, s_lo), s_hi)
    if d2 < best_d2 - TIE_D2 or (d2 <= best_d2 + TIE_D2 and s > best_s):
        return s, d2
    return best_s, best_d2


@numba.njit(cache=True, inline="always")
def _visit(kind, s0, data, bound, j, px, py, pz, s_lo, s_hi, best_s, best_d2):
    """:func:`search_segment` unless segment ``j``'s bounding sphere rules it out."""
    lb = _lower_bound(bound, j, px, py, pz)
    if lb > 0.0 and lb * lb > best_d2 + TIE_D2:
        return best_s, best_d2
    return search_segment(kind, s0, data, bound, j, px, py, pz, s_lo, s_hi, best_s, best_d2)


@callee
def nearest_window(kind, s0, data, bound, px, py, pz, s_lo, s_hi):
    """Exact nearest point with arc length in [s_lo, s_hi] (clamped to [0, L]): (s_foot, dist2).

    The segment holding the window centre is searched first, then its neighbours outward;
    segments whose bounding sphere cannot beat the best distance so far are skipped. Ties
    (within ``TIE_D2``) keep the point farthest along the path.
    """
    n = kind.shape[0]
    total = s0[n]
    if s_lo > s_hi:
        s_lo, s_hi = s_hi, s_lo
    s_lo = min(max(s_lo, 0.0), total)
    s_hi = min(max(s_hi, 0.0), total)
    i_lo = find_segment(s0, s_lo)
    i_hi = find_segment(s0, s_hi)
    if i_hi > i_lo and s0[i_hi] >= s_hi:
        i_hi -= 1
    ic = min(max(find_segment(s0, 0.5 * (s_lo + s_hi)), i_lo), i_hi)
    best_s, best_d2 = s_lo, np.inf
    # visit ic, ic-1, ic+1, ic-2, ... from one call site (inlined once, not three times)
    for k in range(2 * max(ic - i_lo, i_hi - ic) + 1):
        j = ic - (k + 1) // 2 if k % 2 == 1 else ic + k // 2
        if i_lo <= j <= i_hi:
            best_s, best_d2 = _visit(
                kind, s0, data, bound, j, px, py, pz, s_lo, s_hi, best_s, best_d2
            )
    return best_s, best_d2


@numba.njit(cache=True, inline="always")
def _unit_xy(r):
    """The unit tangent's x and y from an :func:`eval_segment` result (0 where P' vanishes)."""
    norm = math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
    if norm == 0.0:
        return 0.0, 0.0
    return r[3] / norm, r[4] / norm


@numba.njit(cache=True, inline="always")
def unit_tangent(kind, data, i, t):
    """Unit tangent of segment ``i`` at local arc length ``t`` (zeros where P' vanishes)."""
    r = eval_segment(kind, data, i, t)
    norm = math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
    if norm == 0.0:
        return 0.0, 0.0, 0.0
    return r[3] / norm, r[4] / norm, r[5] / norm


@callee
def side_2d(kind, s0, data, closed, s, px, py):
    """Sign (+1 left of travel, -1 right) of a 2-D point whose foot point is at ``s``.

    Uses the sum of the unit tangents just before and just after ``s``, so at a corner the
    side is taken against the bisector; on a closed path the tangent wraps around at 0 and L.
    A point straight ahead of an open end (or exactly on the path) gets +1.
    """
    n = kind.shape[0]
    total = s0[n]
    s = min(max(s, 0.0), total)
    i = find_segment(s0, s)
    t = s - s0[i]
    r = eval_segment(kind, data, i, t)
    ax, ay = _unit_xy(r)
    # the tangent just before s, where s is a corner: one evaluation site, inlined once
    j, tj = -1, 0.0
    if t <= 0.0:
        if i > 0:
            j, tj = i - 1, s0[i] - s0[i - 1]
        elif closed:
            j, tj = n - 1, total - s0[n - 1]
    elif s >= total and closed:
        j, tj = 0, 0.0
    bx, by = ax, ay
    if j >= 0:
        bx, by = _unit_xy(eval_segment(kind, data, j, tj))
    cross = (ax + bx) * (py - r[1]) - (ay + by) * (px - r[0])
    return -1.0 if cross < 0.0 else 1.0
