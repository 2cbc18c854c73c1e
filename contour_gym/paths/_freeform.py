"""Free-form curves (parametric, B-spline, NURBS) compiled to quintic spans in arc length.

A curve ``C(u)`` is first given as pieces that are smooth inside (B-spline knot spans, or
adaptive Chebyshev interpolants of a user function). Each piece is cut adaptively into spans;
a span ``[u0, u1]`` becomes a quintic Hermite polynomial in local arc length ``t`` matching
point, dP/ds and d2P/ds2 at both ends. Arc length comes from 10-point Gauss-Legendre quadrature
on eight sub-intervals (checked against one rule over the whole span). A span is accepted when,
at seven interior parameters, the polynomial is within ``TOL_POS`` of the curve and its
derivative within ``TOL_TAN`` of the unit tangent; otherwise it is halved.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.polynomial import chebyshev as cheb
from numpy.polynomial import legendre
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array, finite
from contour_gym.paths._batch import chebyshev_many
from contour_gym.paths._geom import POLY5
from contour_gym.paths._path import Path
from contour_gym.paths._table import PathTable, eval_poly5_rows, make_table, poly5_rows

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Triple = tuple[FloatArray, FloatArray, FloatArray]

TOL_POS = 2e-11  # accepted span: position error at the checkpoints, m
TOL_TAN = 2e-9  # accepted span: error of dP/ds at the checkpoints
MAX_DEPTH = 50  # halvings of one piece before giving up
MIN_SPAN = 1e-8  # a span this short (m) that still fails: the curve is (nearly) singular
_N_SUB = 8
_FR = np.linspace(0.0, 1.0, _N_SUB + 1)
_GX, _GW = legendre.leggauss(10)
_GX = 0.5 * (_GX + 1.0)
_GW = 0.5 * _GW
_CHEB_DEG = 24
_CHEB_X = np.cos(np.pi * (2.0 * np.arange(_CHEB_DEG + 1) + 1.0) / (2.0 * (_CHEB_DEG + 1)))
_CHEB_INV = np.linalg.inv(cheb.chebvander(_CHEB_X, _CHEB_DEG))


class _Curve:
    """A curve given as pieces, smooth inside each, evaluated with exact one-sided limits."""

    def __init__(self, breaks: FloatArray, dim: int) -> None:
        self.breaks = breaks
        self.dim = dim

    def eval(self, piece: IntArray, u: FloatArray) -> Triple:
        """C, dC/du, d2C/du2 at ``u`` using piece ``piece`` (each (N, 3))."""
        raise NotImplementedError

    def velocity(self, piece: IntArray, u: FloatArray) -> FloatArray:
        """dC/du alone (N, 3): the same numbers as ``eval(piece, u)[1]``."""
        return self.eval(piece, u)[1]


class _PiecewisePoly(_Curve):
    """Polynomial pieces in local power basis; rational when the last column is a weight."""

    def __init__(self, breaks: FloatArray, coef: FloatArray, dim: int, rational: bool) -> None:
        super().__init__(breaks, dim)
        self.coef = coef  # (P, degree + 1, dim or dim + 1), Taylor coefficients at piece start
        self.rational = rational

    def eval(self, piece: IntArray, u: FloatArray) -> Triple:
        x = (u - self.breaks[piece])[:, None]
        c = self.coef
        deg = c.shape[1] - 1
        v = c[piece, deg]
        d1 = np.zeros_like(v)
        d2 = np.zeros_like(v)
        for j in range(deg - 1, -1, -1):
            d2 = d2 * x + 2.0 * d1
            d1 = d1 * x + v
            v = v * x + c[piece, j]
        if self.rational:
            w, w1, w2 = v[:, -1:], d1[:, -1:], d2[:, -1:]
            p = v[:, :-1] / w
            p1 = (d1[:, :-1] - w1 * p) / w
            p2 = (d2[:, :-1] - 2.0 * w1 * p1 - w2 * p) / w
            v, d1, d2 = p, p1, p2
        return _pad(v), _pad(d1), _pad(d2)


class _ChebPieces(_Curve):
    """Chebyshev interpolants of a user function on adaptive pieces."""

    def __init__(self, breaks: FloatArray, coef: FloatArray, dim: int) -> None:
        super().__init__(breaks, dim)
        self.coef = coef  # (P, deg + 1, dim)
        scale = 2.0 / np.diff(breaks)
        self.d1 = cheb.chebder(coef, axis=1) * scale[:, None, None]
        self.d2 = cheb.chebder(self.d1, axis=1) * scale[:, None, None]

    def eval(self, piece: IntArray, u: FloatArray) -> Triple:
        x = self._local(piece, u)
        return (_pad(_clenshaw(self.coef, piece, x)), _pad(_clenshaw(self.d1, piece, x)),
                _pad(_clenshaw(self.d2, piece, x)))

    def velocity(self, piece: IntArray, u: FloatArray) -> FloatArray:
        # one series of three: the arc-length quadrature needs the speed only
        return _pad(_clenshaw(self.d1, piece, self._local(piece, u)))

    def _local(self, piece: IntArray, u: FloatArray) -> FloatArray:
        # u in each piece's Chebyshev variable, in [-1, 1]
        a = self.breaks[piece]
        b = self.breaks[piece + 1]
        x: FloatArray = (2.0 * u - a - b) / (b - a)
        return x


class _Analytic(_Curve):
    """One smooth piece with closed-form derivatives."""

    def __init__(self, fn: Callable[[FloatArray], Triple], a: float, b: float, dim: int) -> None:
        super().__init__(np.array([a, b]), dim)
        self.fn = fn

    def eval(self, piece: IntArray, u: FloatArray) -> Triple:
        v, d1, d2 = self.fn(u)
        return _pad(v), _pad(d1), _pad(d2)


def _pad(v: FloatArray) -> FloatArray:
    if v.shape[1] == 3:
        return v
    out = np.zeros((v.shape[0], 3))
    out[:, : v.shape[1]] = v
    return out


def _clenshaw(coef: FloatArray, piece: IntArray, x: FloatArray) -> FloatArray:
    # the series coef[piece[k]] at x[k] (N,) -> (N, dim)
    if coef.shape[2] > 3:  # the kernel evaluates up to three coordinates
        raise ValueError(f"Chebyshev series of at most 3 coordinates, got {coef.shape[2]}")
    out = np.empty((piece.shape[0], coef.shape[2]))
    chebyshev_many(np.ascontiguousarray(coef), piece.astype(np.int64, copy=False),
                   np.ascontiguousarray(x), out)
    return out


# fitting -------------------------------------------------------------------------------------


def _unit_and_curvature(d1: FloatArray, d2: FloatArray) -> tuple[FloatArray, FloatArray]:
    speed = np.linalg.norm(d1, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):  # stationary points are caught later
        t = d1 / speed
        k = (d2 - np.sum(d2 * t, axis=-1, keepdims=True) * t) / speed**2
    return t, k


def _try_spans(curve: _Curve, piece: IntArray, ua: FloatArray, ub: FloatArray
               ) -> tuple[NDArray[np.bool_], FloatArray, FloatArray, FloatArray]:
    """Fit candidate spans; return (accepted mask, rows, lengths, minimum speed per span)."""
    k = ua.shape[0]
    width = ub - ua
    sub_w = width / _N_SUB
    nodes = (ua[:, None, None] + width[:, None, None] * _FR[None, :-1, None]
             + sub_w[:, None, None] * _GX[None, None, :])
    whole = ua[:, None] + width[:, None] * _GX[None, :]
    u_all = np.concatenate([nodes.reshape(k, -1), whole], axis=1)
    speed = np.linalg.norm(curve.velocity(np.repeat(piece, u_all.shape[1]), u_all.ravel()),
                           axis=1).reshape(k, -1)
    n_sub_nodes = _N_SUB * _GX.shape[0]
    sub_len = (speed[:, :n_sub_nodes].reshape(k, _N_SUB, -1) @ _GW) * sub_w[:, None]
    cum = np.cumsum(sub_len, axis=1)
    length = cum[:, -1]
    whole_len = (speed[:, n_sub_nodes:] @ _GW) * width
    quad_ok = np.abs(length - whole_len) <= 1e-12 * length
    ub_pts = ua[:, None] + width[:, None] * _FR[None, :]
    ub_pts[:, -1] = ub
    c, d1, d2 = curve.eval(np.repeat(piece, _N_SUB + 1), ub_pts.ravel())
    c = c.reshape(k, _N_SUB + 1, 3)
    t, kv = _unit_and_curvature(d1.reshape(k, _N_SUB + 1, 3), d2.reshape(k, _N_SUB + 1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        rows = poly5_rows(c[:, 0], t[:, 0], kv[:, 0], c[:, -1], t[:, -1], kv[:, -1], length)
        h, hd = eval_poly5_rows(rows, cum[:, :-1])
    pos_err = np.max(np.linalg.norm(h - c[:, 1:-1], axis=2), axis=1)
    tan_err = np.max(np.linalg.norm(hd - t[:, 1:-1], axis=2), axis=1)
    ok = quad_ok & (pos_err <= TOL_POS) & (tan_err <= TOL_TAN)
    vmin = np.minimum(speed.min(axis=1), np.linalg.norm(d1, axis=1).reshape(k, -1).min(axis=1))
    return ok, rows, length, vmin


def _fit(curve: _Curve, name: str) -> PathTable:
    """Cut the curve into accepted quintic spans and build the table."""
    piece = np.arange(curve.breaks.shape[0] - 1)
    ua = curve.breaks[:-1].copy()
    ub = curve.breaks[1:].copy()
    parts: list[tuple[FloatArray, FloatArray, FloatArray]] = []
    vscale = 0.0
    for _ in range(MAX_DEPTH):
        ok, rows, length, vmin = _try_spans(curve, piece, ua, ub)
        vscale = max(vscale, float(np.max(length / (ub - ua))))
        bad_speed = ~(vmin > 1e-9 * vscale)
        if np.any(bad_speed):
            where = float(ua[np.argmax(bad_speed)])
            raise ValueError(f"{name}: the curve has a stationary point (|dC/du| = 0) in the "
                             f"span starting at u = {where:.9g}")
        parts.append((ua[ok], rows[ok], length[ok]))
        if np.all(ok):
            break
        bad = ~ok
        tiny = bad & (length < MIN_SPAN)
        if np.any(tiny):
            where = float(ua[np.argmax(tiny)])
            raise ValueError(f"{name}: cannot fit the curve near u = {where:.9g}: it is not "
                             "smooth there or turns too sharply (nearly a stationary point)")
        mid = 0.5 * (ua[bad] + ub[bad])
        piece = np.repeat(piece[bad], 2)
        ua, ub = np.stack([ua[bad], mid], 1).ravel(), np.stack([mid, ub[bad]], 1).ravel()
    else:
        raise ValueError(f"{name}: span fitting did not converge near u = {float(ua[0]):.9g}")
    starts = np.concatenate([p[0] for p in parts])
    order = np.argsort(starts, kind="stable")
    rows_all = np.concatenate([p[1] for p in parts])[order]
    lengths = np.concatenate([p[2] for p in parts])[order]
    return make_table(np.full(lengths.shape[0], POLY5), lengths, rows_all, curve.dim)


def curve_path(curve: _Curve, name: str) -> Path:
    """Compile a curve to a path."""
    return Path(_fit(curve, name), name)


# B-splines and NURBS -------------------------------------------------------------------------


def _degree(value: Any) -> int:
    integral = isinstance(value, (int, np.integer)) or (
        isinstance(value, (float, np.floating)) and float(value).is_integer())
    if isinstance(value, bool) or not integral:
        raise ValueError(f"degree must be an integer >= 1, got {value!r}")
    deg = int(value)
    if deg < 1:
        raise ValueError(f"degree must be an integer >= 1, got {value!r}")
    return deg


def _check_spline(control_points: ArrayLike, knots: ArrayLike, degree: Any
                  ) -> tuple[FloatArray, FloatArray, int]:
    deg = _degree(degree)
    ctrl = as_finite_array(control_points, "control_points", ndim=2)
    if ctrl.shape[1] not in (2, 3):
        raise ValueError(f"control_points must have shape (N, 2) or (N, 3), got {ctrl.shape}")
    n = ctrl.shape[0]
    if n < deg + 1:
        raise ValueError(f"a degree-{deg} curve needs at least {deg + 1} control points, got {n}")
    kn = as_finite_array(knots, "knots", ndim=1)
    if kn.shape[0] != n + deg + 1:
        raise ValueError(f"knots must have n_ctrl + degree + 1 = {n + deg + 1} values, "
                         f"got {kn.shape[0]}")
    dec = np.nonzero(np.diff(kn) < 0.0)[0]
    if dec.size:
        i = int(dec[0])
        raise ValueError(f"knots must be non-decreasing: knots[{i + 1}] = {kn[i + 1]!r} < "
                         f"knots[{i}] = {kn[i]!r}")
    if not kn[deg] < kn[n]:
        raise ValueError(f"empty domain: knots[{deg}] = {kn[deg]!r} and knots[{n}] = {kn[n]!r}")
    inner = kn[deg + 1:n]
    values, counts = np.unique(inner, return_counts=True)
    if np.any(counts > deg + 1):
        bad = float(values[np.argmax(counts)])
        raise ValueError(f"knot {bad!r} has multiplicity {int(counts.max())} > degree + 1")
    return ctrl, kn, deg


def _spline_pieces(ctrl_h: FloatArray, kn: FloatArray, deg: int, dim: int, rational: bool,
                   name: str) -> _PiecewisePoly:
    from scipy.interpolate import BSpline  # here: its import took 0.19-0.23 s

    n = ctrl_h.shape[0]
    spl = BSpline(kn, ctrl_h, deg, extrapolate=False)
    breaks = np.unique(kn[deg:n + 1])
    starts = breaks[:-1]
    coef = np.stack([spl(starts, nu=j) / math.factorial(j) for j in range(deg + 1)], axis=1)
    curve = _PiecewisePoly(breaks, coef, dim, rational)
    if breaks.shape[0] > 2:
        idx = np.arange(breaks.shape[0] - 2)
        left = curve.eval(idx, breaks[1:-1])[0]
        right = curve.eval(idx + 1, breaks[1:-1])[0]
        gap = np.linalg.norm(left - right, axis=1)
        if np.any(gap > 1e-9):
            j = int(np.argmax(gap))
            raise ValueError(f"{name} is discontinuous at knot u = {breaks[j + 1]!r} "
                             f"(jump {gap[j]:.3g} m)")
    return curve


def bspline(control_points: ArrayLike, knots: ArrayLike, degree: int) -> Path:
    """A B-spline curve, reparameterised by arc length.

    Args:
        control_points: (n, 2) or (n, 3) control points, m; n >= degree + 1.
        knots: Full knot vector, non-decreasing, length ``n + degree + 1``; the curve is the
            part on ``[knots[degree], knots[n]]``.
        degree: Polynomial degree >= 1.

    Returns:
        The curve as POLY5 spans, within 1e-10 m of the exact curve. Knots where the tangent
        jumps (multiplicity >= degree) become corners.

    Raises:
        ValueError: on bad shapes, non-finite values, too few control points, degree < 1,
            decreasing knots, an empty domain, a discontinuity or a stationary point.
    """
    ctrl, kn, deg = _check_spline(control_points, knots, degree)
    curve = _spline_pieces(ctrl, kn, deg, ctrl.shape[1], False, "bspline")
    return curve_path(curve, "bspline")


def nurbs(control_points: ArrayLike, weights: ArrayLike, knots: ArrayLike, degree: int) -> Path:
    """A NURBS curve (B-spline in homogeneous coordinates), reparameterised by arc length.

    Args:
        control_points: (n, 2) or (n, 3) control points, m; n >= degree + 1.
        weights: (n,) weights > 0.
        knots: Full knot vector, non-decreasing, length ``n + degree + 1``; domain
            ``[knots[degree], knots[n]]``.
        degree: Polynomial degree >= 1.

    Returns:
        The curve as POLY5 spans, within 1e-10 m of the exact curve.

    Raises:
        ValueError: as :func:`bspline`, and for weights that are not finite and > 0.
    """
    ctrl, kn, deg = _check_spline(control_points, knots, degree)
    w = as_finite_array(weights, "weights", shape=(ctrl.shape[0],))
    if np.any(w <= 0.0):
        i = int(np.argmax(w <= 0.0))
        raise ValueError(f"weights must be > 0: weights[{i}] = {w[i]!r}")
    ctrl_h = np.concatenate([ctrl * w[:, None], w[:, None]], axis=1)
    curve = _spline_pieces(ctrl_h, kn, deg, ctrl.shape[1], True, "nurbs")
    return curve_path(curve, "nurbs")


# parametric ----------------------------------------------------------------------------------


def _call_fn(fn: Callable[[FloatArray], ArrayLike], t: FloatArray, dim: int | None
             ) -> FloatArray:
    out = np.asarray(fn(t), dtype=np.float64)
    want = (t.shape[0], dim) if dim is not None else None
    if out.ndim != 2 or out.shape[0] != t.shape[0] or out.shape[1] not in (2, 3) or (
            want is not None and out.shape != want):
        raise ValueError(f"fn must map an array of {t.shape[0]} t values to points of shape "
                         f"({t.shape[0]}, 2 or 3), got shape {out.shape}")
    if not np.all(np.isfinite(out)):
        bad = float(t[np.argmax(~np.all(np.isfinite(out), axis=1))])
        raise ValueError(f"fn returned a non-finite point at t = {bad!r}")
    return out


def _chebyshev_pieces(fn: Callable[[FloatArray], ArrayLike], a: float, b: float) -> _ChebPieces:
    """Adaptive Chebyshev interpolants of ``fn`` on [a, b], accurate to ~1e-14 relative."""
    edges = np.linspace(a, b, 9)
    lo, hi = edges[:-1], edges[1:]
    done: list[tuple[FloatArray, FloatArray, FloatArray]] = []
    dim: int | None = None
    tol = 0.0
    for _ in range(MAX_DEPTH):
        t = 0.5 * (lo + hi)[:, None] + 0.5 * (hi - lo)[:, None] * _CHEB_X[None, :]
        vals = _call_fn(fn, t.ravel(), dim)
        dim = vals.shape[1]
        vals = vals.reshape(t.shape[0], t.shape[1], dim)
        if tol == 0.0:
            tol = 2e-14 * max(float(np.max(np.abs(vals))), 1e-300)
        coef = np.einsum("jk,ikd->ijd", _CHEB_INV, vals)
        ok = np.max(np.abs(coef[:, -3:, :]), axis=(1, 2)) <= tol
        done.append((lo[ok], hi[ok], coef[ok]))
        if np.all(ok):
            break
        mid = 0.5 * (lo[~ok] + hi[~ok])
        lo, hi = np.stack([lo[~ok], mid], 1).ravel(), np.stack([mid, hi[~ok]], 1).ravel()
        if np.any(hi - lo <= 1e-12 * (abs(a) + abs(b))):
            raise ValueError(f"parametric: fn is not smooth near t = {float(lo[0]):.9g}; split "
                             "the path there and join the parts with composite()")
    else:
        raise ValueError("parametric: fn could not be resolved")
    los = np.concatenate([d[0] for d in done])
    order = np.argsort(los)
    his = np.concatenate([d[1] for d in done])[order]
    breaks = np.concatenate([los[order], his[-1:]])
    assert dim is not None
    return _ChebPieces(breaks, np.concatenate([d[2] for d in done])[order], dim)


def parametric(fn: Callable[[FloatArray], ArrayLike], t_start: float, t_end: float) -> Path:
    """A smooth curve ``t -> fn(t)``, reparameterised by arc length.

    ``fn`` is sampled (only inside [t_start, t_end]) and replaced by adaptive Chebyshev
    interpolants accurate to about 1e-14 of the coordinate size, whose exact derivatives feed
    the arc-length fit. ``fn`` must be smooth (analytic pieces); join non-smooth parts with
    :func:`composite`.

    Args:
        fn: Maps an array of N parameter values to points (N, 2) or (N, 3), m.
        t_start: Parameter at the start.
        t_end: Parameter at the end, > t_start.

    Returns:
        The curve as POLY5 spans, within 1e-10 m of ``fn``.

    Raises:
        ValueError: on a bad interval, a misshaped or non-finite result of ``fn``, a
            non-smooth ``fn`` or a stationary point.
    """
    if not callable(fn):
        raise ValueError(f"fn must be callable, got {type(fn).__name__}")
    a = finite(t_start, "t_start")
    b = finite(t_end, "t_end")
    if not a < b:
        raise ValueError(f"t_end must be > t_start, got t_start = {t_start!r}, t_end = {t_end!r}")
    return curve_path(_chebyshev_pieces(fn, a, b), "parametric")


def analytic_path(fn: Callable[[FloatArray], Triple], a: float, b: float, dim: int,
                  name: str) -> Path:
    """A path from a curve with closed-form derivatives ``fn(u) -> (C, C', C'')`` on [a, b]."""
    return curve_path(_Analytic(fn, a, b, dim), name)
