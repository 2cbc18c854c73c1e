"""Lines, arcs, circles, polylines, helices and composites."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array, finite, positive
from contour_gym.paths._geom import HELIX, LINE
from contour_gym.paths._path import Path
from contour_gym.paths._table import concat_tables, line_row, make_table, split_helix

FloatArray = NDArray[np.float64]

JOIN_TOL = 1e-9  # composite: consecutive ends must meet within this, m
_EZ = np.array([0.0, 0.0, 1.0])


def _point(value: ArrayLike, name: str) -> FloatArray:
    arr = as_finite_array(value, name, ndim=1)
    if arr.shape[0] not in (2, 3):
        raise ValueError(f"{name} must be a 2-D or 3-D point, got shape {arr.shape}")
    return arr


def _pad3(p: FloatArray) -> FloatArray:
    out = np.zeros(3)
    out[: p.shape[0]] = p
    return out


def line(start: ArrayLike, end: ArrayLike) -> Path:
    """A straight segment.

    Args:
        start: Start point (2,) or (3,), m.
        end: End point, same dimension, m.

    Returns:
        The line as a path.

    Raises:
        ValueError: on non-finite or misshaped points, or if start == end.
    """
    a = _point(start, "start")
    b = _point(end, "end")
    if a.shape != b.shape:
        raise ValueError(f"start and end must have the same dimension, got {a.shape} and {b.shape}")
    if np.array_equal(a, b):
        raise ValueError(f"line has zero length: start == end == {a.tolist()}")
    length, row = line_row(_pad3(a), _pad3(b))
    return Path(make_table([LINE], [length], row, a.shape[0]), "line")


def polyline(points: ArrayLike) -> Path:
    """Straight segments through ``points`` with sharp corners at the inner points.

    Args:
        points: (N, 2) or (N, 3) vertices, N >= 2, consecutive vertices distinct, m.

    Returns:
        The polyline as a path; ``corners`` lists the vertices where the direction changes.

    Raises:
        ValueError: on non-finite or misshaped points, fewer than two, or a repeated vertex.
    """
    pts = as_finite_array(points, "points", ndim=2)
    if pts.shape[0] < 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (N >= 2, 2 or 3), got {pts.shape}")
    dim = pts.shape[1]
    p3 = np.zeros((pts.shape[0], 3))
    p3[:, :dim] = pts
    lengths = []
    rows = []
    for i in range(pts.shape[0] - 1):
        if np.array_equal(p3[i], p3[i + 1]):
            raise ValueError(f"points[{i + 1}] repeats points[{i}] = {pts[i].tolist()}")
        length, row = line_row(p3[i], p3[i + 1])
        lengths.append(length)
        rows.append(row)
    return Path(make_table([LINE] * len(rows), lengths, np.array(rows), dim), "polyline")


def arc(center: ArrayLike, radius: float, start_angle: float, sweep: float) -> Path:
    """A 2-D circular arc.

    Args:
        center: Centre (2,), m.
        radius: Radius > 0, m.
        start_angle: Polar angle of the start point about the centre, rad.
        sweep: Signed angle turned, rad; positive is counter-clockwise; 0 < |sweep| <= 2 pi.

    Returns:
        The arc as a path (one segment).

    Raises:
        ValueError: on a bad centre, radius <= 0, zero sweep or a sweep over a full turn.
    """
    c = as_finite_array(center, "center", shape=(2,))
    r = positive(radius, "radius")
    a0 = finite(start_angle, "start_angle")
    sw = finite(sweep, "sweep")
    if sw == 0.0 or abs(sw) > 2.0 * math.pi * (1.0 + 1e-12):
        raise ValueError(f"sweep must satisfy 0 < |sweep| <= 2 pi, got {sweep!r}")
    return _arc_path(c, r, a0, sw, "arc")


def _arc_path(center2: FloatArray, radius: float, a0: float, sweep: float, name: str) -> Path:
    e1 = np.array([math.cos(a0), math.sin(a0), 0.0])
    e2 = np.cross(_EZ, e1)
    lengths, rows = split_helix(_pad3(center2), e1, e2, radius, sweep, 0.0)
    return Path(make_table([HELIX], lengths, rows[0], 2), name)


def circle(radius: float, center: ArrayLike = (0.0, 0.0), start_angle: float = 0.0) -> Path:
    """A full counter-clockwise 2-D circle (closed, one segment).

    Args:
        radius: Radius > 0, m.
        center: Centre (2,), m.
        start_angle: Polar angle of the start (and end) point, rad.

    Returns:
        The circle as a path of length ``2 pi radius``.

    Raises:
        ValueError: on radius <= 0 or a bad centre.
    """
    c = as_finite_array(center, "center", shape=(2,))
    r = positive(radius, "radius")
    a0 = finite(start_angle, "start_angle")
    return _arc_path(c, r, a0, 2.0 * math.pi, "circle")


def helix(radius: float, pitch: float, turns: float, center: ArrayLike = (0.0, 0.0, 0.0),
          start_angle: float = 0.0) -> Path:
    """A 3-D helix about the z axis, counter-clockwise seen from +z.

    The path starts at ``center + radius (cos a0, sin a0, 0)`` and rises ``pitch`` per turn.
    Its length is ``turns sqrt((2 pi radius)^2 + pitch^2)``. It is stored as pieces of at most a
    quarter turn (tighter bounding spheres for the nearest-point search).

    Args:
        radius: Radius > 0, m.
        pitch: Rise per turn, m; negative descends. Zero is rejected: a flat circle is
            ``circle``/``arc`` (2-D) or a G-code ``G2``/``G3`` in 3-D.
        turns: Number of turns > 0 (fractional allowed).
        center: Axis point at the start height (3,), m.
        start_angle: Polar angle of the start point, rad.

    Returns:
        The helix as a 3-D path.

    Raises:
        ValueError: on radius <= 0, pitch == 0, turns <= 0 or a bad centre.
    """
    r = positive(radius, "radius")
    p = finite(pitch, "pitch")
    if p == 0.0:
        raise ValueError("pitch must be non-zero, got 0; use circle() or arc() for a flat circle")
    n = positive(turns, "turns")
    c = as_finite_array(center, "center", shape=(3,))
    a0 = finite(start_angle, "start_angle")
    e1 = np.array([math.cos(a0), math.sin(a0), 0.0])
    e2 = np.cross(_EZ, e1)
    lengths, rows = split_helix(c, e1, e2, r, 2.0 * math.pi * n, p * n)
    return Path(make_table([HELIX] * len(rows), lengths, np.array(rows), 3), "helix")


def composite(segments: Sequence[Path]) -> Path:
    """Paths joined end to end.

    Args:
        segments: Paths of one dimension; each must start where the previous one ends
            (within 1e-9 m). Tangent jumps at the joins become corners.

    Returns:
        The joined path.

    Raises:
        ValueError: on an empty list, a non-Path item, mixed dimensions, or a gap (naming the
            index of the segment that does not start where the previous one ends).
    """
    items = list(segments)
    if not items:
        raise ValueError("composite needs at least one segment, got none")
    for i, seg in enumerate(items):
        if not isinstance(seg, Path):
            raise ValueError(f"segments[{i}] must be a Path, got {type(seg).__name__}")
        if seg.dim != items[0].dim:
            raise ValueError(f"segments[{i}] has dim {seg.dim}, segments[0] has {items[0].dim}")
    for i in range(1, len(items)):
        gap = float(np.linalg.norm(items[i].point(0.0) - items[i - 1].point(items[i - 1].length)))
        if gap > JOIN_TOL:
            raise ValueError(f"segments[{i}] starts {gap:.3g} m away from the end of "
                             f"segments[{i - 1}] (tolerance {JOIN_TOL:g} m)")
    return Path(concat_tables([seg.table for seg in items]), "composite")
