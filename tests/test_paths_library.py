"""Named library paths: shapes from the papers, and exact nearest points on every one."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from _paths_brute import brute_nearest, points_near

import contour_gym.paths as cgp

REAL_NAMES = [n for n in cgp.NAMES if n != "circle"]


@pytest.mark.parametrize("name", REAL_NAMES)
def test_nearest_matches_brute_force(name):
    path = cgp.load(name)
    rng = np.random.default_rng(abs(hash(name)) % 2**32)
    pts, _ = points_near(path, rng, 150, spread=4e-3)
    s_ref, d_ref = brute_nearest(path, pts)
    s, d = path.nearest(pts)
    dist = np.abs(d)
    # exact search can never be worse than any sample, and the refined brute force is exact
    # in its basin: the two agree to well below the 1e-9 m target
    assert np.all(dist <= d_ref + 1e-12)
    np.testing.assert_allclose(dist, d_ref, atol=1e-10, rtol=0)
    # the reported foot really is at the reported distance
    foot = path.point(s)
    np.testing.assert_allclose(np.linalg.norm(foot - pts, axis=1), dist, atol=1e-12, rtol=0)
    same_basin = np.abs(s - s_ref) < 1e-4
    assert same_basin.mean() > 0.95
    np.testing.assert_allclose(s[same_basin], s_ref[same_basin], atol=2e-7, rtol=0)


@pytest.mark.parametrize("name", REAL_NAMES)
def test_foot_point_is_stationary(name):
    """At an interior foot point the offset is normal to the tangent (first-order condition)."""
    path = cgp.load(name)
    rng = np.random.default_rng(7)
    pts, _ = points_near(path, rng, 300, spread=3e-3)
    s, d = path.nearest(pts)
    interior = (s > 1e-9) & (s < path.length - 1e-9)
    for c in path.corners:
        interior &= np.abs(s - c) > 1e-9
    foot, d1, _ = path.evaluate(s[interior])
    g = np.sum((foot - pts[interior]) * d1, axis=1)
    assert np.max(np.abs(g)) < 1e-13


@pytest.mark.parametrize("name", [n for n in REAL_NAMES if cgp.load(n).dim == 2])
def test_signed_distance_sign_on_library_paths(name):
    path = cgp.load(name)
    rng = np.random.default_rng(3)
    pts, _ = points_near(path, rng, 300, spread=2e-3)
    s, d = path.nearest(pts)
    ok = np.abs(d) > 1e-9
    for c in path.corners:
        ok &= np.abs(s - c) > 1e-6
    foot = path.point(s[ok])
    t = path.tangent(s[ok])
    off = pts[ok] - foot
    cross = t[:, 0] * off[:, 1] - t[:, 1] * off[:, 0]
    assert np.all(np.sign(cross) == np.sign(d[ok]))


def test_hint_search_agrees_with_global_near_the_path():
    for name in REAL_NAMES:
        path = cgp.load(name)
        rng = np.random.default_rng(11)
        s_true = rng.uniform(0.0, path.length, 400)
        pts = path.point(s_true) + rng.normal(scale=20e-6, size=(400, path.dim))
        hint = np.clip(s_true - rng.uniform(0, 2e-4, 400), 0, path.length)  # lagging reference
        s_h, d_h = path.nearest(pts, s_hint=hint)
        s_g, d_g = path.nearest(pts)
        np.testing.assert_allclose(d_h, d_g, atol=1e-12, rtol=0, err_msg=name)


def test_infinity_hint_stays_on_its_branch_at_the_crossing():
    path = cgp.load("infinity")
    s_cross = path.length / 2.0  # the second pass through the origin
    p0 = path.point(0.0)
    np.testing.assert_allclose(path.point(s_cross), p0, atol=1e-9)
    t = path.tangent(s_cross)
    q = p0 + 1e-5 * np.array([-t[1], t[0]])
    s_h, d_h = path.nearest(q, s_hint=s_cross)
    assert abs(s_h - s_cross) < 1e-4
    assert d_h == pytest.approx(1e-5, abs=1e-10)


def test_library_shapes_follow_the_papers():
    c10 = cgp.load("circle_r10")
    np.testing.assert_allclose(c10.point(0.0), [0.0, 0.0], atol=1e-15)
    tt = np.linspace(0, 2, 9)
    ref = np.stack([10e-3 * np.cos(np.pi * tt) - 10e-3, 10e-3 * np.sin(np.pi * tt)], 1)
    np.testing.assert_allclose(c10.point(tt * np.pi * 10e-3), ref, atol=1e-15)
    assert cgp.load("circle") is c10
    assert cgp.load("circle_r20").length == pytest.approx(2 * math.pi * 0.02, abs=1e-15)
    np.testing.assert_allclose(cgp.load("circle_r50").point(0.0), [0.05, 0.0])
    leaf = cgp.load("three_leaf")
    assert leaf.closed
    th = np.linspace(0, np.pi, 7)
    rose = 0.025 * np.cos(3 * th)[:, None] * np.stack([np.cos(th), np.sin(th)], 1)
    s, d = leaf.nearest(rose)
    assert np.max(np.abs(d)) < 1e-10
    corner = cgp.load("corner")
    np.testing.assert_allclose(corner.corners, [0.025])
    np.testing.assert_allclose(corner.tangent([0.01, 0.04]),
                               np.array([[1, 1], [1, -1]]) / math.sqrt(2), atol=1e-15)
    inf = cgp.load("infinity")
    box = inf.point(np.linspace(0, inf.length, 20001))
    np.testing.assert_allclose(box.max(0) - box.min(0), [0.1, 0.05], rtol=2e-3)
    assert inf.closed and not cgp.load("trident").closed
    hx = cgp.load("helix")
    assert hx.dim == 3
    assert hx.length == pytest.approx(2 * math.hypot(2 * math.pi * 0.02, 0.01), abs=1e-15)
    assert cgp.load("bspline_complex").length == pytest.approx(0.742, rel=1e-3)


def test_trident_curvature_is_irregular():
    path = cgp.load("trident")
    kappa = path.curvature(np.linspace(0, path.length, 5001))
    assert kappa.max() > 20 * np.median(kappa)
    peaks = np.sum((kappa[1:-1] > kappa[:-2]) & (kappa[1:-1] > kappa[2:]))
    assert peaks >= 5


def test_bspline_complex_has_straight_stretches():
    path = cgp.load("bspline_complex")
    kappa = path.curvature(np.linspace(0, path.length, 20001))
    assert np.mean(kappa < 1e-9) > 0.2
    assert kappa.max() > 20.0


def test_every_builder_documents_its_source():
    for name in REAL_NAMES:
        doc = cgp._library._BUILDERS[name].__doc__
        assert doc is not None and "paper 00" in doc, name


def test_load_unknown_name_lists_accepted_names():
    with pytest.raises(ValueError, match="bspline_complex.*trident"):
        cgp.load("square")


def test_library_paths_pickle_round_trip():
    for name in REAL_NAMES:
        path = cgp.load(name)
        back = pickle.loads(pickle.dumps(path))
        assert back.name == path.name and back.closed == path.closed
        s = np.linspace(0, path.length, 101)
        np.testing.assert_array_equal(back.point(s), path.point(s))
