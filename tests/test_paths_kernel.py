"""The compiled geometry engine: exact formulas, njit callers, windows, helices, spans."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest

import contour_gym.paths as cgp
from contour_gym.paths import _branch as branch
from contour_gym.paths import _geom as geom


@numba.njit
def _eval_all(kind, s0, data, s):
    out = np.empty((s.shape[0], 9))
    for k in range(s.shape[0]):
        r = geom.eval_path(kind, s0, data, s[k])
        for j in range(9):
            out[k, j] = r[j]
    return out


@numba.njit
def _window_all(kind, s0, data, bound, pts, lo, hi):
    out = np.empty((pts.shape[0], 2))
    for k in range(pts.shape[0]):
        s, d2 = geom.nearest_window(kind, s0, data, bound, pts[k, 0], pts[k, 1], pts[k, 2],
                                 lo[k], hi[k])
        out[k, 0] = s
        out[k, 1] = d2
    return out


@numba.njit
def _foot_d2(kind, s0, data, s, p):
    # the distance as the loop takes it: from the evaluated foot point
    r = geom.eval_path(kind, s0, data, s)
    return (r[0] - p[0]) ** 2 + (r[1] - p[1]) ** 2 + (r[2] - p[2]) ** 2


@numba.njit
def _hint_all(kind, s0, data, bound, closed, pts, hint):
    out = np.empty((pts.shape[0], 3))
    for k in range(pts.shape[0]):
        s, _ = branch.branch_nearest(kind, s0, data, bound, pts[k, 0], pts[k, 1], pts[k, 2],
                                     hint[k], hint[k])
        out[k, 0] = s
        out[k, 1] = _foot_d2(kind, s0, data, s, pts[k])
        out[k, 2] = geom.side_2d(kind, s0, data, closed, s, pts[k, 0], pts[k, 1])
    return out


@numba.njit
def _global_all(kind, s0, data, bound, pts):
    out = np.empty((pts.shape[0], 2))
    for k in range(pts.shape[0]):
        s, _ = branch.nearest_global(kind, s0, data, bound, pts[k, 0], pts[k, 1], pts[k, 2])
        out[k, 0] = s
        out[k, 1] = _foot_d2(kind, s0, data, s, pts[k])
    return out


def _pad3(pts):
    out = np.zeros((pts.shape[0], 3))
    out[:, : pts.shape[1]] = pts
    return out


@pytest.mark.parametrize("name", ["circle_r20", "corner", "three_leaf", "helix", "infinity"])
def test_njit_callers_match_python_api(name):
    path = cgp.load(name)
    t = path.table
    rng = np.random.default_rng(1)
    s = rng.uniform(-0.01, path.length + 0.01, 500)
    raw = _eval_all(t.kind, t.s0, t.data, s)
    p, d1, d2 = path.evaluate(s)
    d = path.dim
    np.testing.assert_array_equal(raw[:, :d], p)
    np.testing.assert_array_equal(raw[:, 3:3 + d], d1)
    np.testing.assert_array_equal(raw[:, 6:6 + d], d2)
    pts = path.point(rng.uniform(0, path.length, 300)) + rng.normal(scale=1e-3, size=(300, d))
    hint = rng.uniform(0, path.length, 300)
    s_api, dist_api = path.nearest(pts, s_hint=hint)
    raw_h = _hint_all(t.kind, t.s0, t.data, t.bound, path.closed, _pad3(pts), hint)
    np.testing.assert_array_equal(raw_h[:, 0], s_api)
    signed = np.sqrt(raw_h[:, 1]) * (raw_h[:, 2] if d == 2 else 1.0)
    np.testing.assert_array_equal(signed, dist_api)
    s_g, dist_g = path.nearest(pts)
    raw_g = _global_all(t.kind, t.s0, t.data, t.bound, _pad3(pts))
    np.testing.assert_array_equal(raw_g[:, 0], s_g)
    np.testing.assert_array_equal(np.sqrt(raw_g[:, 1]), np.abs(dist_g))


def test_line_nearest_is_exact():
    a, b = np.array([0.1, -0.2]), np.array([0.4, 0.3])
    path = cgp.line(a, b)
    u = (b - a) / np.linalg.norm(b - a)
    n = np.array([-u[1], u[0]])
    rng = np.random.default_rng(2)
    along = rng.uniform(0, np.linalg.norm(b - a), 200)
    off = rng.uniform(-0.05, 0.05, 200)
    pts = a + along[:, None] * u + off[:, None] * n
    s, d = path.nearest(pts)
    np.testing.assert_allclose(s, along, atol=1e-12, rtol=0)
    np.testing.assert_allclose(d, off, atol=1e-12, rtol=0)  # left of travel is positive
    beyond = b + 0.01 * u + 0.02 * n
    s_end, d_end = path.nearest(beyond)
    assert s_end == path.length
    assert d_end == pytest.approx(math.hypot(0.01, 0.02), abs=1e-15)


def test_arc_nearest_is_exact():
    c, r = np.array([0.02, -0.01]), 0.03
    path = cgp.arc(c, r, 0.3, -2.0)  # clockwise arc
    rng = np.random.default_rng(3)
    phi = 0.3 - rng.uniform(0, 2.0, 200)
    rho = rng.uniform(0.001, 0.06, 200)
    pts = c + rho[:, None] * np.stack([np.cos(phi), np.sin(phi)], 1)
    s, d = path.nearest(pts)
    np.testing.assert_allclose(s, (0.3 - phi) * r, atol=1e-12, rtol=0)
    # clockwise travel: the centre side is to the right, so inside is negative
    np.testing.assert_allclose(d, rho - r, atol=1e-12, rtol=0)
    # outside the angular range: the nearer end point
    q = c + 0.05 * np.array([math.cos(0.5), math.sin(0.5)])
    s_q, d_q = path.nearest(q)
    assert s_q == 0.0
    assert abs(d_q) == pytest.approx(np.linalg.norm(q - path.point(0.0)), abs=1e-15)


def test_signed_distance_on_ccw_circle():
    path = cgp.circle(0.02, center=(0.01, 0.0))
    rng = np.random.default_rng(4)
    phi = rng.uniform(0, 2 * np.pi, 100)
    rho = rng.uniform(0.001, 0.04, 100)
    pts = np.array([0.01, 0.0]) + rho[:, None] * np.stack([np.cos(phi), np.sin(phi)], 1)
    _, d = path.nearest(pts)
    np.testing.assert_allclose(d, 0.02 - rho, atol=1e-12, rtol=0)  # inside (left) positive


def test_corner_sign_uses_the_bisector():
    path = cgp.load("corner")  # right turn at the apex
    apex = path.point(0.025)
    s, d = path.nearest(apex + np.array([0.0, 0.003]))  # outside the turn: left
    assert s == pytest.approx(0.025, abs=1e-15)
    assert d == pytest.approx(0.003, abs=1e-15)
    s, d = path.nearest(apex - np.array([0.0, 0.001]))  # inside the turn: right
    assert d == pytest.approx(-0.001 / math.sqrt(2), abs=1e-15)  # equidistant from both legs
    closed = cgp.polyline([[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]])  # CCW square
    np.testing.assert_allclose(closed.corners, [0.0, 1.0, 2.0, 3.0])
    s0, d0 = closed.nearest([-0.1, -0.1])  # outside at the start vertex
    assert s0 in (0.0, 4.0)
    assert d0 == pytest.approx(-math.hypot(0.1, 0.1), abs=1e-15)


def test_find_segment_and_eval_clamp():
    path = cgp.polyline([[0, 0], [1, 0], [1, 2]])
    s0 = path.table.s0
    assert geom.find_segment(s0, -1.0) == 0
    assert geom.find_segment(s0, 0.5) == 0
    assert geom.find_segment(s0, 1.0) == 1  # a corner belongs to the segment starting there
    assert geom.find_segment(s0, 3.0) == 1
    assert geom.find_segment(s0, 9.0) == 1
    np.testing.assert_array_equal(path.tangent(1.0), [0.0, 1.0])
    np.testing.assert_array_equal(path.point(-5.0), [0.0, 0.0])
    np.testing.assert_array_equal(path.point(50.0), [1.0, 2.0])


def test_window_restricts_the_search():
    path = cgp.circle(0.01)
    t = path.table
    q = np.array([[0.0, 0.02, 0.0]])  # nearest at a quarter turn
    full = _window_all(t.kind, t.s0, t.data, t.bound, q, np.array([0.0]), np.array([1.0]))
    assert full[0, 0] == pytest.approx(path.length / 4, abs=1e-15)
    part = _window_all(t.kind, t.s0, t.data, t.bound, q, np.array([0.03]),
                       np.array([0.05]))  # window past the foot: its start wins
    assert part[0, 0] == pytest.approx(0.03, abs=1e-15)
    swapped = _window_all(t.kind, t.s0, t.data, t.bound, q, np.array([0.05]),
                          np.array([0.03]))
    np.testing.assert_array_equal(swapped, part)


def test_window_over_many_spans_matches_restricted_brute_force():
    path = cgp.load("three_leaf")
    t = path.table
    rng = np.random.default_rng(5)
    n = 200
    lo = rng.uniform(0, path.length, n)
    hi = lo + rng.uniform(0, 0.02, n)
    pts = path.point(rng.uniform(0, path.length, n)) + rng.normal(scale=2e-3, size=(n, 2))
    got = _window_all(t.kind, t.s0, t.data, t.bound, _pad3(pts), lo, hi)
    assert np.all(got[:, 0] >= np.minimum(lo, path.length) - 1e-15)
    assert np.all(got[:, 0] <= np.minimum(hi, path.length) + 1e-15)
    for k in range(n):
        s = np.linspace(lo[k], min(hi[k], path.length), 20001)
        d2 = np.sum((path.point(s) - pts[k]) ** 2, axis=1)
        assert got[k, 1] <= d2.min() + 1e-15
        h = s[1] - s[0]  # between samples d2 can dip by at most 2 |p - P| h + h^2
        assert got[k, 1] >= d2.min() - 2.0 * np.sqrt(d2.min()) * h - h * h


def test_helix_points_on_axis_and_on_cylinder():
    r, pitch = 0.02, 0.01
    path = cgp.helix(r, pitch, 2.0)
    z = np.linspace(0.0005, 0.0195, 40)
    s, d = path.nearest(np.stack([np.zeros_like(z), np.zeros_like(z), z], 1))
    np.testing.assert_allclose(d, r, atol=1e-12, rtol=0)
    np.testing.assert_allclose(path.point(s)[:, 2], z, atol=1e-12, rtol=0)
    phi = np.linspace(0.1, 4 * np.pi - 0.1, 50)
    rho = 0.025
    q = np.stack([rho * np.cos(phi), rho * np.sin(phi), pitch * phi / (2 * np.pi)], 1)
    s, d = path.nearest(q)
    np.testing.assert_allclose(d, rho - r, atol=1e-12, rtol=0)
    np.testing.assert_allclose(s, phi * path.length / (4 * np.pi), atol=1e-12, rtol=0)


def test_steep_helix_with_far_points_against_brute_force():
    from _paths_brute import brute_nearest

    path = cgp.helix(0.005, -0.002, 3.5, center=(0.1, 0.2, 0.3), start_angle=1.0)
    rng = np.random.default_rng(6)
    pts = np.array([0.1, 0.2, 0.29]) + rng.normal(scale=0.01, size=(100, 3))
    _, d_ref = brute_nearest(path, pts)
    _, d = path.nearest(pts)
    np.testing.assert_allclose(d, d_ref, atol=1e-11, rtol=0)


def test_span_with_two_minima_is_solved_exactly():
    """A point near the centre of curvature of a tight free-form bend sees several minima."""
    from _paths_brute import brute_nearest

    path = cgp.parametric(lambda t: np.stack([0.01 * np.cos(t), 0.006 * np.sin(t)], 1), 0.0, 3.0)
    rng = np.random.default_rng(8)
    pts = rng.normal(scale=0.004, size=(200, 2))
    _, d_ref = brute_nearest(path, pts)
    _, d = path.nearest(pts)
    np.testing.assert_allclose(np.abs(d), d_ref, atol=1e-11, rtol=0)


def test_bounds_contain_every_segment():
    for name in ("three_leaf", "helix", "circle_r10", "bspline_complex"):
        path = cgp.load(name)
        t = path.table
        for i in range(t.n_segments):
            s = np.linspace(t.s0[i], t.s0[i + 1], 50)
            p = _pad3(path.point(s))
            dist = np.linalg.norm(p - t.bound[i, :3], axis=1)
            assert np.all(dist <= t.bound[i, 3]), (name, i)
