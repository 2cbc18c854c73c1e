"""The batched Python interface over the registered, compiled estimators."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import jit
from contour_gym.contour import _estimators  # noqa: F401 (registers the built-ins)
from contour_gym.contour.base import ESTIMATOR_FAMILY, ESTIMATORS, ContourEstimator
from contour_gym.paths import Path

FloatArray = NDArray[np.float64]


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
    """A configured estimator: the registered one and its option row, callable on a batch.

    Attributes:
        kind: The registered :class:`~contour_gym.contour.base.ContourEstimator`.
        params: Its option row.
    """

    kind: ContourEstimator
    params: FloatArray = field(repr=False)

    @property
    def name(self) -> str:
        """Registry name."""
        return self.kind.name

    @property
    def needs_history(self) -> bool:
        """Whether it reads previous reference points."""
        return self.kind.needs_history

    def _kernel(self) -> tuple[Any, int]:
        # the batch kernel with this estimator among the family's, and its code
        slots, codes = jit.bind({ESTIMATOR_FAMILY: [self.kind]})
        kernel = jit.specialise("contour_gym.contour._many", slots)
        return kernel, codes[ESTIMATOR_FAMILY.name][0]

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
        if self.kind.path_check is not None:
            self.kind.path_check(path)
        if self.needs_history and s_hist is None and ds is None:
            raise ValueError(f"estimator {self.name!r} reads previous reference points: "
                             "pass s_hist or ds")
        past, step, mode = _history_args(pos.shape[0], s_hist, ds)
        out = np.empty((pos.shape[0], 4))
        fell = np.empty(pos.shape[0], dtype=np.bool_)
        t = path.table
        kernel, code = self._kernel()
        bad = kernel.estimate_many(code, self.kind.foot is None, self.params, t.kind, t.s0,
                                   t.data, t.bound, pos, s, past, step, mode, out, fell)
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


def get_estimator(name: str, **options: Any) -> Estimator:
    """The estimator ``name`` with ``options`` (its schema's names).

    Raises:
        ValueError: for an unknown name (the message lists the accepted ones) or bad options.
    """
    kind = ESTIMATORS.get(name)
    row = np.ascontiguousarray(kind.params.row(**options)).reshape(-1)  # checks every name
    return Estimator(kind, row if kind.params.size else np.zeros(1))


def build_estimator(name: str, **options: Any) -> Estimator:
    """The configured estimator ``name`` (what the loop needs); alias of :func:`get_estimator`."""
    return get_estimator(name, **options)


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
