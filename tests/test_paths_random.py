"""Random paths (contour_gym.paths._random): determinism, limits, families, loop, feeds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba.core import event

import contour_gym
from contour_gym.api import make_scenario
from contour_gym.paths import HELIX, LINE, PATH_FAMILIES, GcodePath, Path, random_path, random_paths

WITHIN = ((0.10, 0.25), (-0.02, 0.06))  # an off-centre, non-square travel box, m
MARGIN = 0.003
LENGTH = (0.03, 0.12)
SMOOTH = ("spline", "lissajous", "rose", "spiral")


def _draw(seed: int, family: str | None, **kwargs: object) -> Path:
    return random_path(np.random.default_rng(seed), family, **kwargs)  # type: ignore[arg-type]


def _same(p: Path, q: Path) -> bool:
    a, b = p.table, q.table
    return (a.data.shape == b.data.shape and np.array_equal(a.data, b.data)
            and np.array_equal(a.s0, b.s0) and np.array_equal(a.kind, b.kind))


@pytest.mark.parametrize("family", PATH_FAMILIES)
def test_same_generator_state_same_path_bit_for_bit(family: str) -> None:
    assert _same(_draw(11, family), _draw(11, family))
    assert not _same(_draw(11, family), _draw(12, family))


def test_global_random_state_is_untouched() -> None:
    before = np.random.get_state()  # noqa: NPY002 (the legacy global state is under test)
    _draw(4, "cam")
    _draw(4, "spiral", length=0.02)
    after = np.random.get_state()  # noqa: NPY002
    assert all(np.array_equal(x, y) for x, y in zip(before, after, strict=True))


def _signed_area(path: Path) -> float:
    x, y = path.point(np.linspace(0.0, path.length, 2001)).T
    return 0.5 * float(np.sum(x[:-1] * y[1:] - x[1:] * y[:-1]))


def test_orientation_mirror_and_position_are_drawn() -> None:
    roses = [_draw(seed, "rose", length=0.03) for seed in range(12)]
    areas = [_signed_area(p) for p in roses]  # a rose runs counter-clockwise unless mirrored
    assert min(areas) < 0.0 < max(areas)
    lines = [_draw(seed, "polyline") for seed in range(30)]
    heading = np.array([math.atan2(*p.tangent(0.0)[::-1]) for p in lines])
    assert np.all(np.histogram(heading, bins=4, range=(-math.pi, math.pi))[0] > 0)
    starts = np.array([p.point(0.0) for p in lines])
    assert np.all(np.ptp(starts, axis=0) > 0.03)
    splines = [_draw(seed, "spline", length=0.03) for seed in range(12)]
    assert {p.closed for p in splines} == {True, False}
    assert all(p.closed for p in roses)


def test_no_family_draws_every_family_and_random_paths_is_sequential() -> None:
    names = {p.name for p in random_paths(5, 40, family="polyline", length=0.01)}
    assert names == {"random_polyline"}
    drawn = {_draw(seed, None, length=0.01).name for seed in range(40)}
    assert drawn == {f"random_{f}" for f in PATH_FAMILIES}
    rng = np.random.default_rng(3)
    one_by_one = [random_path(rng, "cam"), random_path(rng, "polyline")]
    both = random_paths(3, 2, family="cam")
    assert _same(both[0], one_by_one[0]) and not _same(both[1], both[0])
    assert all(_same(p, q) for p, q in zip(random_paths(9, 3), random_paths(9, 3), strict=True))


def test_a_list_of_families_draws_among_them_and_all_of_them_is_none() -> None:
    names = [p.name for p in random_paths(4, 30, family=["cam", "cam", "rose"], length=0.01)]
    assert set(names) == {"random_cam", "random_rose"}
    assert names.count("random_cam") > names.count("random_rose")
    listed, named = random_paths(2, 3, family=["spiral"]), random_paths(2, 3, family="spiral")
    assert all(_same(p, q) for p, q in zip(listed, named, strict=True))  # one name: that name
    every = random_paths(6, 8, family=list(PATH_FAMILIES), length=0.02)
    assert all(_same(p, q) for p, q in zip(every, random_paths(6, 8, length=0.02), strict=True))


def _check_inside_and_smooth(path: Path, smooth: bool) -> None:
    s = np.unique(np.concatenate([np.linspace(0.0, path.length, 4001), path.table.s0]))
    pts = path.point(s)
    lo = np.array([WITHIN[0][0], WITHIN[1][0]]) + MARGIN
    hi = np.array([WITHIN[0][1], WITHIN[1][1]]) - MARGIN
    assert np.all(pts >= lo) and np.all(pts <= hi), (pts.min(axis=0), pts.max(axis=0))
    if smooth:  # no corner, no near-cusp: radius of curvature >= 0.1 % of the extent
        assert path.corners.size == 0
        radius = 1.0 / np.max(path.curvature(s))
        assert radius >= 1e-3 * np.ptp(pts, axis=0).max()


@pytest.mark.parametrize("family", PATH_FAMILIES)
def test_every_path_is_finite_long_enough_and_inside_the_box(family: str) -> None:
    lengths = []
    for seed in range(30):
        p = _draw(seed, family, within=WITHIN, margin=MARGIN, length=LENGTH)
        assert p.dim == 2 and p.name == f"random_{family}"
        assert np.all(np.isfinite(p.table.data)) and np.all(np.isfinite(p.table.s0))
        assert LENGTH[0] * (1 - 1e-9) <= p.length <= LENGTH[1] * (1 + 1e-9)
        _check_inside_and_smooth(p, family in SMOOTH)
        lengths.append(p.length)
    assert np.ptp(lengths) > 0.3 * (LENGTH[1] - LENGTH[0])  # drawn over the range
    fixed = _draw(0, family, within=(*WITHIN, (0.0, 0.1)), margin=MARGIN, length=0.05)
    assert fixed.length == pytest.approx(0.05, rel=1e-9)  # a z range is ignored


def _turns(path: Path) -> np.ndarray:
    """Turning angles at the corners, degrees."""
    c = path.corners
    before = path.evaluate(np.nextafter(c, 0.0))[1]
    after = path.tangent(c)
    cos = np.sum(before * after, axis=1) / np.linalg.norm(before, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def test_polyline_corners_span_sharp_to_shallow() -> None:
    turns = np.concatenate([_turns(_draw(seed, "polyline")) for seed in range(30)])
    assert turns.size > 100
    assert turns.max() > 165.0 and turns.min() < 6.0
    assert np.all((turns > 2.9) & (turns < 179.1))
    assert np.sum(turns < 20.0) > 10 and np.sum(turns > 90.0) > 10


def test_zigzag_turns_back_at_every_vertex_or_steps_aside() -> None:
    sharp = steps = 0
    for seed in range(30):
        p = _draw(seed, "zigzag")
        assert set(p.table.kind.tolist()) == {LINE}
        turns, legs = _turns(p), np.diff(p.table.s0)
        d = p.evaluate(p.table.s0[:-1])[1]  # each segment's direction
        cross = d[:-1, 0] * d[1:, 1] - d[:-1, 1] * d[1:, 0]  # > 0: the corner turns left
        sides, k = [], 0
        while k < turns.size:  # a vertex turns back (150 to 179.9 degrees) or steps aside
            if abs(turns[k] - 90.0) < 1e-6:  # a raster step: 90, a short segment, 90 alike
                assert abs(turns[k + 1] - 90.0) < 1e-6
                assert np.sign(cross[k + 1]) == np.sign(cross[k])
                assert legs[k + 1] < 0.3 * min(legs[k], legs[k + 2])  # 0.02-0.08 beside 0.3-1
                steps, k = steps + 1, k + 1
            else:
                assert 149.9 < turns[k] < 179.95, turns[k]
                sharp += 1
            sides.append(np.sign(cross[k]))
            k += 1
        # alternately left and right
        assert all(a != b for a, b in zip(sides[:-1], sides[1:], strict=True))
    assert sharp > 50 and steps > 10


def test_cam_joins_lines_and_arcs_tangentially_and_at_corners() -> None:
    tangent = corners = short = 0
    kinds: set[int] = set()
    for seed in range(30):
        p = _draw(seed, "cam")
        joins = p.table.s0[1:-1]
        at_corner = np.isin(joins, p.corners)
        tangent += int(np.sum(~at_corner))
        corners += int(np.sum(at_corner))
        smooth = joins[~at_corner]
        before = p.evaluate(np.nextafter(smooth, 0.0))[1]  # end of the segment before
        assert np.allclose(before, p.tangent(smooth), rtol=0.0, atol=1e-7)
        short += int(np.sum(np.diff(p.table.s0) < 0.05 * p.length / p.table.n_segments))
        kinds |= set(p.table.kind.tolist())
    assert tangent > 20 and corners > 20 and short > 0
    assert kinds == {LINE, HELIX}


def _compiles(fn: object) -> list[str]:
    with event.install_recorder("numba:compile") as rec:
        fn()  # type: ignore[operator]
    return [ev.data["dispatcher"].py_func.__qualname__ for _, ev in rec.buffer if ev.is_start]


def test_random_paths_run_in_the_servo_loop_without_recompiling() -> None:
    first = _draw(1, "spline", length=(0.03, 0.04))
    second = _draw(2, "cam", length=(0.06, 0.07), feed_range=(0.01, 0.03))
    assert first.table.n_segments != second.table.n_segments
    m1 = contour_gym.simulate(plant="xy_dc_servo", path=first)
    out: dict[str, float] = {}
    assert _compiles(lambda: out.update(contour_gym.simulate(plant="xy_dc_servo",
                                                             path=second))) == []
    for m in (m1, out):
        assert all(math.isfinite(v) for v in m.values()), m
        assert m["finished"] == 1.0 and m["failed"] == 0.0


@pytest.mark.parametrize("family", ["spline", "polyline", "cam"])
def test_feeds_are_drawn_per_block_within_the_range(family: str) -> None:
    lo, hi = 0.004, 0.02
    blocks = 0
    for seed in range(8):
        p = _draw(seed, family, feed_range=(lo, hi))
        assert isinstance(p, GcodePath)
        feeds = p.segment_feedrates
        assert np.all((feeds >= lo) & (feeds <= hi))
        assert np.all(np.diff(p.segment_lines) >= 0) and p.segment_lines[0] == 1
        # one feed per block: segments of one block share it
        for line in np.unique(p.segment_lines):
            assert np.ptp(feeds[p.segment_lines == line]) == 0.0
        blocks += int(p.segment_lines[-1])
        assert make_scenario("xy_dc_servo", p).feedrate == pytest.approx(feeds.max())
        assert _same(p, _draw(seed, family, feed_range=(lo, hi)))
    assert blocks > 8  # more than one block per path on the whole
    assert not isinstance(_draw(0, family), GcodePath)


@pytest.mark.parametrize(("kwargs", "word"), [
    ({"family": "meander"}, "meander"),
    ({"family": ["cam", "meander"]}, "meander"),
    ({"family": []}, r"\[\]"),
    ({"family": 3}, "3"),
    ({"length": (0.9, 2.0)}, "0.9"),
    ({"length": (0.1, 0.05)}, "0.05"),
    ({"length": math.nan}, "nan"),
    ({"length": -0.01}, "-0.01"),
    ({"within": ((0.0, math.inf), (0.0, 0.1))}, "within"),
    ({"within": ((0.1, 0.0), (0.0, 0.1))}, "within"),
    ({"within": ((0.0, 0.1),)}, "within"),
    ({"margin": 0.06}, "0.06"),
    ({"margin": math.nan}, "margin"),
    ({"feed_range": (0.03, 0.01)}, "0.03"),
    ({"feed_range": (0.0, 0.01)}, "feed_range"),
    ({"dim": 4}, "4"),
])
def test_bad_input_raises_value_error_naming_it(kwargs: dict, word: str) -> None:
    with pytest.raises(ValueError, match=word):
        random_path(np.random.default_rng(0), **kwargs)


def test_bad_generator_and_3d() -> None:
    for rng in (0, np.random.RandomState(0), None):
        with pytest.raises(ValueError, match="Generator"):
            random_path(rng)  # type: ignore[arg-type]
    with pytest.raises(NotImplementedError, match="2-D"):
        random_path(np.random.default_rng(0), dim=3)
    with pytest.raises(ValueError, match="-1"):
        random_paths(0, -1)


def test_curves_near_a_cusp_are_refused_and_lengths_are_exact() -> None:
    from contour_gym.paths._random import _smooth_shape

    def build(k: float) -> Path:
        raise AssertionError("not built")

    def astroid(t: np.ndarray) -> np.ndarray:  # cusps where |dP/dt| = 0
        return np.stack([np.cos(t) ** 3, np.sin(t) ** 3], axis=1)

    def d_astroid(t: np.ndarray) -> np.ndarray:
        return np.stack([-3 * np.cos(t) ** 2 * np.sin(t), 3 * np.sin(t) ** 2 * np.cos(t)], axis=1)

    breaks = np.linspace(0.0, 2 * math.pi, 5)
    assert _smooth_shape(astroid, d_astroid, breaks, build) is None
    ellipse = _smooth_shape(lambda t: np.stack([np.cos(t), 0.5 * np.sin(t)], axis=1),
                            lambda t: np.stack([-np.sin(t), 0.5 * np.cos(t)], axis=1),
                            breaks, build)
    assert ellipse is not None
    assert ellipse.length == pytest.approx(4.844224110273838, rel=1e-13)  # 4 E(3/4)
