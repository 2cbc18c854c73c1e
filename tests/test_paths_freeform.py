"""Free-form curves: tables against direct B-spline/NURBS evaluation, arc length, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial import legendre
from scipy.interpolate import BSpline

import contour_gym.paths as cgp

_GX, _GW = legendre.leggauss(30)


def _arc_length_at(deriv, u):
    """Independent arc length s(u) of a curve with derivative deriv(u) -> (N, dim)."""
    s = np.zeros(u.shape[0])
    for k in range(1, u.shape[0]):
        a, b = u[k - 1], u[k]
        x = 0.5 * (b - a) * _GX + 0.5 * (a + b)
        s[k] = s[k - 1] + 0.5 * (b - a) * np.sum(_GW * np.linalg.norm(deriv(x), axis=1))
    return s


def _nurbs_eval(ctrl, w, knots, deg):
    h = BSpline(knots, np.c_[ctrl * w[:, None], w], deg)
    dh = h.derivative()

    def value(u):
        v = h(u)
        return v[:, :-1] / v[:, -1:]

    def deriv(u):
        v, dv = h(u), dh(u)
        return (dv[:, :-1] - dv[:, -1:] * v[:, :-1] / v[:, -1:]) / v[:, -1:]

    return value, deriv


def _random_curve(seed, n, dim, deg):
    rng = np.random.default_rng(seed)
    ctrl = rng.uniform(-0.05, 0.05, (n, dim))
    m = n - deg - 1
    inner = (np.arange(1, m + 1) + rng.uniform(-0.3, 0.3, m)) / (m + 1)  # irregular, not tiny
    knots = np.r_[[0.0] * (deg + 1), inner, [1.0] * (deg + 1)]
    return ctrl, knots, rng


@pytest.mark.parametrize(("seed", "dim", "deg"), [(0, 2, 3), (1, 3, 3), (2, 2, 5), (3, 2, 2)])
def test_bspline_table_matches_scipy(seed, dim, deg):
    ctrl, knots, _ = _random_curve(seed, 9, dim, deg)
    path = cgp.bspline(ctrl, knots, deg)
    spl = BSpline(knots, ctrl, deg)
    u = np.unique(np.r_[np.linspace(0, 1, 3001), knots])
    s = _arc_length_at(spl.derivative(), u)
    assert path.length == pytest.approx(s[-1], abs=1e-11)
    err = np.linalg.norm(path.point(s) - spl(u), axis=1)
    assert err.max() < 1e-10


@pytest.mark.parametrize(("seed", "dim"), [(4, 2), (5, 3)])
def test_nurbs_table_matches_homogeneous_evaluation(seed, dim):
    ctrl, knots, rng = _random_curve(seed, 10, dim, 3)
    w = rng.uniform(0.3, 3.0, 10)
    path = cgp.nurbs(ctrl, w, knots, 3)
    value, deriv = _nurbs_eval(ctrl, w, knots, 3)
    u = np.unique(np.r_[np.linspace(0, 1, 3001), knots])
    s = _arc_length_at(deriv, u)
    err = np.linalg.norm(path.point(s) - value(u), axis=1)
    assert err.max() < 1e-10


def test_library_nurbs_tables_match_their_definition():
    from contour_gym.paths import _library as lib

    path = lib.trident()
    pts = np.array([(0, 50), (0, 10), (5, 0), (15, 0), (20, 10), (22, 60), (28, 60), (30, 10),
                    (35, 0), (45, 0), (50, 10), (50, 50)], dtype=float) * 1e-3
    w = np.array([1.0, 1.0, 2.0, 1.0, 0.6, 1.5, 1.5, 0.6, 1.0, 2.0, 1.0, 1.0])
    knots = np.r_[[0.0] * 4, [0.08, 0.2, 0.3, 0.45, 0.55, 0.7, 0.8, 0.92], [1.0] * 4]
    value, deriv = _nurbs_eval(pts, w, knots, 3)
    u = np.unique(np.r_[np.linspace(0, 1, 4001), knots])
    s = _arc_length_at(deriv, u)
    assert np.linalg.norm(path.point(s) - value(u), axis=1).max() < 1e-10


@pytest.mark.parametrize("name", ["three_leaf", "infinity", "trident", "bspline_complex"])
def test_unit_speed_along_free_form_paths(name):
    path = cgp.load(name)
    s = np.linspace(0, path.length, 200001)
    speed = np.linalg.norm(path.evaluate(s)[1], axis=1)
    assert np.max(np.abs(speed - 1.0)) < 1e-8


def test_parametric_matches_the_function():
    a, b = 0.04, 0.015

    def ellipse(t):
        return np.stack([a * np.cos(t), b * np.sin(t), 0.01 * t], axis=1)

    path = cgp.parametric(ellipse, 0.0, 5.0)
    assert path.dim == 3
    t = np.linspace(0, 5, 2001)
    s = _arc_length_at(lambda x: np.stack([-a * np.sin(x), b * np.cos(x),
                                           np.full_like(x, 0.01)], 1), t)
    assert np.linalg.norm(path.point(s) - ellipse(t), axis=1).max() < 1e-10


def test_parametric_circle_has_exact_length():
    path = cgp.parametric(lambda t: 0.02 * np.stack([np.cos(t), np.sin(t)], 1), 0.0, 2 * np.pi)
    assert path.length == pytest.approx(2 * math.pi * 0.02, abs=1e-12)
    assert path.closed


def test_corners_at_tangent_breaking_knots():
    ctrl = np.array([[0, 0], [0.01, 0], [0.02, 0], [0.02, 0.01], [0.02, 0.02], [0.03, 0.02]])
    knots = np.array([0, 0, 0, 1, 1, 2, 2, 2], dtype=float)  # multiplicity 2 = degree at u = 1
    path = cgp.bspline(ctrl[[0, 1, 2, 3, 4]], knots, 2)
    assert path.corners.size == 1
    np.testing.assert_allclose(path.point(path.corners[0]), [0.02, 0.0], atol=1e-15)
    lin = cgp.bspline(ctrl, np.r_[0, 0, np.arange(1, 5), 5, 5], 1)
    poly = cgp.polyline(ctrl)
    assert lin.length == pytest.approx(poly.length, abs=1e-15)
    np.testing.assert_allclose(lin.corners, poly.corners, atol=1e-15)
    smooth = cgp.bspline(ctrl, np.r_[[0] * 4, 1, 2, [3] * 4], 3)
    assert smooth.corners.size == 0


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: cgp.bspline(np.zeros((3, 2)), np.r_[0, 0, 0, 0, 1, 1, 1], 3), "at least 4"),
        (lambda: cgp.bspline(np.eye(4, 2), np.r_[0, 0, 0, 0, 1, 1, 1, 1], 0), "degree"),
        (lambda: cgp.bspline(np.eye(4, 2), np.r_[0, 0, 0, 0, 1, 1, 1, 1], 2.5), "degree"),
        (lambda: cgp.bspline(np.eye(4, 2), np.r_[0, 0, 0, 0, 1, 1, 1], 3), "knots must have"),
        (lambda: cgp.bspline(np.eye(4, 2), np.r_[0, 0, 0, 2, 1, 2, 2], 2), "non-decreasing"),
        (lambda: cgp.bspline(np.eye(4, 2), np.r_[0, 0, 0, 0, 0, 0, 0, 0], 3), "empty domain"),
        (lambda: cgp.bspline(np.full((4, 2), np.nan), np.r_[0, 0, 0, 0, 1, 1, 1, 1], 3), "finite"),
        (lambda: cgp.bspline(np.zeros((4, 2)), np.r_[0, 0, 0, 0, 1, 1, 1, 1], 3), "stationary"),
        (lambda: cgp.bspline(np.eye(4, 4), np.r_[0, 0, 0, 0, 1, 1, 1, 1], 3), r"\(N, 2\)"),
        (lambda: cgp.nurbs(np.eye(4, 2), [1, 1, 0, 1], np.r_[0, 0, 0, 0, 1, 1, 1, 1], 3),
         r"weights\[2\]"),
        (lambda: cgp.nurbs(np.eye(4, 2), [1, 1, -2, 1], np.r_[0, 0, 0, 0, 1, 1, 1, 1], 3),
         "weights must be > 0"),
        (lambda: cgp.nurbs(np.eye(4, 2), [1, 1, 1], np.r_[0, 0, 0, 0, 1, 1, 1, 1], 3),
         "weights must have shape"),
        (lambda: cgp.parametric(lambda t: np.stack([t, t], 1), 1.0, 1.0), "t_end must be >"),
        (lambda: cgp.parametric(lambda t: t, 0.0, 1.0), "fn must map"),
        (lambda: cgp.parametric(lambda t: np.stack([np.log(t), t], 1), 0.0, 1.0), "finite|smooth"),
        (lambda: cgp.parametric(lambda t: np.stack([t**3, t**2], 1), -1.0, 1.0), "stationary"),
        (lambda: cgp.parametric(lambda t: np.stack([t, np.abs(t - 0.3)], 1), 0.0, 1.0),
         "not smooth near t = 0.3|not smooth there"),
        (lambda: cgp.parametric(5, 0.0, 1.0), "callable"),
    ],
)
def test_free_form_bad_inputs(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_discontinuous_bspline_is_rejected():
    ctrl = np.array([[0, 0], [1, 0], [2, 0], [5, 5], [6, 5], [7, 5]], dtype=float)
    knots = np.r_[[0] * 3, 1, 1, 1, [2] * 3]  # multiplicity 3 = degree + 1: may jump
    with pytest.raises(ValueError, match="discontinuous at knot"):
        cgp.bspline(ctrl, knots, 2)


def test_nearly_singular_curve_is_rejected_quickly():
    ctrl = np.array([[0, 0], [0.05, 0.0], [0.0, 1e-9], [0.05, 0.01]])
    with pytest.raises(ValueError, match="turns too sharply"):
        cgp.bspline(ctrl, np.r_[0, 0, 0, 0.5, 1, 1, 1], 2)


def test_bspline_stationary_point_inside_is_rejected():
    ctrl = np.array([[0, 0], [0.01, 0], [0.01, 0], [0.01, 0], [0.02, 0.01]])
    with pytest.raises(ValueError, match="stationary|cannot fit"):
        cgp.bspline(ctrl, np.r_[[0] * 4, 0.5, [1] * 4], 3)


@pytest.mark.parametrize("dim", [1, 2, 3])
def test_the_compiled_chebyshev_series_equals_numpys(dim: int) -> None:
    # the fitting's compiled Clenshaw recurrence against numpy's chebval, piece by piece
    from numpy.polynomial import chebyshev

    from contour_gym.paths._batch import chebyshev_many

    rng = np.random.default_rng(dim)
    coef = rng.normal(size=(4, 25, dim))
    piece = rng.integers(0, 4, 200)
    x = rng.uniform(-1.0, 1.0, 200)
    out = np.empty((200, dim))
    chebyshev_many(coef, piece, x, out)
    expected = np.array([chebyshev.chebval(x[k], coef[piece[k]]) for k in range(200)])
    np.testing.assert_allclose(out, expected, rtol=1e-12, atol=1e-12)


def test_a_series_of_more_coordinates_than_the_kernel_evaluates_is_refused() -> None:
    from contour_gym.paths._freeform import _clenshaw

    with pytest.raises(ValueError, match="at most 3 coordinates, got 4"):
        _clenshaw(np.zeros((1, 3, 4)), np.zeros(2, np.int64), np.zeros(2))
