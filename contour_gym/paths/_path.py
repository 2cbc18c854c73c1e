"""The :class:`Path` class: an immutable, arc-length parameterised contour backed by a table."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array
from contour_gym.paths import _batch
from contour_gym.paths._geom import CORNER_TOL
from contour_gym.paths._table import PathTable, concat_tables, transform_table
from contour_gym.paths._timelaw import TimeLaw

FloatArray = NDArray[np.float64]


class Path:
    """A 2-D or 3-D contour parameterised by arc length ``s`` in metres.

    Every evaluation goes through the compiled table (:attr:`table`), the same arrays and
    functions the servo-loop kernel uses. Paths are immutable and picklable.

    Arc lengths outside ``[0, length]`` are clamped to it. Array inputs of shape (N,) give
    outputs of shape (N, dim) or (N,); scalars give (dim,) or a float.

    Attributes:
        length: Total arc length, m.
        dim: 2 or 3.
        table: The compiled :class:`PathTable`.
        name: A label (library name, constructor name, ...).
        closed: True if the end point equals the start point (within 1e-9 m).
        corners: Arc lengths where the tangent is discontinuous (sorted). On a closed path whose
            end tangent differs from its start tangent, 0.0 is included.
        time_law: The path's own reference timing ``s(t)`` (e.g. 003's three-leaf at
            ``theta = 2 pi f t``), or None: the path is then run at a feedrate.
    """

    __slots__ = ("_table", "_name", "_closed", "_corners", "_time_law")
    _table: PathTable
    _name: str
    _closed: bool
    _corners: FloatArray
    _time_law: TimeLaw | None

    def __init__(
        self, table: PathTable, name: str = "path", time_law: TimeLaw | None = None
    ) -> None:
        """Build a path around a compiled table.

        Args:
            table: The compiled segments.
            name: A label.
            time_law: The path's own timing (its ``s`` must end at the path's length).

        Raises:
            ValueError: for a time law that is not a :class:`TimeLaw` or ends elsewhere.
        """
        if time_law is not None:
            _check_law(time_law, table.length, name)
        ends = _batch.segment_ends(table.kind, table.s0, table.data)
        closed = table.closed  # the branch search's flag: one definition of closed
        jump = np.linalg.norm(ends[1:, 0, 3:] - ends[:-1, 1, 3:], axis=1) > CORNER_TOL
        corners = table.s0[1:-1][jump]
        if closed and np.linalg.norm(ends[0, 0, 3:] - ends[-1, 1, 3:]) > CORNER_TOL:
            corners = np.concatenate(([0.0], corners))
        corners = np.array(corners, dtype=np.float64)
        corners.flags.writeable = False
        object.__setattr__(self, "_table", table)
        object.__setattr__(self, "_name", str(name))
        object.__setattr__(self, "_closed", closed)
        object.__setattr__(self, "_corners", corners)
        object.__setattr__(self, "_time_law", time_law)

    def __setattr__(self, key: str, value: Any) -> None:
        raise AttributeError(f"{type(self).__name__} is immutable")

    def __reduce__(self) -> tuple[Any, ...]:
        return (Path, (self._table, self._name, self._time_law))

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(name={self._name!r}, dim={self.dim}, "
                f"length={self.length:.6g} m, segments={self._table.n_segments})")

    @property
    def table(self) -> PathTable:
        """The compiled table."""
        return self._table

    @property
    def name(self) -> str:
        """A label for the path."""
        return self._name

    @property
    def length(self) -> float:
        """Total arc length, m."""
        return self._table.length

    @property
    def dim(self) -> int:
        """Number of coordinates: 2 or 3."""
        return self._table.dim

    @property
    def closed(self) -> bool:
        """True if the end point equals the start point within 1e-9 m."""
        return self._closed

    @property
    def corners(self) -> FloatArray:
        """Arc lengths where the unit tangent jumps by more than 1e-8 (read-only array)."""
        return self._corners

    @property
    def time_law(self) -> TimeLaw | None:
        """The path's own reference timing, or None (run at a feedrate)."""
        return self._time_law

    def with_time_law(self, time_law: TimeLaw | None) -> Path:
        """This geometry with its own reference timing (None: run at a feedrate).

        Raises:
            ValueError: if the law does not end at this path's length, or for a path with
                per-segment program data (a G-code part runs on its F words).
        """
        self._plain("with_time_law")
        return Path(self._table, self._name, time_law)

    def repeat(self, laps: int) -> Path:
        """This closed path traced ``laps`` times (its time law, if any, repeated too).

        Raises:
            ValueError: for an open path, a bad ``laps`` or a G-code part.
        """
        if not isinstance(laps, (int, np.integer)) or laps < 1:
            raise ValueError(f"laps must be a positive int, got {laps!r}")
        if laps == 1:
            return self
        self._plain("repeat")
        if not self._closed:
            raise ValueError(f"path {self._name!r} is open: only a closed path can be repeated")
        law = None if self._time_law is None else self._time_law.repeat(int(laps))
        table = concat_tables([self._table] * int(laps))
        return Path(table, f"{self._name} x{laps}", law)

    def _plain(self, what: str) -> None:
        if type(self) is not Path:
            raise ValueError(f"{what} applies to plain paths, not {type(self).__name__}")

    # evaluation -----------------------------------------------------------------------------

    def _eval(self, s: ArrayLike) -> tuple[FloatArray, bool]:
        arr = as_finite_array(s, "s")
        flat = np.ascontiguousarray(arr.reshape(-1))
        out = np.empty((flat.shape[0], 9))
        t = self._table
        _batch.eval_many(t.kind, t.s0, t.data, flat, out)
        return out, arr.ndim == 0

    def evaluate(self, s: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Point, first and second derivative with respect to arc length.

        Args:
            s: Arc length(s), m.

        Returns:
            ``(P, dP/ds, d2P/ds2)``, each (N, dim) for an array, (dim,) for a scalar. At a corner
            the derivatives of the segment starting there are returned.
        """
        out, scalar = self._eval(s)
        d = self.dim
        parts = (out[:, 0:d], out[:, 3:3 + d], out[:, 6:6 + d])
        if scalar:
            return parts[0][0], parts[1][0], parts[2][0]
        return parts

    def point(self, s: ArrayLike) -> FloatArray:
        """Point(s) on the path at arc length ``s``: (N, dim) or (dim,)."""
        return self.evaluate(s)[0]

    def tangent(self, s: ArrayLike) -> FloatArray:
        """Unit tangent at arc length ``s``, the outgoing one at a corner: (N, dim) or (dim,)."""
        d1 = self.evaluate(s)[1]
        return d1 / np.linalg.norm(d1, axis=-1, keepdims=True)

    def curvature(self, s: ArrayLike) -> FloatArray | float:
        """Curvature ``|dP x d2P| / |dP|^3 >= 0`` at ``s``, 1/m: (N,) or float."""
        out, scalar = self._eval(s)
        d1 = out[:, 3:6]
        kappa = np.linalg.norm(np.cross(d1, out[:, 6:9]), axis=1) / np.linalg.norm(d1, axis=1) ** 3
        return float(kappa[0]) if scalar else kappa

    def signed_curvature(self, s: ArrayLike) -> FloatArray | float:
        """Signed curvature of a 2-D path (positive turning left, i.e. counter-clockwise), 1/m.

        Raises:
            ValueError: if the path is 3-D.
        """
        if self.dim != 2:
            raise ValueError(f"signed_curvature needs a 2-D path, this one has dim {self.dim}")
        out, scalar = self._eval(s)
        num = out[:, 3] * out[:, 7] - out[:, 4] * out[:, 6]
        kappa = num / np.hypot(out[:, 3], out[:, 4]) ** 3
        return float(kappa[0]) if scalar else kappa

    # nearest point --------------------------------------------------------------------------

    def _points3(self, points: ArrayLike) -> tuple[FloatArray, bool]:
        arr = as_finite_array(points, "points")
        if arr.ndim == 1 and arr.shape == (self.dim,):
            arr = arr[None, :]
            single = True
        elif arr.ndim == 2 and arr.shape[1] == self.dim:
            single = False
        else:
            raise ValueError(f"points must have shape ({self.dim},) or (N, {self.dim}), "
                             f"got {arr.shape}")
        pts = np.zeros((arr.shape[0], 3))
        pts[:, : self.dim] = arr
        return pts, single

    def nearest(
        self, points: ArrayLike, s_hint: ArrayLike | None = None, s_from: ArrayLike | None = None
    ) -> tuple[FloatArray | float, FloatArray | float]:
        """Exact nearest point on the path: its arc length and the (signed) distance.

        Without ``s_hint`` the whole path is searched. With ``s_hint`` (the reference's arc
        length, one per point) the point is measured against its *branch*, as the servo loop
        measures the machine (:mod:`contour_gym.paths._branch`): the stretch from ``s_from``
        (where the point's foot was a moment before; default ``s_hint``) to ``s_hint``,
        extended at both ends until the path has turned 180 degrees beyond it. That is the
        whole path's nearest point wherever the path does not cross or come back near itself
        after a half turn, and the traversed branch where it does (``infinity``'s centre).

        Args:
            points: (N, dim) or (dim,) points, m.
            s_hint: Optional (N,) reference arc lengths (a scalar for one point), m.
            s_from: Optional (N,) arc lengths of the previous foot points, m (with ``s_hint``).

        Returns:
            ``(s, distance)``: arc length of the foot point and the distance, signed in 2-D
            (positive left of the direction of travel; against the corner bisector at a corner),
            non-negative in 3-D. Arrays (N,) or floats for a single point.

        Raises:
            ValueError: for points or arc lengths that are not finite or not one per point,
                or ``s_from`` without ``s_hint``.
        """
        pts, single = self._points3(points)
        n = pts.shape[0]
        t = self._table
        out_s = np.empty(n)
        out_d2 = np.empty(n)
        if s_hint is None:
            if s_from is not None:
                raise ValueError("s_from needs s_hint (the reference the branch reaches to)")
            _batch.nearest_many(t.kind, t.s0, t.data, t.bound, pts, out_s, out_d2)
        else:
            hint = self._arc_lengths(s_hint, "s_hint", n)
            start = hint if s_from is None else self._arc_lengths(s_from, "s_from", n)
            _batch.nearest_many_hinted(t.kind, t.s0, t.data, t.bound, pts, start, hint, out_s,
                                       out_d2)
        return self._signed(pts, out_s, out_d2, single)

    def track(
        self, points: ArrayLike, s_ref: ArrayLike, s_start: float = 0.0
    ) -> tuple[FloatArray, FloatArray]:
        """The true contour error along a trajectory, as the servo loop measures it.

        Point ``k`` is measured against the branch from the foot point of point ``k - 1`` to
        its reference ``s_ref[k]`` (:meth:`nearest`); a run's recorded positions and
        references (:class:`~contour_gym.loop.Trace`) give back its ``eps`` exactly.

        Args:
            points: (N, dim) positions in order, m.
            s_ref: (N,) the reference's arc length at each, m.
            s_start: Arc length of the foot before the first point (the path start), m.

        Returns:
            ``(s, distance)`` (N,) each: the foot points' arc lengths and the signed (2-D) or
            unsigned (3-D) distances.

        Raises:
            ValueError: for points or arc lengths that are not finite or not one per point.
        """
        pts, _ = self._points3(points)
        n = pts.shape[0]
        ref = self._arc_lengths(s_ref, "s_ref", n)
        start = float(self._arc_lengths(s_start, "s_start", 1)[0])
        t = self._table
        out_s, out_d2 = np.empty(n), np.empty(n)
        _batch.track_many(t.kind, t.s0, t.data, t.bound, pts, ref, start, out_s, out_d2)
        s, d = self._signed(pts, out_s, out_d2, False)
        return np.asarray(s), np.asarray(d)

    def _arc_lengths(self, values: ArrayLike, name: str, n: int) -> FloatArray:
        # (n,) finite arc lengths clamped to [0, L]
        arr = np.ascontiguousarray(as_finite_array(values, name).reshape(-1))
        if arr.shape != (n,):
            raise ValueError(f"{name} must have one value per point ({n}), got {arr.shape}")
        return np.clip(arr, 0.0, self.length)

    def _signed(self, pts: FloatArray, out_s: FloatArray, out_d2: FloatArray, single: bool
                ) -> tuple[FloatArray | float, FloatArray | float]:
        # distances from the squared ones, signed in 2-D (against the corner bisector)
        t = self._table
        dist = np.sqrt(out_d2)
        if self.dim == 2:
            sign = np.empty(pts.shape[0])
            _batch.side_many(t.kind, t.s0, t.data, self._closed, out_s, pts, sign)
            dist = dist * sign
        if single:
            return float(out_s[0]), float(dist[0])
        return out_s, dist

    # transformations ------------------------------------------------------------------------

    def transformed(self, rotation: ArrayLike | None = None, offset: ArrayLike | None = None
                    ) -> Path:
        """A copy moved by ``x -> rotation @ x + offset`` (exact: the table rows are mapped).

        Args:
            rotation: Orthogonal (dim, dim) matrix; identity if omitted. A reflection swaps left
                and right, so it flips the sign of 2-D distances.
            offset: (dim,) translation, m; zero if omitted.

        Returns:
            The transformed path, same name.
        """
        d = self.dim
        rot = np.eye(d) if rotation is None else as_finite_array(rotation, "rotation", shape=(d, d))
        if not np.allclose(rot @ rot.T, np.eye(d), atol=1e-12):
            raise ValueError(f"rotation must be orthogonal, got {rot.tolist()}")
        off = np.zeros(d) if offset is None else as_finite_array(offset, "offset", shape=(d,))
        rot3 = np.eye(3)
        rot3[:d, :d] = rot
        off3 = np.zeros(3)
        off3[:d] = off
        return self._rebuilt(transform_table(self._table, rot3, off3))

    def _rebuilt(self, table: PathTable) -> Path:
        """Same kind of path with another table (subclasses keep their extra data)."""
        return Path(table, self._name, self._time_law)


def _check_law(law: object, length: float, name: str) -> None:
    if not isinstance(law, TimeLaw):
        raise ValueError(f"time_law must be a TimeLaw, got {type(law).__name__}")
    if abs(law.length - length) > 1e-9 * max(1.0, length):
        raise ValueError(
            f"time law ends at s = {law.length:.9g} m but path {name!r} is {length:.9g} m long"
        )
