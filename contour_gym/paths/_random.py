"""Random paths: a world of contours to train and test controllers on.

:func:`random_path` draws one path from a :class:`numpy.random.Generator` (never the global
random state): the same generator state gives the same path bit for bit. Families
(:data:`PATH_FAMILIES`; ``family=None`` draws one uniformly, a sequence of names one of them
uniformly, so a name given twice is drawn twice as often):

* ``"spline"``: a cubic B-spline (:func:`~contour_gym.paths.bspline`) on 5 or more control
  points from a random walk (below, turns up to 100 degrees); open (clamped knots) or closed
  (uniform knots, control points wrapped round), drawn with equal odds.
* ``"lissajous"``: ``(sin(a t + d), e sin(b t))``, ``t`` over one period, coprime ``a != b``,
  random phase ``d`` and aspect ``e`` in [0.5, 1] (closed; :func:`~contour_gym.paths.parametric`).
* ``"rose"``: the offset rose ``rho = (c + cos(k theta)) / (1 + c)``, ``k >= 2``, ``c`` in
  [0.1, 0.5] (big petals with small inner loops, closed; never through the origin's cusp).
* ``"spiral"``: an Archimedean spiral ``rho = r0 + (1 - r0) theta / Theta`` over 1 or more
  turns, ``r0`` in [0.05, 0.4], squashed by [0.6, 1] along y, run inwards or outwards (open).
* ``"polyline"``: a random walk of 3 or more straight segments of random length (uniform, 0.2
  to 1) with corners turning log-uniformly from 3 degrees (shallow) to 179 degrees (nearly a
  reversal), left or right; a walk that strays 2 units from its start turns back towards it.
* ``"zigzag"``: engraving strokes and zig-zag fills: 3 or more legs (uniform, 0.3 to 1) turning
  back at every vertex, alternately left and right, by 150 to 179.9 degrees (uniform); with odds
  1/3 a vertex is a raster step instead, a short segment (2 to 8 % of a unit) between two
  90-degree corners, so that the legs on either side run back side by side.
* ``"cam"``: lines and arcs as CAM output joins them: a polyline (some segments short, 2 to 8 %)
  whose inner vertices get, with even odds, a tangent arc fillet or stay corners; segments
  between two corners become bulged arcs (non-tangent at both ends) with odds 0.3.

The parametric and spline curves are rejected and redrawn when they come near a cusp: their
speed ``|dP/dt|`` drops below 5 % of its mean, or their radius of curvature below 0.2 % of
their larger extent, somewhere.

Size and placement: the path length is drawn uniformly from ``length`` (default 20 to 200 mm).
A shape is drawn in a unit frame (its complexity, e.g. the number of segments or lobes, grows
with the ratio of that length to the travel box), given a random rotation (uniform angle) and a
mirror (odds 0.5), scaled to the drawn length and moved to a uniformly random position where
it lies inside ``within`` less ``margin`` on every side. A shape that does not fit is redrawn
(the length is kept). Lengths over :data:`MAX_RATIO` times the smaller side of the usable box
are refused.

Feeds: with ``feed_range`` the path is a :class:`~contour_gym.paths.GcodePath`, as read from a
G-code program, whose blocks each carry a programmed feedrate drawn uniformly from the range
(``segment_feedrates``; ``segment_lines`` numbers the blocks from 1). A block is one line or
arc (polyline, cam) or a run of consecutive quintic spans of a free-form curve (1 to 4 runs cut
at random span boundaries). :func:`contour_gym.make_scenario` runs such a path at its own feeds
(its nominal feedrate is the highest one), exactly as a G-code part.

Only 2-D paths are drawn; ``dim=3`` raises NotImplementedError. Cost: a polyline, cam or
zigzag path takes milliseconds; the smooth families 0.04 to 0.2 s on one core (the fit of their
quintic spans and the clearances of their search rows).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import legendre
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array, finite
from contour_gym.paths._freeform import bspline, parametric
from contour_gym.paths._gcode_path import GcodePath
from contour_gym.paths._geom import POLY5
from contour_gym.paths._path import Path
from contour_gym.paths._primitives import arc, composite, line, polyline

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Curve = Callable[[FloatArray], FloatArray]

PATH_FAMILIES = ("spline", "lissajous", "rose", "spiral", "polyline", "cam", "zigzag")
DEFAULT_WITHIN = ((-0.05, 0.05), (-0.05, 0.05))  # travel box, m
DEFAULT_LENGTH = (0.02, 0.2)  # path length range, m
DEFAULT_MARGIN = 0.002  # free border inside the travel box, m
MAX_RATIO = 6.0  # longest path: this many times the smaller side of the usable box
MIN_SPEED = 0.05  # smooth curves: min |dP/dt| at least this fraction of its mean
MIN_RADIUS = 0.002  # smooth curves: min radius of curvature, fraction of the larger extent
ATTEMPTS = 60  # shapes drawn before giving up on fitting one into the box
_SLACK = 1e-3  # fraction of the usable box left free for the sampling error of the extents
_WALK_RADIUS = 2.0  # random walks: distance from the start beyond which they turn back
_N_SAMPLES = 8192  # samples of a smooth curve (extents, speed check)
_GX, _GW = legendre.leggauss(10)
_GX = 0.5 * (_GX + 1.0)
_GW = 0.5 * _GW


@dataclass(frozen=True)
class _Shape:
    """A shape in its unit frame: samples of its points, its length and its builder.

    Attributes:
        samples: (N, 2) points of the curve dense enough to bound its extent.
        length: Arc length in the unit frame.
        build: The path scaled by a factor about the unit frame's origin.
    """

    samples: FloatArray
    length: float
    build: Callable[[float], Path]


Maker = Callable[[np.random.Generator, float], _Shape | None]


# smooth curves -------------------------------------------------------------------------------


def _arc_length(speed: Curve, breaks: FloatArray) -> float:
    """Integral of ``speed`` over [breaks[0], breaks[-1]].

    10-point Gauss-Legendre rules on 16 equal parts of every interval between breaks (keep the
    breaks on the curve's knots).
    """
    edges = np.unique(np.concatenate(
        [np.linspace(a, b, 17) for a, b in zip(breaks[:-1], breaks[1:], strict=True)]))
    width = np.diff(edges)
    nodes = edges[:-1, None] + width[:, None] * _GX[None, :]
    return float(np.sum((speed(nodes.ravel()).reshape(nodes.shape) @ _GW) * width))


def _smooth_shape(fn: Curve, dfn: Curve, breaks: FloatArray,
                  build: Callable[[float], Path]) -> _Shape | None:
    """A smooth curve ``fn`` on [breaks[0], breaks[-1]]; None if it nearly has a cusp.

    Near-cusps: the speed ``|dP/dt|`` drops below :data:`MIN_SPEED` of its mean, or the radius
    of curvature below :data:`MIN_RADIUS` of the curve's larger extent (curvature from
    ``dfn`` and its finite differences on the samples).
    """
    t = np.linspace(breaks[0], breaks[-1], _N_SAMPLES)
    d1 = dfn(t)
    speed = np.linalg.norm(d1, axis=1)
    if speed.min() < MIN_SPEED * speed.mean():
        return None
    d2 = np.gradient(d1, t, axis=0)
    kappa = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / speed**3
    points = fn(t)
    if kappa.max() * MIN_RADIUS * float(np.ptp(points, axis=0).max()) > 1.0:
        return None

    def norm(u: FloatArray) -> FloatArray:
        out: FloatArray = np.linalg.norm(dfn(u), axis=1)
        return out

    return _Shape(points, _arc_length(norm, breaks), build)


def _parametric_shape(fn: Curve, dfn: Curve, t_end: float) -> _Shape | None:
    """A smooth curve on [0, t_end] built with :func:`parametric`."""
    def build(k: float) -> Path:
        return parametric(lambda t: k * fn(t), 0.0, t_end)

    return _smooth_shape(fn, dfn, np.linspace(0.0, t_end, 65), build)


def _spline(rng: np.random.Generator, need: float) -> _Shape | None:
    """A cubic B-spline on the vertices of a random walk, open or closed."""
    n = int(rng.integers(5, 8 + math.ceil(10.0 * need)))
    ctrl = _walk(rng, n - 1, 100.0, 0.0)[0]
    deg = 3
    if rng.integers(2):  # closed: uniform knots, the first control points repeated
        ctrl = np.concatenate([ctrl, ctrl[:deg]])
        knots = np.arange(ctrl.shape[0] + deg + 1, dtype=np.float64)
    else:
        knots = np.concatenate([np.zeros(deg), np.linspace(0.0, 1.0, n - deg + 1), np.ones(deg)])
    from scipy.interpolate import BSpline  # here: its import took 0.19-0.23 s

    spl = BSpline(knots, ctrl, deg)
    breaks = np.unique(knots[deg:ctrl.shape[0] + 1])

    def build(k: float) -> Path:
        return bspline(k * ctrl, knots, deg)

    return _smooth_shape(spl, spl.derivative(), breaks, build)


def _lissajous(rng: np.random.Generator, need: float) -> _Shape | None:
    """A Lissajous figure of coprime frequencies, random phase and aspect."""
    top = 3 + math.ceil(1.5 * need)
    pairs = [(a, b) for a in range(1, top + 1) for b in range(1, top + 1)
             if a != b and math.gcd(a, b) == 1]
    a, b = pairs[int(rng.integers(len(pairs)))]
    phase = rng.uniform(0.0, 2.0 * math.pi)
    aspect = rng.uniform(0.5, 1.0)

    def fn(t: FloatArray) -> FloatArray:
        return np.stack([np.sin(a * t + phase), aspect * np.sin(b * t)], axis=1)

    def dfn(t: FloatArray) -> FloatArray:
        return np.stack([a * np.cos(a * t + phase), aspect * b * np.cos(b * t)], axis=1)

    return _parametric_shape(fn, dfn, 2.0 * math.pi)


def _polar(rho: Curve, drho: Curve, squash: float = 1.0) -> tuple[Curve, Curve]:
    """Point and derivative of the polar curve ``rho(theta)``, y scaled by ``squash``."""
    def fn(t: FloatArray) -> FloatArray:
        return rho(t)[:, None] * np.stack([np.cos(t), squash * np.sin(t)], axis=1)

    def dfn(t: FloatArray) -> FloatArray:
        r, dr = rho(t), drho(t)
        c, s = np.cos(t), np.sin(t)
        return np.stack([dr * c - r * s, squash * (dr * s + r * c)], axis=1)

    return fn, dfn


def _rose(rng: np.random.Generator, need: float) -> _Shape | None:
    """An offset rose: petals with inner loops, clear of the cusp at the origin."""
    k = int(rng.integers(2, 4 + math.ceil(2.0 * need)))
    c = rng.uniform(0.1, 0.5)
    fn, dfn = _polar(lambda t: (c + np.cos(k * t)) / (1.0 + c),
                     lambda t: -k * np.sin(k * t) / (1.0 + c))
    return _parametric_shape(fn, dfn, 2.0 * math.pi)


def _spiral(rng: np.random.Generator, need: float) -> _Shape | None:
    """An Archimedean spiral squashed along y, run outwards or inwards."""
    end = 2.0 * math.pi * rng.uniform(1.0, 1.5 + need)
    r0 = rng.uniform(0.05, 0.4)
    squash = rng.uniform(0.6, 1.0)
    sign = 1.0 if rng.integers(2) else -1.0  # outwards or inwards
    start = 0.0 if sign > 0 else end
    grow = (1.0 - r0) / end
    fn0, dfn0 = _polar(lambda t: r0 + grow * t, lambda t: np.full_like(t, grow), squash)
    return _parametric_shape(lambda u: fn0(start + sign * u),
                             lambda u: sign * dfn0(start + sign * u), end)


# lines and arcs ------------------------------------------------------------------------------


def _walk(rng: np.random.Generator, n: int, max_turn_deg: float, short_odds: float
          ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Vertices (n + 1, 2), segment lengths (n,) and signed turns (n - 1,) of a random walk.

    Segment lengths are uniform in [0.2, 1], or with ``short_odds`` in [0.02, 0.08]; turns are
    log-uniform in [3, max_turn_deg] degrees, left or right with even odds, except that a
    walk more than :data:`_WALK_RADIUS` from its start turns back towards it (so that a long
    walk stays compact).
    """
    seg = rng.uniform(0.2, 1.0, n)
    short = rng.random(n) < short_odds
    seg[short] = rng.uniform(0.02, 0.08, int(short.sum()))
    size = np.radians(np.exp(rng.uniform(math.log(3.0), math.log(max_turn_deg), n - 1)))
    side = rng.choice([-1.0, 1.0], n - 1)
    pts = np.zeros((n + 1, 2))
    heading = 0.0
    turn = np.zeros(n - 1)
    for j in range(n):
        if j > 0:
            p = pts[j]
            out = math.cos(heading) * p[0] + math.sin(heading) * p[1] > 0.0
            if out and math.hypot(p[0], p[1]) > _WALK_RADIUS:  # turn towards the start
                side[j - 1] = -1.0 if math.cos(heading) * p[1] > math.sin(heading) * p[0] \
                    else 1.0
            turn[j - 1] = side[j - 1] * size[j - 1]
            heading += turn[j - 1]
        pts[j + 1] = pts[j] + seg[j] * np.array([math.cos(heading), math.sin(heading)])
    return pts, seg, turn


def _polyline(rng: np.random.Generator, need: float) -> _Shape | None:
    """A random walk of straight segments."""
    n = int(rng.integers(3, 5 + math.ceil(10.0 * need)))
    pts, seg, _ = _walk(rng, n, 179.0, 0.0)

    def build(k: float) -> Path:
        return polyline(k * pts)

    return _Shape(pts, float(seg.sum()), build)


@dataclass(frozen=True)
class _Piece:
    """A line or an arc in the unit frame.

    A line (``radius`` 0) runs from ``a`` to ``b``; an arc has centre ``a``, ``radius``,
    ``start`` angle and signed ``sweep`` and ends at ``b``.
    """

    a: FloatArray
    b: FloatArray
    radius: float = 0.0
    start: float = 0.0
    sweep: float = 0.0

    def build(self, k: float) -> Path:
        if self.radius == 0.0:
            return line(k * self.a, k * self.b)
        return arc(k * self.a, k * self.radius, self.start, self.sweep)

    def samples(self) -> FloatArray:
        if self.radius == 0.0:
            return np.stack([self.a, self.b])
        ang = self.start + self.sweep * np.linspace(0.0, 1.0, 65)
        return self.a + self.radius * np.stack([np.cos(ang), np.sin(ang)], axis=1)

    @property
    def length(self) -> float:
        if self.radius == 0.0:
            return float(np.linalg.norm(self.b - self.a))
        return self.radius * abs(self.sweep)


def _arc_piece(p: FloatArray, q: FloatArray, sweep: float) -> _Piece:
    """The arc from ``p`` to ``q`` turning ``sweep`` (signed, |sweep| < pi)."""
    chord = q - p
    half = float(np.linalg.norm(chord)) / 2.0
    radius = half / math.sin(abs(sweep) / 2.0)
    left = np.array([-chord[1], chord[0]]) / (2.0 * half)
    centre = 0.5 * (p + q) + math.copysign(radius * math.cos(sweep / 2.0), sweep) * left
    start = math.atan2(p[1] - centre[1], p[0] - centre[0])
    return _Piece(centre, q, radius, start, sweep)


def _cam_pieces(rng: np.random.Generator, pts: FloatArray, seg: FloatArray,
                turn: FloatArray) -> list[_Piece]:
    """Lines and arcs along the walk: fillets at some vertices, bulges on some segments."""
    n = seg.shape[0]
    fillet = np.concatenate([[False], rng.random(n - 1) < 0.5, [False]])
    trim = np.zeros(n + 1)  # tangent length of the fillet at each vertex
    room = 0.45 * np.minimum(seg[:-1], seg[1:])
    trim[1:-1] = np.where(fillet[1:-1], rng.uniform(0.3, 1.0, n - 1) * room, 0.0)
    bulge = np.less(rng.random(n), 0.3)
    pieces: list[_Piece] = []
    for j in range(n):
        d = (pts[j + 1] - pts[j]) / seg[j]
        a, b = pts[j] + trim[j] * d, pts[j + 1] - trim[j + 1] * d
        if j > 0 and fillet[j]:
            pieces.append(_arc_piece(pieces[-1].b, a, float(turn[j - 1])))
        if bulge[j] and not (fillet[j] or fillet[j + 1]):
            pieces.append(_arc_piece(a, b, math.radians(rng.uniform(20.0, 90.0))
                                     * rng.choice([-1.0, 1.0])))
        else:
            pieces.append(_Piece(a, b))
    return pieces


def _cam(rng: np.random.Generator, need: float) -> _Shape | None:
    """Lines and arcs along a random walk, joined tangentially or at corners."""
    n = int(rng.integers(3, 6 + math.ceil(10.0 * need)))
    pieces = _cam_pieces(rng, *_walk(rng, n, 120.0, 0.2))

    def build(k: float) -> Path:
        return composite([p.build(k) for p in pieces])

    return _Shape(np.concatenate([p.samples() for p in pieces]),
                  float(sum(p.length for p in pieces)), build)


def _zigzag(rng: np.random.Generator, need: float) -> _Shape | None:
    """Legs turning back at every vertex, alternately left and right, or raster steps."""
    n = int(rng.integers(3, 5 + math.ceil(6.0 * need)))
    legs = rng.uniform(0.3, 1.0, n)
    side = 1.0 if rng.integers(2) else -1.0
    pts = [np.zeros(2)]
    heading = 0.0
    for j in range(n):
        if j > 0:
            side = -side
            if rng.random() < 1.0 / 3.0:  # a raster step: 90, a short segment, 90
                heading += side * 0.5 * math.pi
                step = rng.uniform(0.02, 0.08)
                pts.append(pts[-1] + step * np.array([math.cos(heading), math.sin(heading)]))
                heading += side * 0.5 * math.pi
            else:
                heading += side * math.radians(rng.uniform(150.0, 179.9))
        pts.append(pts[-1] + legs[j] * np.array([math.cos(heading), math.sin(heading)]))
    vertices = np.array(pts)
    length = float(np.sum(np.linalg.norm(np.diff(vertices, axis=0), axis=1)))

    def build(k: float) -> Path:
        return polyline(k * vertices)

    return _Shape(vertices, length, build)


_MAKERS: dict[str, Maker] = {
    "spline": _spline, "lissajous": _lissajous, "rose": _rose, "spiral": _spiral,
    "polyline": _polyline, "cam": _cam, "zigzag": _zigzag,
}


# placement and feeds -------------------------------------------------------------------------


def _orientation(rng: np.random.Generator) -> FloatArray:
    """A uniformly random rotation, mirrored (y -> -y first) with odds 0.5."""
    angle = rng.uniform(0.0, 2.0 * math.pi)
    c, s = math.cos(angle), math.sin(angle)
    mirror = np.diag([1.0, -1.0 if rng.integers(2) else 1.0])
    return np.array([[c, -s], [s, c]]) @ mirror


def _placed(rng: np.random.Generator, family: str, target: float, box: FloatArray) -> Path:
    """A shape of ``family`` scaled to ``target`` length at a random place inside ``box``."""
    size = box[:, 1] - box[:, 0]
    need = target / float(size.min())
    for attempt in range(ATTEMPTS):
        shape = _MAKERS[family](rng, need * min(1.05**attempt, 2.0))
        if shape is None:
            continue
        rot = _orientation(rng)
        scale = target / shape.length
        pts = scale * (shape.samples @ rot.T)
        low, high = pts.min(axis=0), pts.max(axis=0)
        room = size - (high - low)
        if np.all(room >= 0.0):
            offset = box[:, 0] - low + rng.uniform(0.0, 1.0, 2) * room
            return shape.build(scale).transformed(rot, offset)
    raise ValueError(f"could not fit a {family} path of length {target!r} m into the box "
                     f"{box.tolist()} m (less margin) in {ATTEMPTS} attempts")


def _blocks(rng: np.random.Generator, path: Path) -> IntArray:
    """Block index (from 0) of each table segment: one per line or arc, 1 to 4 per curve."""
    n = path.table.n_segments
    if not np.all(path.table.kind == POLY5):
        return np.arange(n, dtype=np.int64)
    count = min(int(rng.integers(1, 5)), n)
    cuts = np.sort(rng.choice(np.arange(1, n), count - 1, replace=False))
    return np.searchsorted(cuts, np.arange(n), side="right").astype(np.int64)


def _with_feeds(rng: np.random.Generator, path: Path, feeds: tuple[float, float],
                name: str) -> GcodePath:
    """``path`` as a G-code part whose blocks have feedrates drawn from ``feeds``."""
    blocks = _blocks(rng, path)
    rate = rng.uniform(feeds[0], feeds[1], int(blocks[-1]) + 1)
    return GcodePath(path.table, name, rate[blocks], blocks + 1,
                     np.zeros(blocks.shape[0], dtype=bool))


# input checks --------------------------------------------------------------------------------


def _range(value: Any, name: str, default: tuple[float, float] | None = None
           ) -> tuple[float, float] | None:
    """``(lo, hi)`` with ``0 < lo <= hi`` finite; a scalar is ``(v, v)``; None: ``default``."""
    if value is None:
        return default
    arr = as_finite_array(value, name)
    if arr.ndim == 0:
        arr = np.array([arr, arr])
    if arr.shape != (2,) or not 0.0 < arr[0] <= arr[1]:
        raise ValueError(f"{name} must be a number or a pair (lo, hi) with 0 < lo <= hi, "
                         f"got {value!r}")
    return float(arr[0]), float(arr[1])


def _usable_box(within: ArrayLike | None, margin: float) -> FloatArray:
    """The x-y box, (2, 2), that a path may use: ``within`` less the margin and a slack."""
    box = as_finite_array(DEFAULT_WITHIN if within is None else within, "within")
    if box.ndim != 2 or box.shape[0] not in (2, 3) or box.shape[1] != 2:
        raise ValueError(f"within must be ((x_lo, x_hi), (y_lo, y_hi)[, (z_lo, z_hi)]) in m, "
                         f"got {within!r}")
    if np.any(box[:, 1] <= box[:, 0]):
        raise ValueError(f"within must have lo < hi on every axis, got {within!r}")
    free = finite(margin, "margin")
    if free < 0.0:
        raise ValueError(f"margin must be >= 0, got {margin!r}")
    xy = box[:2] + np.array([free, -free])
    if np.any(xy[:, 1] <= xy[:, 0]):
        raise ValueError(f"margin {margin!r} m leaves no room inside within = {within!r}")
    slack = _SLACK * (xy[:, 1] - xy[:, 0])
    return xy + np.stack([slack, -slack], axis=1)


def _check_rng(rng: Any) -> None:
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {rng!r}")


def _families(family: Any) -> tuple[str, ...]:
    """The families one is drawn from (uniformly): all for None, ``(family,)`` for a name."""
    if family is None:
        return PATH_FAMILIES
    names = (family,) if isinstance(family, str) else family
    if not isinstance(names, (tuple, list)) or not names or any(
            not isinstance(name, str) or name not in PATH_FAMILIES for name in names):
        raise ValueError(f"unknown family {family!r}; choose from {', '.join(PATH_FAMILIES)}, "
                         "a non-empty list of them, or None")
    return tuple(names)


def _check_dim(dim: Any) -> None:
    if isinstance(dim, bool) or dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    if dim == 3:
        raise NotImplementedError("random_path draws 2-D paths only (dim=2)")


# public API ----------------------------------------------------------------------------------


def random_path(rng: np.random.Generator, family: str | Sequence[str] | None = None, *,
                within: ArrayLike | None = None, dim: int = 2,
                length: float | tuple[float, float] | None = None,
                feed_range: tuple[float, float] | None = None,
                margin: float = DEFAULT_MARGIN) -> Path:
    """Draw one random path (see the module documentation for the families and placement).

    Args:
        rng: The generator every random number comes from.
        family: One of :data:`PATH_FAMILIES`; a list or tuple of them to draw one uniformly
            (repeat a name to weight it; a list of one name is that name); None: all of them
            (the same draws as ``PATH_FAMILIES`` given as the list).
        within: Travel box ``((x_lo, x_hi), (y_lo, y_hi)[, (z_lo, z_hi)])``, m; the z range is
            ignored. Default +-50 mm in x and y.
        dim: 2 (3 raises NotImplementedError).
        length: Path length, m: ``(lo, hi)`` draws it uniformly, a number fixes it. Default
            20 to 200 mm. The built length matches the draw to about 1e-12 relative.
        feed_range: ``(f_lo, f_hi)``, m/s: draw a programmed feedrate per block and return a
            :class:`~contour_gym.paths.GcodePath` carrying them. None: a plain path.
        margin: Free border inside ``within`` that no point of the path enters, m (2 mm).

    Returns:
        The path, named ``"random_<family>"``.

    Raises:
        ValueError: naming the value, for a non-Generator ``rng``, an unknown family or a bad
            list of them, a non-finite or misshaped box, length, feed range or margin, a length
            over :data:`MAX_RATIO` times the smaller usable side, or a shape that did not fit.
        NotImplementedError: for ``dim=3``.

    >>> p = random_path(np.random.default_rng(7), "cam", length=0.1)
    >>> p.name, round(p.length, 12)
    ('random_cam', 0.1)
    """
    _check_rng(rng)
    families = _families(family)
    _check_dim(dim)
    box = _usable_box(within, margin)
    lo, hi = _range(length, "length", DEFAULT_LENGTH) or DEFAULT_LENGTH
    feeds = _range(feed_range, "feed_range")
    side = float(np.min(box[:, 1] - box[:, 0]))
    if lo > MAX_RATIO * side:
        raise ValueError(f"length {length!r} m cannot fit within {within!r}: its lower bound "
                         f"is over {MAX_RATIO:g} x the usable side {side:.6g} m")
    name = families[0] if len(families) == 1 else families[int(rng.integers(len(families)))]
    target = lo if lo == hi else float(rng.uniform(lo, hi))
    path = _placed(rng, name, target, box)
    if feeds is None:
        return Path(path.table, f"random_{name}")
    return _with_feeds(rng, path, feeds, f"random_{name}")


def random_paths(seed: int, n: int, **kwargs: Any) -> list[Path]:
    """``n`` paths drawn one after the other from ``np.random.default_rng(seed)``.

    Args:
        seed: Seed of the generator.
        n: Number of paths (>= 0).
        **kwargs: Arguments of :func:`random_path` (``family``, ``within``, ``length``, ...).

    Raises:
        ValueError: for a bad ``n`` and as :func:`random_path`.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"n must be an int >= 0, got {n!r}")
    rng = np.random.default_rng(seed)
    return [random_path(rng, **kwargs) for _ in range(int(n))]


__all__ = ["MAX_RATIO", "PATH_FAMILIES", "random_path", "random_paths"]
