"""The compiled path representation (:class:`PathTable`) and the builders of its rows."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym.jit.stack import on_reserved_stack
from contour_gym.paths import _batch
from contour_gym.paths._branch import B_CLEAR, B_CLOSED, N_CELLS, NB, build_rows, fill_clearances
from contour_gym.paths._geom import HELIX, LINE, NCOL, POLY5

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def _frozen(arr: Any, dtype: type) -> Any:
    out: NDArray[Any] = np.array(arr, dtype=dtype, order="C", copy=True)
    out.flags.writeable = False
    return out


def build_bound(kind: IntArray, s0: FloatArray, data: FloatArray, spheres: FloatArray
                ) -> FloatArray:
    """A table's ``bound`` rows (:mod:`contour_gym.paths._branch`) from its segments' spheres.

    ``spheres``: each segment's bounding sphere ``(n, 4)``, centre xyz and radius (m).
    ``kind``, ``s0`` and ``data`` read-only, as a :class:`~contour_gym.paths.PathTable` holds
    them: the clearances are searched on a read-only view of the other rows, so the searches
    compile once for the tables and the servo loop alike (the same array types).
    """
    bound = build_rows(kind, s0, data, spheres)
    rows = bound.view()
    rows.flags.writeable = False
    n = kind.shape[0]
    clear = np.zeros((n, N_CELLS))
    fill_clearances(kind, s0, data, rows, clear)
    bound[:n, B_CLEAR:] = clear
    return bound


@dataclass(frozen=True, eq=False)
class PathTable:
    """Contiguous, read-only arrays describing a path for the compiled kernels.

    Attributes:
        kind: Segment kinds (n,): 0 = LINE, 1 = HELIX (plain arcs have zero rise), 2 = POLY5.
        s0: Cumulative arc length at each segment start (n + 1,), m; ``s0[n]`` is the length.
        data: Segment parameters (n, 18); layout in :mod:`contour_gym.paths._geom`.
        bound: The search's rows (3n - 1, NB) (:mod:`contour_gym.paths._branch`): per
            segment its bounding sphere (centre xyz and radius, m), turning and clearances,
            then a tree of spheres over the segments. Given as the segments' spheres (n, 4),
            the rest is built.
        dim: 2 or 3; 2-D paths have z = 0 everywhere in ``data`` and ``bound``.
    """

    kind: IntArray
    s0: FloatArray
    data: FloatArray
    bound: FloatArray
    dim: int

    def __post_init__(self) -> None:
        object.__setattr__(self, "kind", _frozen(self.kind, np.int64))
        object.__setattr__(self, "s0", _frozen(self.s0, np.float64))
        object.__setattr__(self, "data", _frozen(self.data, np.float64))
        n = self.kind.shape[0]
        if n < 1 or self.s0.shape != (n + 1,) or self.data.shape != (n, NCOL):
            raise ValueError("inconsistent PathTable shapes")
        bound = np.asarray(self.bound, dtype=np.float64)
        if bound.shape == (n, 4):
            args = (self.kind, self.s0, self.data, np.ascontiguousarray(bound))
            compiled = build_rows.signatures and fill_clearances.signatures
            # until its builders are compiled in this process, below a reserved stack
            bound = build_bound(*args) if compiled else on_reserved_stack(build_bound, *args)
        object.__setattr__(self, "bound", _frozen(bound, np.float64))
        if self.bound.shape != (3 * n - 1, NB) or self.dim not in (2, 3):
            raise ValueError("inconsistent PathTable bound shape or dim")

    def __reduce__(self) -> tuple[Any, ...]:
        return (PathTable, (self.kind, self.s0, self.data, self.bound, self.dim))

    @property
    def n_segments(self) -> int:
        """Number of segments."""
        return int(self.kind.shape[0])

    @property
    def length(self) -> float:
        """Total arc length, m."""
        return float(self.s0[-1])

    @property
    def closed(self) -> bool:
        """Whether the path ends where it starts (within ``CLOSED_TOL``; the search's flag)."""
        return bool(self.bound[self.n_segments, B_CLOSED] != 0.0)

    @property
    def spheres(self) -> FloatArray:
        """Each segment's bounding sphere (n, 4): centre xyz and radius, m (read-only)."""
        out: FloatArray = self.bound[: self.n_segments, :4]
        return out


def make_table(kind: Sequence[int] | IntArray, lengths: Sequence[float] | FloatArray,
               data: FloatArray, dim: int, bound: FloatArray | None = None) -> PathTable:
    """Assemble a table from per-segment kinds, lengths and rows.

    ``bound``: the segments' bounding spheres (n, 4), computed if absent, from which the
    search's other rows are built; or all of a table's rows (3n - 1, ``NB``), taken as given.
    """
    kind_arr = _frozen(kind, np.int64)
    lens = np.asarray(lengths, dtype=np.float64)
    s0 = _frozen(np.concatenate(([0.0], np.cumsum(lens))), np.float64)
    rows = _frozen(np.asarray(data, dtype=np.float64).reshape(-1, NCOL), np.float64)
    if bound is None:  # on read-only arrays, as every other builder: one compile of each callee
        bound = _batch.compute_bounds(kind_arr, s0, rows)
    return PathTable(kind_arr, s0, rows, bound, dim)


def concat_tables(tables: Sequence[PathTable]) -> PathTable:
    """Join tables end to end (the caller checks that the ends meet)."""
    kind = np.concatenate([t.kind for t in tables])
    lengths = np.concatenate([np.diff(t.s0) for t in tables])
    data = np.concatenate([t.data for t in tables])
    spheres = np.concatenate([t.spheres for t in tables])
    return make_table(kind, lengths, data, tables[0].dim, spheres)


def line_row(start: FloatArray, end: FloatArray) -> tuple[float, FloatArray]:
    """Length and row of a LINE from ``start`` to ``end`` (3-vectors)."""
    d = np.asarray(end, dtype=np.float64) - start
    length = float(np.linalg.norm(d))
    row = np.zeros(NCOL)
    row[0:3] = start
    row[3:6] = d / length
    return length, row


def helix_row(center: FloatArray, e1: FloatArray, e2: FloatArray, radius: float, sweep: float,
              rise: float) -> tuple[float, FloatArray]:
    """Length and row of a helix (or arc when ``rise == 0``) turning ``sweep`` rad about e1 x e2.

    Args:
        center: Centre at the start height (3,).
        e1: Unit vector from the centre to the start point (3,).
        e2: Unit vector perpendicular to ``e1``; positive ``sweep`` turns from e1 towards e2.
        radius: Radius, m.
        sweep: Signed angle turned, rad.
        rise: Displacement along ``e1 x e2`` over the whole segment, m.
    """
    length = float(np.hypot(radius * sweep, rise))
    row = np.zeros(NCOL)
    row[0:3] = center
    row[3:6] = e1
    row[6:9] = e2
    row[9:12] = np.cross(e1, e2)
    row[12] = radius
    row[13] = sweep / length
    row[14] = rise / length
    return length, row


def split_helix(
    center: FloatArray, e1: FloatArray, e2: FloatArray, radius: float, sweep: float, rise: float,
    max_sweep: float = 0.5 * np.pi,
) -> tuple[list[float], list[FloatArray]]:
    """Rows of a helix cut into pieces turning at most ``max_sweep`` (tighter bounding spheres).

    A plain arc (``rise == 0``) is kept whole: it is solved in closed form.
    """
    if rise == 0.0:
        length, row = helix_row(center, e1, e2, radius, sweep, 0.0)
        return [length], [row]
    n = max(1, int(np.ceil(abs(sweep) / max_sweep - 1e-12)))
    axis = np.cross(e1, e2)
    lengths: list[float] = []
    rows: list[FloatArray] = []
    for k in range(n):
        phi = sweep * k / n
        f1 = np.cos(phi) * e1 + np.sin(phi) * e2
        f2 = np.cos(phi) * e2 - np.sin(phi) * e1
        c = center + axis * rise * k / n
        length, row = helix_row(c, f1, f2, radius, sweep / n, rise / n)
        lengths.append(length)
        rows.append(row)
    return lengths, rows


def poly5_rows(p0: FloatArray, t0: FloatArray, k0: FloatArray, p1: FloatArray, t1: FloatArray,
               k1: FloatArray, length: FloatArray) -> FloatArray:
    """POLY5 rows of quintic Hermite spans matching point, dP/ds, d2P/ds2 at both ends.

    All arguments are per span: points/derivatives (K, 3), ``length`` (K,). Returns (K, 18).
    """
    el = length[:, None]
    a1 = el * t0
    a2 = 0.5 * el * el * k0
    d0 = p1 - p0 - a1 - a2
    d1 = el * t1 - a1 - 2.0 * a2
    d2 = el * el * k1 - 2.0 * a2
    a3 = 10.0 * d0 - 4.0 * d1 + 0.5 * d2
    a4 = -15.0 * d0 + 7.0 * d1 - d2
    a5 = 6.0 * d0 - 3.0 * d1 + 0.5 * d2
    coef = np.stack([p0, t0, 0.5 * k0, a3 / el**3, a4 / el**4, a5 / el**5], axis=1)
    return coef.reshape(-1, NCOL)


def eval_poly5_rows(rows: FloatArray, t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Point and dP/ds of POLY5 rows (K, 18) at local ``t`` (K, m): arrays (K, m, 3)."""
    c = rows.reshape(-1, 6, 3)
    tt = t[:, :, None]
    p = c[:, None, 5]
    d = 5.0 * c[:, None, 5]
    for j in range(4, -1, -1):
        p = p * tt + c[:, None, j]
        if j >= 1:
            d = d * tt + j * c[:, None, j]
    return p, d


def transform_table(table: PathTable, rotation: FloatArray, offset: FloatArray) -> PathTable:
    """Table of the path mapped by ``x -> rotation @ x + offset`` (rotation orthogonal, 3x3).

    The search's rows move with the path: the spheres' centres are mapped, and the radii,
    turning and clearances (distances and angles) are kept, not searched again.
    """
    bound = table.bound.copy()
    bound[:, 0:3] = bound[:, 0:3] @ rotation.T + offset
    data = table.data.copy()
    det = float(np.sign(np.linalg.det(rotation)))
    for i, k in enumerate(table.kind):
        row = data[i]
        if k == LINE:
            row[0:3] = rotation @ row[0:3] + offset
            row[3:6] = rotation @ row[3:6]
        elif k == HELIX:
            row[0:3] = rotation @ row[0:3] + offset
            row[3:6] = rotation @ row[3:6]
            row[6:9] = rotation @ row[6:9]
            row[9:12] = det * (rotation @ row[9:12])
            row[14] *= det
        elif k == POLY5:
            c = row.reshape(6, 3) @ rotation.T
            c[0] += offset
            row[:] = c.reshape(-1)
    return make_table(table.kind, np.diff(table.s0), data, table.dim, bound)
