"""The estimator registry and the batched Python interface over the compiled estimators."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import choice, positive
from contour_gym.contour import _kernel
from contour_gym.paths import HELIX, LINE, Path, PathTable

FloatArray = NDArray[np.float64]
DEFAULT_MAX_TURN = 1.0  # rad: kappa |e| beyond which linearisations at the reference give up


@dataclass(frozen=True)
class ContourEstimate:
    """One estimate per batch member.

    Attributes:
        vector: (B, dim) contour error vector, tool -> estimated foot point (``C eps``), m.
        eps: (B,) contour error: signed in 2-D (positive left of travel), ``>= 0`` in 3-D, m.
        gains: (B, dim) coupling gains C (unit; ``-n_left`` in 2-D).
        fallback: (B,) True where the estimator could not find a foot point and the exact
            search answered instead.
    """

    vector: FloatArray
    eps: FloatArray
    gains: FloatArray
    fallback: NDArray[np.bool_]


def _int_option(value: Any, name: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not lo <= value <= hi:
        raise ValueError(f"{name} must be an int in [{lo}, {hi}], got {value!r}")
    return int(value)


def _row(*values: float) -> FloatArray:
    row = np.zeros(_kernel.N_EST_P)
    row[: len(values)] = values
    return row


def _no_options() -> FloatArray:
    return _row()


def _tangent_options(max_turn: float = DEFAULT_MAX_TURN) -> FloatArray:
    return _row(positive(max_turn, "max_turn"))


def _frenet_options(order: int = 2, max_turn: float = DEFAULT_MAX_TURN) -> FloatArray:
    return _row(_int_option(order, "order", 1, 2), positive(max_turn, "max_turn"))


def _angle_options(lag: int = 1, max_turn: float = DEFAULT_MAX_TURN) -> FloatArray:
    return _row(_int_option(lag, "lag", 1, _kernel.N_HIST), positive(max_turn, "max_turn"))


def _window_options(half_width: int = 1) -> FloatArray:
    return _row(_int_option(half_width, "half_width", 1, _kernel.N_HIST))


_METHODS = {"newton": 0, "circle": 1}


def _iterative_options(n_iter: int = 4, method: str = "circle", tol: float = 1e-9) -> FloatArray:
    code = _METHODS[choice(method, "iteration method", _METHODS)]
    return _row(_int_option(n_iter, "n_iter", 1, 50), code, positive(tol, "tol"))


@functools.lru_cache(maxsize=64)
def _is_lines_and_arcs(table: PathTable) -> bool:
    ok = (table.kind == LINE) | ((table.kind == HELIX) & (table.data[:, 14] == 0.0))
    return bool(np.all(ok))


def _lines_and_arcs(path: Path) -> None:
    if not _is_lines_and_arcs(path.table):
        raise ValueError(f"estimator 'exact' needs a path made of lines and arcs; {path.name!r} "
                         "has free-form or helix segments (use 'iterative' or 'ground_truth')")


def _floats(value: ArrayLike, name: str) -> FloatArray:
    try:
        return np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric, got {value!r}") from exc


def _history_args(b: int, s_hist: ArrayLike | None, ds: ArrayLike | None
                  ) -> tuple[FloatArray, FloatArray, int]:
    """Kernel arguments ``(s_hist (B|1, n), ds (B|1,), mode)`` of the given history."""
    if s_hist is not None and ds is not None:
        raise ValueError("give either s_hist or ds, not both")
    if s_hist is not None:
        given = _floats(s_hist, "s_hist")
        given = given[None, :] if given.ndim == 1 else given
        if given.ndim != 2 or given.shape[1] < 1 or given.shape[0] not in (1, b):
            raise ValueError(f"s_hist must have shape ({b}, n) or (n,), got {np.shape(s_hist)}")
        return given, _ZERO, 1
    if ds is not None:
        step = _floats(ds, "ds").reshape(-1)
        if step.shape[0] not in (1, b):
            raise ValueError(f"ds must be a scalar or have shape ({b},), got {np.shape(ds)}")
        return _NO_HIST, step, 2
    return _NO_HIST, _ZERO, 0


_ZERO = np.zeros(1)
_NO_HIST = np.zeros((1, 1))


@dataclass(frozen=True)
class Estimator:
    """A configured estimator: the kernel kind and option row, callable on a batch.

    Attributes:
        name: Registry name.
        kind: Kernel kind (``contour_gym.contour._kernel.EST_*``).
        params: (N_EST_P,) option row the kernel reads.
        needs_history: Whether it reads previous reference points (then pass ``s_hist`` or
            ``ds``).
        path_check: Raises ValueError for paths it cannot handle.
    """

    name: str
    kind: int
    params: FloatArray
    needs_history: bool = False
    path_check: Callable[[Path], None] | None = field(default=None, repr=False)

    def __call__(self, path: Path, s_ref: ArrayLike, positions: ArrayLike, *,
                 s_hist: ArrayLike | None = None, ds: ArrayLike | None = None) -> ContourEstimate:
        """Estimate the contour error of each tool position.

        Args:
            path: The contour.
            s_ref: (B,) or scalar reference arc length of each member, m.
            positions: (B, dim) tool positions in path coordinates, m.
            s_hist: (B, n) or (n,) previous reference arc lengths, most recent first (the
                reference 1, 2, ... n ticks ago); beyond n the oldest value is held.
            ds: Instead of ``s_hist``: a constant interpolation step (scalar or (B,)), m;
                the history is ``max(s_ref - i ds, 0)``.

        Returns:
            The :class:`ContourEstimate`.

        Raises:
            ValueError: for a non-Path, positions of the wrong shape or dimension, NaN or
                infinite input, a missing history where one is needed, or a path the
                estimator cannot handle (``exact`` on free-form curves).
        """
        pos, s = _check_inputs(path, s_ref, positions)
        if self.path_check is not None:
            self.path_check(path)
        if self.needs_history and s_hist is None and ds is None:
            raise ValueError(f"estimator {self.name!r} reads previous reference points: "
                             "pass s_hist or ds")
        past, step, mode = _history_args(pos.shape[0], s_hist, ds)
        out = np.empty((pos.shape[0], 4))
        fell = np.empty(pos.shape[0], dtype=np.bool_)
        t = path.table
        bad = _kernel.estimate_many(self.kind, self.params, t.kind, t.s0, t.data, t.bound, pos, s,
                              past, step, mode, out, fell)
        if bad >= 0:
            raise ValueError(f"positions, s_ref and the history must be finite; member {bad} "
                             "is not")
        d = path.dim
        gains = out[:, 1 : 1 + d]
        return ContourEstimate(gains * out[:, :1], out[:, 0], gains, fell)


def _check_inputs(path: Path, s_ref: ArrayLike, positions: ArrayLike
                  ) -> tuple[FloatArray, FloatArray]:
    if not isinstance(path, Path):
        raise ValueError(f"path must be a contour_gym.paths.Path, got {type(path).__name__}")
    p = _floats(positions, "positions")
    if p.ndim != 2 or p.shape[1] != path.dim:
        raise ValueError(f"positions must have shape (B, {path.dim}) for the {path.dim}-D path "
                         f"{path.name!r}, got {p.shape}")
    s = _floats(s_ref, "s_ref")
    if s.ndim > 1 or (s.ndim == 1 and s.shape[0] != p.shape[0]):
        raise ValueError(f"s_ref must be a scalar or have shape ({p.shape[0]},), got {s.shape}")
    return p, s.reshape(-1)


@dataclass(frozen=True)
class EstimatorFactory:
    """Registry entry: ``factory(**options)`` builds an :class:`Estimator`.

    Attributes:
        name: Registry name.
        kind: Kernel kind.
        builder: ``builder(**options) -> (N_EST_P,)`` option row; raises ValueError on bad
            options.
        needs_history: Whether the estimator reads previous reference points.
        path_check: Raises ValueError for paths it cannot handle (Python API only: the loop's
            kernel falls back to the exact search instead).
    """

    name: str
    kind: int
    builder: Callable[..., FloatArray]
    needs_history: bool = False
    path_check: Callable[[Path], None] | None = None

    def __call__(self, **options: Any) -> Estimator:
        """The estimator with these options (see each builder's keywords)."""
        try:
            params = self.builder(**options)
        except TypeError as exc:
            raise ValueError(f"bad options for estimator {self.name!r}: {exc}") from exc
        return Estimator(self.name, self.kind, params, self.needs_history, self.path_check)


ESTIMATORS: dict[str, EstimatorFactory] = {
    f.name: f
    for f in (
        EstimatorFactory("ground_truth", _kernel.EST_GROUND_TRUTH, _no_options),
        EstimatorFactory("exact", _kernel.EST_EXACT, _no_options, path_check=_lines_and_arcs),
        EstimatorFactory("two_circle", _kernel.EST_TWO_CIRCLE, _no_options, needs_history=True),
        EstimatorFactory("tangent", _kernel.EST_TANGENT, _tangent_options),
        EstimatorFactory("frenet", _kernel.EST_FRENET, _frenet_options),
        EstimatorFactory("angle", _kernel.EST_ANGLE, _angle_options, needs_history=True),
        EstimatorFactory("window", _kernel.EST_WINDOW, _window_options, needs_history=True),
        EstimatorFactory("iterative", _kernel.EST_ITERATIVE, _iterative_options),
    )
}


def get_estimator(name: str, **options: Any) -> Estimator:
    """The estimator ``name`` with ``options``.

    Raises:
        ValueError: for an unknown name (the message lists the accepted ones) or bad options.
    """
    return ESTIMATORS[choice(name, "estimator", ESTIMATORS)](**options)


def build_estimator(name: str, **options: Any) -> tuple[int, FloatArray]:
    """Kernel kind and option row of the estimator ``name`` (what the loop needs).

    Raises:
        ValueError: for an unknown name (the message lists the accepted ones) or bad options.
    """
    est = get_estimator(name, **options)
    return est.kind, est.params


def estimate_full(name: str, path: Path, s_ref: ArrayLike, positions: ArrayLike,
                  **kwargs: Any) -> ContourEstimate:
    """Like :func:`estimate`, returning vector, scalar error, coupling gains and fallbacks."""
    s_hist = kwargs.pop("s_hist", None)
    ds = kwargs.pop("ds", None)
    return get_estimator(name, **kwargs)(path, s_ref, positions, s_hist=s_hist, ds=ds)


def estimate(name: str, path: Path, s_ref: ArrayLike, positions: ArrayLike,
             **kwargs: Any) -> FloatArray:
    """Contour error vector from each tool position to its estimated foot point on ``path``.

    Args:
        name: Estimator name, a key of :data:`ESTIMATORS`.
        path: The contour.
        s_ref: (B,) (or scalar) current reference arc length, m.
        positions: (B, dim) tool positions in path coordinates, m.
        **kwargs: ``s_hist`` ((B, n) previous reference arc lengths, most recent first) or
            ``ds`` (constant interpolation step) for the estimators that read previous
            reference points (``two_circle``, ``angle``, ``window``); every other keyword is
            an option of the estimator.

    Returns:
        (B, dim) contour error vectors, m.

    Raises:
        ValueError: for an unknown name, bad options, positions of the wrong dimension,
            NaN/inf input, a missing history, or ``exact`` on a free-form path.
    """
    return estimate_full(name, path, s_ref, positions, **kwargs).vector
