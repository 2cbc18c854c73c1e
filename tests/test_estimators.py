"""Contour error estimators: interface, exactness, invariance, fallbacks, loop agreement, CCC."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import contour_gym.paths as cgp
from contour_gym.api import make_scenario
from contour_gym.contour import (
    ESTIMATORS,
    Estimator,
    build_estimator,
    estimate,
    estimate_full,
    get_estimator,
)
from contour_gym.contour._history import N_HIST

NAMES = tuple(ESTIMATORS)
PAPER_NAMES = ("exact", "two_circle", "tangent", "frenet", "angle", "window")
DS = 20e-6  # interpolation step used with synthetic tool positions, m


def lagging_tool(path, s, lag, offset):
    """Tool positions ``lag`` of arc length behind ``s``, moved ``offset`` along the normal."""
    s = np.asarray(s, dtype=float)
    p = path.point(s - lag)
    t = path.tangent(s - lag)
    if path.dim == 2:
        return p + offset[:, None] * np.stack([-t[:, 1], t[:, 0]], axis=1)
    side = np.cross(t, [0.3, -0.5, 0.8])
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    return p + offset[:, None] * side


def truth(path, s, pos):
    """Exact contour error vectors (tool -> foot) and signed distances, from Path.nearest."""
    foot, dist = path.nearest(pos, s_hint=s)
    return path.point(foot) - pos, dist


def history_of(trace_s):
    """(T, N_HIST) history rows of a recorded reference, as the loop's ring buffer holds it."""
    idx = np.arange(trace_s.size)[:, None] - 1 - np.arange(N_HIST)[None, :]
    return np.where(idx >= 0, trace_s[np.clip(idx, 0, None)], 0.0)


# interface -----------------------------------------------------------------------------------


def test_registry_names_and_factories():
    assert set(NAMES) == {"ground_truth", "exact", "two_circle", "tangent", "frenet", "angle",
                          "window", "iterative"}
    est = get_estimator("tangent", max_turn=0.5)
    assert isinstance(est, Estimator) and est.params[est.kind.params.col.max_turn] == 0.5
    it = build_estimator("iterative", n_iter=6, method="circle")
    col = it.kind.params.col
    assert it.kind is ESTIMATORS.get("iterative")
    assert [it.params[col.n_iter], it.params[col.method]] == [6, 1]


def test_estimate_returns_vector_scalar_and_unit_gains():
    path = cgp.circle(0.01)
    s = np.linspace(0.005, 0.05, 7)
    pos = lagging_tool(path, s, 2e-4, np.linspace(-5e-5, 5e-5, 7))
    for name in NAMES:
        vec = estimate(name, path, s, pos, ds=DS)
        full = estimate_full(name, path, s, pos, ds=DS)
        assert vec.shape == (7, 2)
        np.testing.assert_array_equal(vec, full.vector)
        np.testing.assert_allclose(np.linalg.norm(full.gains, axis=1), 1.0, atol=1e-12)
        np.testing.assert_array_equal(full.vector, full.gains * full.eps[:, None])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"name": "nope"}, "unknown estimator"),
        ({"positions": np.zeros((3, 3))}, "shape"),
        ({"positions": np.zeros(2)}, "shape"),
        ({"positions": [[0.0, np.nan]] * 3}, "finite"),
        ({"s_ref": [0.0, np.inf, 0.0]}, "finite"),
        ({"s_ref": np.zeros(2)}, "s_ref"),
        ({"name": "two_circle", "ds": None}, "s_hist or ds"),
        ({"name": "window", "s_hist": np.zeros((2, 4)), "ds": None}, "s_hist"),
        ({"name": "angle", "s_hist": [[0.0, np.nan]], "ds": None}, "finite"),
        ({"ds": 1e-5, "s_hist": np.zeros(3)}, "either"),
        ({"name": "tangent", "max_turn": -1.0}, "max_turn"),
        ({"name": "frenet", "order": 3}, "order"),
        ({"name": "iterative", "method": "secant"}, "iterative.method"),
        ({"name": "window", "colour": 1}, "unknown parameter"),
        ({"path": "circle"}, "Path"),
    ],
)
def test_bad_input_is_a_value_error(kwargs, match):
    args = {"name": "tangent", "path": cgp.circle(0.01), "s_ref": np.zeros(3),
            "positions": np.full((3, 2), 0.001), "ds": 1e-5}
    args.update(kwargs)
    if args["ds"] is None:
        del args["ds"]
    with pytest.raises(ValueError, match=match):
        estimate(args.pop("name"), args.pop("path"), args.pop("s_ref"), args.pop("positions"),
                 **args)


def test_exact_rejects_free_form_paths_in_python_and_falls_back_in_the_loop():
    with pytest.raises(ValueError, match="lines and arcs"):
        estimate("exact", cgp.load("infinity"), [0.0], [[0.0, 0.0]])
    loop = make_scenario("xy_dc_servo", "infinity", ideal=True).loop(
        ccc_gains=(300.0, 0.0, 0.0), estimator="exact", record=True)
    loop.reset(0)
    loop.step(400)
    tr = loop.trace()
    # ground truth answered every tick (the fallback's search window is hinted by the
    # reference, the true error's by the machine's foot: the same foot to rounding)
    np.testing.assert_allclose(tr.eps_est, tr.eps, rtol=0, atol=1e-15)


def test_unknown_estimator_in_the_loop_is_a_value_error():
    with pytest.raises(ValueError, match="accepted"):
        make_scenario("xy_dc_servo").loop(estimator="nearest")


def test_history_by_step_or_by_list_agree():
    path = cgp.load("infinity")
    s = np.linspace(0.01, 0.29, 50)
    pos = lagging_tool(path, s, 6e-4, np.full(50, 3e-5))
    hist = np.maximum(s[:, None] - DS * np.arange(1, N_HIST + 1), 0.0)
    for name in ("two_circle", "angle", "window"):
        a = estimate(name, path, s, pos, ds=DS)
        b = estimate(name, path, s, pos, s_hist=hist)
        c = estimate(name, path, s, pos, s_hist=hist[:, :40])  # older entries held: unused
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)


# exactness -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "path",
    [cgp.circle(0.01, center=(0.02, -0.03), start_angle=1.0), cgp.arc((0.0, 0.01), 0.02, 2.0, -2.5),
     cgp.line([0.01, 0.02], [0.05, -0.03]), cgp.line([0.0, 0.1, -0.2], [0.3, 0.2, 0.1])],
    ids=["circle", "cw_arc", "line", "line_3d"],
)
def test_exact_equals_ground_truth_on_lines_and_arcs(path):
    rng = np.random.default_rng(1)
    s = rng.uniform(0.2, 0.8, 200) * path.length
    pos = lagging_tool(path, s, rng.uniform(-1e-3, 2e-3, 200), rng.uniform(-5e-4, 5e-4, 200))
    vec, dist = truth(path, s, pos)
    est = estimate_full("exact", path, s, pos)
    gt = estimate_full("ground_truth", path, s, pos)
    assert not est.fallback.any()
    np.testing.assert_allclose(est.vector, vec, atol=1e-9)
    np.testing.assert_allclose(gt.vector, vec, atol=1e-12)
    if path.dim == 2:
        np.testing.assert_allclose(est.eps, dist, atol=1e-9)
        np.testing.assert_allclose(gt.eps, dist, atol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("name", NAMES)
def test_every_estimator_is_exact_on_a_straight_line(name, dim):
    ends = ([0.01, -0.02], [0.09, 0.04]) if dim == 2 else ([0.01, -0.02, 0.03], [0.09, 0.04, -0.05])
    path = cgp.line(*ends)
    rng = np.random.default_rng(2)
    s = rng.uniform(0.03, 0.09, 100)
    pos = lagging_tool(path, s, rng.uniform(-DS, 2e-3, 100), rng.uniform(-3e-4, 3e-4, 100))
    vec, _ = truth(path, s, pos)
    np.testing.assert_allclose(estimate(name, path, s, pos, ds=DS), vec, atol=1e-12)


def test_tangent_estimate_is_the_distance_to_the_tangent_line():
    # 001's estimate on a circle, tool on the path phi behind: eps_hat = R (1 - cos phi),
    # pointing along the normal at the reference (a check of the reconstruction, and of
    # its large-lag breakdown: the true error is 0)
    r = 0.01
    path = cgp.circle(r)
    phi = np.array([0.01, 0.05, 0.2])
    s = np.full(3, 0.03)
    pos = path.point(s - r * phi)
    est = estimate_full("tangent", path, s, pos)
    np.testing.assert_allclose(np.abs(est.eps), r * (1 - np.cos(phi)), rtol=1e-9)
    normal = path.point(s) / r
    np.testing.assert_allclose(np.abs(np.sum(est.gains * normal, axis=1)), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_sign_convention(name):
    # counter-clockwise circle: a tool outside is right of travel (eps < 0), inside is left
    path = cgp.circle(0.02)
    s = np.full(2, 0.04)
    pos = lagging_tool(path, s, 1e-4, np.array([-2e-5, 2e-5]))  # -: right (outside)
    est = estimate_full(name, path, s, pos, ds=DS)
    assert est.eps[0] < 0 < est.eps[1]
    outward = pos / np.linalg.norm(pos, axis=1, keepdims=True)
    assert np.sum(est.vector[0] * outward[0]) < 0 < np.sum(est.vector[1] * outward[1])


@pytest.mark.parametrize("name", NAMES)
def test_3d_error_is_unsigned_with_unit_gains(name):
    path = cgp.line([0, 0, 0], [0.2, 0.1, 0.3]) if name == "exact" else cgp.load("helix")
    s = np.linspace(0.02, 0.2, 20)
    pos = lagging_tool(path, s, 3e-4, np.linspace(-5e-5, 5e-5, 20))
    est = estimate_full(name, path, s, pos, ds=DS)
    assert np.all(est.eps >= 0)
    np.testing.assert_allclose(np.linalg.norm(est.gains, axis=1), 1.0, atol=1e-12)
    vec, _ = truth(path, s, pos)
    np.testing.assert_allclose(est.vector, vec, atol=3e-6)  # tangent: kappa lag^2 / 2 = 2.2 um


# rigid-motion invariance ---------------------------------------------------------------------


def rotation_2d(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def rotation_3d(a, b, c):
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    rz = np.array([[math.cos(b), -math.sin(b), 0], [math.sin(b), math.cos(b), 0], [0, 0, 1]])
    ry = np.array([[math.cos(c), 0, math.sin(c)], [0, 1, 0], [-math.sin(c), 0, math.cos(c)]])
    return rz @ rx @ ry


_CTRL_2D = np.array([[0, 0], [10, 15], [25, 20], [40, 5], [55, 12], [65, 30]], float) * 1e-3
_CTRL_3D = np.array([[0, 0, 0], [10, 15, 5], [25, 20, -5], [40, 5, 10], [55, 12, 0]], float) * 1e-3
_POLY = np.array([[0, 0], [30, 10], [45, 40], [70, 35]], float) * 1e-3


def moved_pair(kind, rot, off):
    """A path built by a constructor and the same path rigidly moved, built the same way."""
    if kind == "arc":
        theta = math.atan2(rot[1, 0], rot[0, 0])
        c = np.array([0.01, -0.02])
        return cgp.arc(c, 0.015, 0.3, 4.0), cgp.arc(rot @ c + off, 0.015, 0.3 + theta, 4.0)
    if kind == "polyline":
        return cgp.polyline(_POLY), cgp.polyline(_POLY @ rot.T + off)
    ctrl = _CTRL_2D if kind == "nurbs" else _CTRL_3D
    w = np.linspace(0.8, 1.5, ctrl.shape[0])
    knots = np.r_[[0.0] * 4, np.linspace(0, 1, ctrl.shape[0] - 2)[1:-1], [1.0] * 4]
    return cgp.nurbs(ctrl, w, knots, 3), cgp.nurbs(ctrl @ rot.T + off, w, knots, 3)


@pytest.mark.parametrize("kind", ["arc", "polyline", "nurbs", "nurbs_3d"])
@settings(max_examples=40, deadline=None)
@given(
    angles=st.tuples(*[st.floats(-math.pi, math.pi)] * 3),
    off=st.tuples(*[st.floats(-0.2, 0.2)] * 3),
    frac=st.floats(0.15, 0.85),
    lag=st.floats(-DS, 2e-3),
    normal=st.floats(-3e-4, 3e-4),
)
def test_estimators_are_invariant_under_rigid_motion(kind, angles, off, frac, lag, normal):
    # two_circle and window pick interpolation points: their estimate jumps where the tool is
    # equidistant from two of them (lag a multiple of DS / 2 on a uniform history), and
    # rounding decides the side there. The irrational shift keeps the lags off those ties.
    lag += DS / math.pi
    dim = 3 if kind.endswith("3d") else 2
    rot = rotation_3d(*angles) if dim == 3 else rotation_2d(angles[0])
    shift = np.array(off[:dim])
    a, b = moved_pair(kind, rot, shift)
    s = np.array([frac * a.length])
    pos = lagging_tool(a, s, lag, np.array([normal]))
    pos_b = pos @ rot.T + shift
    tol = 1e-9 if kind in ("arc", "polyline") else 1e-8  # free-form: two separate fits
    for name in NAMES:
        if name == "exact" and kind.startswith("nurbs"):
            continue
        ea = estimate_full(name, a, s, pos, ds=DS)
        eb = estimate_full(name, b, s, pos_b, ds=DS)
        np.testing.assert_allclose(eb.vector, ea.vector @ rot.T, atol=tol, err_msg=name)
        np.testing.assert_allclose(eb.eps, ea.eps, atol=tol, err_msg=name)


# fallbacks -----------------------------------------------------------------------------------


def assert_fell_back_to_truth(name, path, s, pos, **kwargs):
    est = estimate_full(name, path, s, pos, **kwargs)
    gt = estimate_full("ground_truth", path, s, pos)
    assert est.fallback.all(), name
    np.testing.assert_array_equal(est.eps, gt.eps)
    np.testing.assert_array_equal(est.vector, gt.vector)


def test_history_estimators_fall_back_when_the_tool_lags_beyond_the_buffer():
    path = cgp.load("infinity")
    s = np.linspace(0.1, 0.25, 10)
    pos = lagging_tool(path, s, 140 * DS, np.full(10, 1e-5))
    for name in ("two_circle", "window"):
        assert_fell_back_to_truth(name, path, s, pos, ds=DS)


def test_history_estimators_fall_back_at_rest():
    path = cgp.circle(0.01)
    s = np.full(3, 0.02)
    pos = lagging_tool(path, s, 1e-4, np.full(3, 1e-5))
    for name in ("two_circle", "window", "angle"):
        assert_fell_back_to_truth(name, path, s, pos, ds=0.0)


def test_linearisations_fall_back_far_off_the_path():
    path = cgp.circle(0.01)
    s = np.full(4, 0.04)
    pos = lagging_tool(path, s, 0.015, np.linspace(-1e-3, 1e-3, 4))  # kappa |e| > 1
    for name in ("tangent", "frenet", "angle"):
        assert_fell_back_to_truth(name, path, s, pos, ds=DS)
    est = estimate_full("tangent", path, s, pos, max_turn=5.0)  # allowed: garbage, no fallback
    assert not est.fallback.any()


def test_exact_falls_back_at_the_arc_centre():
    path = cgp.circle(0.01, center=(0.003, 0.004))
    assert_fell_back_to_truth("exact", path, [0.01], [[0.003, 0.004]])


def test_iterative_never_settles_on_the_wrong_leg_of_a_corner():
    path = cgp.load("corner")
    s = np.linspace(0.0245, 0.0275, 60)
    pos = lagging_tool(path, s, 1e-3, np.linspace(-1e-4, 1e-4, 60))
    vec, _ = truth(path, s, pos)
    est = estimate_full("iterative", path, s, pos)
    assert est.fallback.any() and not est.fallback.all()
    np.testing.assert_allclose(est.vector, vec, atol=1e-9)
    # the papers' tangent estimate projects on the outgoing leg there: the breakdown
    assert np.max(np.linalg.norm(estimate("tangent", path, s, pos) - vec, axis=1)) > 1e-4


# accuracy at the papers' settings ------------------------------------------------------------


FREE_FORM = [("infinity", "xy_dc_servo", 0), ("trident", "xy_dc_servo", 0),
             ("three_leaf", "xyy_gantry", 0), ("bspline_complex", "lugre_linear_motor", 0)]


def paper_run(path_name, preset, contour):
    """The paper machine without CCC on the path: (path, s, tool in path coordinates, hist)."""
    sc = make_scenario(preset, path_name)
    loop = sc.loop(record=True)
    loop.reset(0)
    loop.run()
    tr = loop.trace()
    live = np.isfinite(tr.s[0])  # rows after the arrival are NaN
    con = sc.preset.stage.contours[contour]
    pos = tr.x[0][live][:, list(con.axes)] - np.asarray(con.offset or (0.0,) * len(con.axes))
    s = tr.s[0][live]
    moving = tr.v[0][live] > 0
    return sc.path, s, pos, history_of(s), moving


@pytest.mark.parametrize(("path_name", "preset", "contour"), FREE_FORM)
def test_best_free_curve_estimators_within_two_percent_at_the_papers_feedrates(
        path_name, preset, contour):
    path, s, pos, hist, moving = paper_run(path_name, preset, contour)
    vec, _ = truth(path, s, pos)
    scale = np.max(np.linalg.norm(vec[moving], axis=1))
    worst = {}
    for name in ("two_circle", "iterative", "window", "frenet"):
        d = np.linalg.norm(estimate(name, path, s, pos, s_hist=hist) - vec, axis=1)
        worst[name] = np.max(d[moving]) / scale
    assert worst["iterative"] <= 0.02
    assert worst["two_circle"] <= 0.02
    if path_name == "infinity":  # 000 reports up to 18.4 um here; ten times better
        d = np.linalg.norm(estimate("two_circle", path, s, pos, s_hist=hist) - vec, axis=1)
        assert np.max(d) <= 1.84e-6


# the loop uses the same estimators -----------------------------------------------------------


@pytest.mark.parametrize("path_name", ["circle", "infinity"])
@pytest.mark.parametrize("name", NAMES)
def test_python_api_equals_what_the_ccc_saw_in_the_loop(name, path_name):
    if name == "exact" and path_name == "infinity":
        pytest.skip("exact is rejected on free-form paths by the Python API")
    # the CCC sees the true position (ideal); 002's machine, as in the next test, so that both
    # share their compiled kernels (the path and ideal are data, the friction law is code)
    sc = make_scenario("lugre_linear_motor", path_name, ideal=True)
    loop = sc.loop(ccc_gains=sc.preset.ccc_gains.as_tuple(), estimator=name, record=True)
    loop.reset(0)
    loop.step(1200)
    tr = loop.trace()
    est = estimate_full(name, sc.path, tr.s[0], tr.x[0], s_hist=history_of(tr.s[0]))
    np.testing.assert_allclose(est.eps, tr.eps_est[0, :, 0], rtol=0, atol=1e-15)


@pytest.mark.parametrize("path_name", ["circle", "infinity"])
def test_pid_ccc_beats_no_ccc_with_every_estimator(path_name):
    # 002's linear-motor machine: loops stiff enough that the tracking error stays within
    # the linearised estimators' range. (On 000's Kv = 30/s machine the ~1 mm lag biases
    # tangent and angle by kappa e_t^2 / 2 ~ 50 um on the 10 mm circle, and a CCC driven
    # by them does worse than none: see benchmarks/estimators.py.)
    sc = make_scenario("lugre_linear_motor", path_name)
    loop = sc.loop()
    loop.reset(0)
    none = loop.run()["max_contour_error"][0]
    for name in NAMES:
        loop = sc.loop(ccc_gains=sc.preset.ccc_gains.as_tuple(), estimator=name)
        loop.reset(0)
        m = loop.run()
        assert not loop.failed.any(), name
        assert m["max_contour_error"][0] < 0.8 * none, name


def test_the_path_memo_gives_what_eval_path_gives_bit_for_bit():
    """The member row's memo of path points: exact, the sign of zero kept, a zeroed row empty."""
    import numba

    from contour_gym.contour._history import HIST_WIDTH, eval_path_memo
    from contour_gym.paths._geom import eval_path

    @numba.njit
    def both(kind, s0, data, ss, hist, out_memo, out_plain):
        for i in range(ss.shape[0]):
            r = eval_path_memo(kind, s0, data, ss[i], hist)
            q = eval_path(kind, s0, data, ss[i])
            for j in range(9):
                out_memo[i, j] = r[j]
                out_plain[i, j] = q[j]

    for name in ("circle", "three_leaf"):
        t = cgp.load(name).table
        rng = np.random.default_rng(0)
        s = rng.uniform(-0.01, t.s0[-1] + 0.01, 40)
        ss = np.concatenate([s, s[::-1], s[:5], [0.0, -0.0, 0.0, -0.0, np.nan, np.nan]])
        hist = np.zeros(HIST_WIDTH)
        memo, plain = np.empty((ss.size, 9)), np.empty((ss.size, 9))
        both(t.kind, t.s0, t.data, ss, hist, memo, plain)
        np.testing.assert_array_equal(memo, plain)
        assert np.array_equal(np.signbit(memo), np.signbit(plain))
        hist[:] = 0.0  # a reset member: nothing remembered, s = 0 evaluated afresh
        both(t.kind, t.s0, t.data, np.zeros(1), hist, memo[:1], plain[:1])
        np.testing.assert_array_equal(memo[:1], plain[:1])
