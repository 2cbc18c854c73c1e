"""Path constructors, validation, vectorisation, immutability, pickling and invariance."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import contour_gym.paths as cgp
from contour_gym.paths import PathTable

# lengths -------------------------------------------------------------------------------------


def test_lengths_are_exact():
    assert cgp.circle(0.037).length == pytest.approx(2 * math.pi * 0.037, abs=1e-12)
    assert cgp.arc((0, 0), 0.02, 1.0, -1.5).length == pytest.approx(0.03, abs=1e-15)
    assert cgp.line([0, 0, 0], [0.3, 0.4, 1.2]).length == pytest.approx(1.3, abs=1e-15)
    h = cgp.helix(0.015, 0.004, 2.75)
    assert h.length == pytest.approx(2.75 * math.hypot(2 * math.pi * 0.015, 0.004), abs=1e-12)
    assert cgp.polyline([[0, 0], [3, 4], [3, 0]]).length == pytest.approx(9.0, abs=1e-15)


def test_helix_geometry():
    h = cgp.helix(0.02, 0.01, 1.5, center=(0.1, 0.2, 0.3), start_angle=0.5)
    np.testing.assert_allclose(h.point(0.0), [0.1 + 0.02 * math.cos(0.5),
                                              0.2 + 0.02 * math.sin(0.5), 0.3], atol=1e-15)
    end = h.point(h.length)
    np.testing.assert_allclose(end[2], 0.315, atol=1e-15)
    s = np.linspace(0, h.length, 101)
    np.testing.assert_allclose(np.linalg.norm(h.evaluate(s)[1], axis=1), 1.0, atol=1e-14)
    kappa = 0.02 / (0.02**2 + (0.01 / (2 * math.pi)) ** 2)
    np.testing.assert_allclose(h.curvature(s), kappa, rtol=1e-12)
    assert h.corners.size == 0  # quarter-turn pieces join smoothly


def test_curvature_and_signed_curvature():
    ccw = cgp.circle(0.05)
    cw = cgp.arc((0, 0), 0.05, 0.0, -math.pi)
    assert ccw.curvature(0.1) == pytest.approx(20.0, rel=1e-14)
    assert ccw.signed_curvature(0.1) == pytest.approx(20.0, rel=1e-14)
    assert cw.signed_curvature(0.1) == pytest.approx(-20.0, rel=1e-14)
    assert cgp.line([0, 0], [1, 1]).curvature(0.3) == 0.0
    with pytest.raises(ValueError, match="2-D"):
        cgp.helix(0.01, 0.01, 1).signed_curvature(0.0)


def test_vectorised_shapes():
    c = cgp.circle(0.01)
    assert c.point(0.0).shape == (2,)
    assert c.point([0.0, 0.01]).shape == (2, 2)
    assert c.tangent(np.zeros(5)).shape == (5, 2)
    assert isinstance(c.curvature(0.0), float)
    assert c.curvature(np.zeros(3)).shape == (3,)
    s, d = c.nearest([0.02, 0.0])
    assert isinstance(s, float) and isinstance(d, float)
    s, d = c.nearest(np.zeros((4, 2)) + 0.02)
    assert s.shape == (4,) and d.shape == (4,)
    h = cgp.load("helix")
    assert h.point(0.0).shape == (3,)
    s, d = h.nearest(np.ones((3, 3)), s_hint=np.zeros(3))
    assert np.all(d >= 0)


def test_composite_joins_and_corners():
    a = cgp.line([0, 0], [0.01, 0])
    b = cgp.arc((0.01, 0.005), 0.005, -math.pi / 2, math.pi)  # tangent to the line
    c = cgp.line([0.01, 0.01], [0.0, 0.02])  # kinked
    path = cgp.composite([a, b, c])
    assert path.length == pytest.approx(0.01 + 0.005 * math.pi + math.hypot(0.01, 0.01))
    np.testing.assert_allclose(path.corners, [0.01 + 0.005 * math.pi])
    with pytest.raises(ValueError, match=r"segments\[1\]"):
        cgp.composite([a, cgp.line([0.02, 0], [0.03, 0])])
    with pytest.raises(ValueError, match=r"segments\[1\] has dim 3"):
        cgp.composite([a, cgp.line([0.01, 0, 0], [0.02, 0, 0])])
    with pytest.raises(ValueError, match="at least one"):
        cgp.composite([])


def test_closed_flags():
    assert cgp.circle(0.01).closed
    assert not cgp.arc((0, 0), 0.01, 0, 3.0).closed
    assert not cgp.line([0, 0], [1, 0]).closed
    assert cgp.circle(0.01).corners.size == 0


# validation ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: cgp.line([0, 0], [0, 0]), "zero length"),
        (lambda: cgp.line([0, np.nan], [1, 0]), "start must be finite"),
        (lambda: cgp.line([0, 0], [1, np.inf]), "end must be finite"),
        (lambda: cgp.line([0, 0], [1, 0, 0]), "same dimension"),
        (lambda: cgp.line([0, 0, 0, 0], [1, 0, 0, 0]), "2-D or 3-D"),
        (lambda: cgp.polyline([[0, 0]]), "N >= 2"),
        (lambda: cgp.polyline([[0, 0], [1, 1], [1, 1]]), r"points\[2\] repeats"),
        (lambda: cgp.polyline([0, 1, 2]), "dimension"),
        (lambda: cgp.circle(0.0), "radius must be > 0"),
        (lambda: cgp.circle(-1.0), "radius must be > 0"),
        (lambda: cgp.circle(np.nan), "radius must be finite"),
        (lambda: cgp.circle(1.0, center=(0, 0, 0)), "center must have shape"),
        (lambda: cgp.arc((0, 0), 1.0, 0.0, 0.0), "sweep"),
        (lambda: cgp.arc((0, 0), 1.0, 0.0, 7.0), "sweep"),
        (lambda: cgp.arc((0, 0), -1.0, 0.0, 1.0), "radius"),
        (lambda: cgp.helix(0.0, 0.01, 1), "radius"),
        (lambda: cgp.helix(0.01, 0.0, 1), "pitch must be non-zero"),
        (lambda: cgp.helix(0.01, 0.01, 0), "turns must be > 0"),
        (lambda: cgp.helix(0.01, 0.01, 1, center=(0, 0)), "center must have shape"),
        (lambda: cgp.composite([cgp.circle(1.0), "x"]), r"segments\[1\] must be a Path"),
    ],
)
def test_bad_inputs_raise_value_error(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_nearest_input_checks():
    c = cgp.circle(0.01)
    with pytest.raises(ValueError, match="points must have shape"):
        c.nearest([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="points must be finite"):
        c.nearest([np.nan, 0.0])
    with pytest.raises(ValueError, match="s_hint must have one value per point"):
        c.nearest(np.zeros((3, 2)), s_hint=np.zeros(2))
    with pytest.raises(ValueError, match="s must be finite"):
        c.point(np.nan)
    with pytest.raises(ValueError, match="orthogonal"):
        c.transformed(rotation=[[2, 0], [0, 1]])


# immutability and pickling -------------------------------------------------------------------


def test_paths_are_immutable():
    c = cgp.circle(0.01)
    with pytest.raises(AttributeError):
        c.name = "x"  # type: ignore[misc]
    with pytest.raises(AttributeError):
        c.table.kind = None  # type: ignore[misc]
    for arr in (c.table.kind, c.table.s0, c.table.data, c.table.bound, c.corners):
        with pytest.raises(ValueError):
            arr[...] = 0


@pytest.mark.parametrize(
    "make",
    [
        lambda: cgp.circle(0.02),
        lambda: cgp.polyline([[0, 0], [1, 0], [1, 1]]),
        lambda: cgp.helix(0.01, 0.002, 1.2),
        lambda: cgp.load("trident"),
        lambda: cgp.from_gcode("G1 X10 F100\nG2 X20 Y0 R5"),
    ],
)
def test_pickle_round_trip(make):
    path = make()
    back = pickle.loads(pickle.dumps(path))
    assert type(back) is type(path)
    assert back.name == path.name and back.dim == path.dim and back.length == path.length
    np.testing.assert_array_equal(back.corners, path.corners)
    assert not back.table.data.flags.writeable
    pts = path.point(np.linspace(0, path.length, 7)) + 1e-3
    np.testing.assert_array_equal(back.nearest(pts)[1], path.nearest(pts)[1])
    if isinstance(path, cgp.GcodePath):
        np.testing.assert_array_equal(back.segment_feedrates, path.segment_feedrates)


# invariance ----------------------------------------------------------------------------------

_PATHS_2D = ["circle_r10", "corner", "infinity", "three_leaf"]


def _rot2(angle):
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


@settings(max_examples=25, deadline=None)
@given(
    name=st.sampled_from(_PATHS_2D),
    angle=st.floats(-math.pi, math.pi),
    shift=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
    seed=st.integers(0, 2**31),
)
def test_distance_invariant_under_rigid_motion_2d(name, angle, shift, seed):
    path = cgp.load(name)
    rng = np.random.default_rng(seed)
    pts = path.point(rng.uniform(0, path.length, 20)) + rng.normal(scale=2e-3, size=(20, 2))
    rot = _rot2(angle)
    moved = path.transformed(rot, shift)
    s, d = path.nearest(pts)
    s2, d2 = moved.nearest(pts @ rot.T + np.array(shift))
    np.testing.assert_allclose(d2, d, atol=1e-12, rtol=0)
    # a reflection swaps left and right
    mirror = path.transformed(np.diag([1.0, -1.0]))
    _, d3 = mirror.nearest(pts * np.array([1.0, -1.0]))
    np.testing.assert_allclose(d3, -d, atol=1e-12, rtol=0)


@settings(max_examples=15, deadline=None)
@given(
    quat=st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(x * x for x in q) > 0.1),
    shift=st.tuples(*[st.floats(-0.5, 0.5)] * 3),
    seed=st.integers(0, 2**31),
    reflect=st.booleans(),
)
def test_distance_invariant_under_rigid_motion_3d(quat, shift, seed, reflect):
    w, x, y, z = np.array(quat) / np.linalg.norm(quat)
    rot = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    if reflect:
        rot = rot @ np.diag([1.0, 1.0, -1.0])
    hx = cgp.load("helix")
    path = cgp.composite([hx, cgp.line(hx.point(hx.length), [0.0, 0.0, 0.03])])
    rng = np.random.default_rng(seed)
    pts = path.point(rng.uniform(0, path.length, 20)) + rng.normal(scale=3e-3, size=(20, 3))
    moved = path.transformed(rot, shift)
    _, d = path.nearest(pts)
    _, d2 = moved.nearest(pts @ rot.T + np.array(shift))
    np.testing.assert_allclose(d2, d, atol=1e-12, rtol=0)
    np.testing.assert_allclose(moved.point(0.01), rot @ path.point(0.01) + shift, atol=1e-14)


@pytest.mark.parametrize("family", ["lissajous", "cam", "zigzag"])
def test_a_moved_path_carries_its_search_rows_over(family: str) -> None:
    # transformed() maps the spheres and keeps turning and clearances (distances and angles)
    # instead of searching them again: they equal a fresh build's, and so do the searches
    path = cgp.random_path(np.random.default_rng(3), family)
    rot = _rot2(0.7)
    moved = path.transformed(rot, [0.01, -0.02])
    t = moved.table
    fresh = PathTable(t.kind, t.s0, t.data, np.ascontiguousarray(t.spheres), t.dim)
    n = t.n_segments
    np.testing.assert_allclose(t.bound[:n, 4:], fresh.bound[:n, 4:], rtol=0, atol=1e-12)
    assert t.closed == fresh.closed
    rng = np.random.default_rng(0)
    s = rng.uniform(0, t.length, 50)
    pts = moved.point(s) + rng.normal(scale=3e-4, size=(50, 2))
    a = moved.nearest(pts, s_hint=s)
    b = cgp.Path(fresh).nearest(pts, s_hint=s)
    np.testing.assert_allclose(a[1], b[1], rtol=0, atol=1e-15)


def test_the_branch_wraps_on_closed_paths():
    # a tool past the end of a closed contour is near its start: the hinted search must
    # find that, not the end point (the servo loop's ground truth uses the same search)
    c = cgp.circle(0.02)
    p = np.array([[0.02 + 5e-6, 1.5e-4]])  # just past s = 0 == L, 5 um outside
    s_end, d_end = c.nearest(p, s_hint=np.array([c.length]))
    s_glob, d_glob = c.nearest(p)
    assert abs(d_end[0]) == pytest.approx(abs(d_glob[0]), rel=1e-9)
    assert abs(d_end[0]) < 6e-6
