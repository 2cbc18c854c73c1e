"""What every optimiser shares: input checks, the box, batch evaluation and the result.

Every search in this package runs in *unit coordinates* ``u`` in ``[0, 1]^dim``; the objective
sees ``x = low + u * (high - low)``, clipped to ``[low, high]`` so rounding can never step outside
the box. Algorithms keep their own states inside the unit box by clipping (each says how it treats
velocities or steps at a wall). One :class:`Problem` per run counts evaluations, treats
non-finite fitness as ``+inf`` (a failed member) and keeps the best point and the history.

Budget convention (all optimisers): generation 0 evaluates ``population`` points (uniform in the
box unless the algorithm says otherwise; the start points ``x0`` first, when given), then
``iterations`` generations evaluate ``population`` points each, so ``nfev == population *
(iterations + 1)`` and ``history[k]`` is the best fitness seen after generation ``k + 1``
(generation 0 included in the best-so-far).

Units: every optimiser uses the fitness only through comparisons, ranks (:func:`ranks`) or
scale-free ratios of fitness values, so it takes the same path (same points, same result) on
``f`` and on ``c * f`` for any ``c > 0``: an objective in SI units (contour errors ~1e-5 m) is
searched as the same objective in micrometres would be. The path is identical bit for bit,
except for the improved FOA, whose ratios are computed from rounded values (its points can
differ in the last bit). Each module says where this needed a departure from its paper.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from numbers import Integral
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym.params import finite

FloatArray = NDArray[np.float64]


class Objective(Protocol):
    """A batch objective: ``(n, dim)`` points -> ``(n,)`` fitness, lower is better."""

    def __call__(self, x: FloatArray, /) -> ArrayLike:
        """Return the fitness of each row of ``x``."""
        ...


def _frozen(arr: FloatArray) -> FloatArray:
    arr.flags.writeable = False
    return arr


@dataclass(frozen=True)
class OptimResult:
    """Outcome of one optimiser run.

    Attributes:
        x: Best point found, shape ``(dim,)``, exactly the row the objective was given.
        fun: Its fitness; ``inf`` when every evaluation failed (never NaN).
        history: Best-so-far fitness after each of the ``iterations`` generations,
            non-increasing, shape ``(iterations,)``.
        nfev: Number of points evaluated (``population * (iterations + 1)``).
        name: Optimiser name, a key of ``agents.optim.OPTIMIZERS``.
        population_history: Points evaluated in each generation, shape
            ``(iterations, population, dim)``; only with ``keep_population=True``.
    """

    x: FloatArray
    fun: float
    history: FloatArray
    nfev: int
    name: str
    population_history: FloatArray | None = None


def positive_int(value: Any, name: str, minimum: int = 1) -> int:
    """Return ``value`` as an int >= ``minimum`` or raise ValueError naming it."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")
    if int(value) < minimum:
        raise ValueError(f"{name} must be an int >= {minimum}, got {value!r}")
    return int(value)


def in_range(value: Any, name: str, low: float, high: float) -> float:
    """Return ``value`` as a float in ``[low, high]`` or raise ValueError naming it."""
    out = finite(value, name)
    if not low <= out <= high:
        raise ValueError(f"{name} must be in [{low}, {high}], got {value!r}")
    return out


def make_rng(seed: Any) -> np.random.Generator:
    """Return the run's only random source.

    Args:
        seed: A non-negative int (a fresh ``default_rng(seed)``) or a ``numpy.random.Generator``
            (used, and advanced, as is).

    Returns:
        The generator every random draw of the run goes through.

    Raises:
        ValueError: if ``seed`` is neither.
    """
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, Integral) or int(seed) < 0:
        raise ValueError(f"seed must be a non-negative int or numpy.random.Generator, got {seed!r}")
    return np.random.default_rng(int(seed))


def check_bounds(bounds: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Return ``(low, high)`` from a ``(dim, 2)`` array-like or raise ValueError naming the row."""
    try:
        arr = np.asarray(bounds, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"bounds must be a numeric (dim, 2) array, got {bounds!r}") from exc
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise ValueError(f"bounds must have shape (dim, 2) with dim >= 1, got shape {arr.shape}")
    for i, (low, high) in enumerate(arr):
        if not (np.isfinite(low) and np.isfinite(high)):
            raise ValueError(f"bounds[{i}] = [{low}, {high}] must be finite")
        if not low < high:
            raise ValueError(f"bounds[{i}] = [{low}, {high}] needs low < high")
        if not math.isfinite(float(high) - float(low)):
            raise ValueError(f"bounds[{i}] = [{low}, {high}] is wider than a float can hold")
    return arr[:, 0].copy(), arr[:, 1].copy()


class Problem:
    """A box-bounded batch objective seen in unit coordinates, with the run's bookkeeping.

    Args:
        objective: Batch objective on real coordinates.
        bounds: ``(dim, 2)`` array-like of ``[low, high]``.
        keep_population: Record every evaluated point for ``population_history``.
        x0: Start points (:func:`run`), or None.

    Raises:
        ValueError: for a bad objective, bounds or ``x0``, naming the value.
    """

    def __init__(
        self, objective: Objective, bounds: ArrayLike, keep_population: bool,
        x0: ArrayLike | None = None,
    ) -> None:
        if not callable(objective):
            raise ValueError(f"objective must be callable, got {objective!r}")
        self.low, self.high = check_bounds(bounds)
        self.width = self.high - self.low
        self.dim = int(self.low.size)
        self._x0 = self._checked_starts(x0)
        self.starts = (self._x0 - self.low) / self.width  # in unit coordinates
        self.nfev = 0
        self.best_f = np.inf
        self._objective = objective
        self._best_x: FloatArray | None = None
        self._history: list[float] = []
        self._keep = bool(keep_population)
        self._batch: list[FloatArray] = []
        self._generations: list[FloatArray] = []

    def to_x(self, u: FloatArray) -> FloatArray:
        """Map unit coordinates to the box (clipped, so rounding never leaves it).

        A start point's unit coordinates map back to the start point itself, bit for bit.
        """
        x = np.clip(self.low + u * self.width, self.low, self.high)
        for unit, exact in zip(self.starts, self._x0, strict=True):
            x[np.all(u == unit, axis=-1)] = exact
        return x

    def evaluate(self, u: FloatArray) -> FloatArray:
        """Evaluate a batch given in unit coordinates.

        Args:
            u: ``(n, dim)`` points in ``[0, 1]``.

        Returns:
            ``(n,)`` fitness, non-finite values replaced by ``+inf``.

        Raises:
            ValueError: if the objective's answer does not have shape ``(n,)``.
        """
        x = self.to_x(np.atleast_2d(u))
        raw = np.asarray(self._objective(x.copy()), dtype=np.float64)
        if raw.shape != (x.shape[0],):
            raise ValueError(
                f"objective must return shape ({x.shape[0]},) for {x.shape[0]} points, "
                f"got shape {raw.shape}"
            )
        f = np.where(np.isfinite(raw), raw, np.inf)
        self.nfev += x.shape[0]
        i = int(np.argmin(f))
        if self._best_x is None or f[i] < self.best_f:
            self.best_f = float(f[i])
            self._best_x = x[i].copy()
        if self._keep:
            self._batch.append(x)
        return f

    def _checked_starts(self, x0: ArrayLike | None) -> FloatArray:
        """The start points ``x0`` as ``(k, dim)`` (k = 0 for None), checked."""
        if x0 is None:
            return np.empty((0, self.dim))
        try:
            x = np.atleast_2d(np.asarray(x0, dtype=np.float64))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"x0 must be a numeric (k, {self.dim}) array, got {x0!r}") from exc
        if x.ndim != 2 or x.shape[1] != self.dim:
            raise ValueError(f"x0 must have shape (k, {self.dim}), got shape {x.shape}")
        for i, row in enumerate(x):
            if not np.all(np.isfinite(row) & (row >= self.low) & (row <= self.high)):
                raise ValueError(f"x0[{i}] = {row.tolist()} is not a finite point in the bounds")
        return x

    def initial(self, rng: np.random.Generator, n: int) -> tuple[FloatArray, FloatArray]:
        """Generation 0: ``n`` uniform points (the start points first) and their fitness."""
        u = self.seeded(rng.random((n, self.dim)))
        return u, self.evaluate_initial(u)

    def seeded(self, u: FloatArray) -> FloatArray:
        """Generation 0's points ``u``, with the start points written over its first rows.

        The random draws are made whether or not there are start points, so the rest of the
        run's randomness is the same with and without them.
        """
        k = self.starts.shape[0]
        u[:k] = self.starts
        return u

    def evaluate_initial(self, u: FloatArray) -> FloatArray:
        """Evaluate generation 0 (counted in ``nfev`` and the best, not in the generations).

        Its first rows are the start points, exactly (a library optimiser's own scaling of
        the sample it was given may have moved them in the last bit).
        """
        f = self.evaluate(self.seeded(np.array(u)))
        self._batch = []
        return f

    def end_generation(self) -> None:
        """Close a generation: append the best-so-far to the history."""
        self._history.append(self.best_f)
        if self._keep:
            self._generations.append(np.concatenate(self._batch))
            self._batch = []

    def pad_history(self, iterations: int) -> None:
        """Repeat the last best-so-far if a library optimiser stopped before ``iterations``."""
        missing = iterations - len(self._history)
        self._history.extend([self.best_f] * missing)
        if self._keep and missing > 0:
            self._generations.extend([self._generations[-1]] * missing)

    def result(self, name: str) -> OptimResult:
        """Freeze the run into an :class:`OptimResult`."""
        assert self._best_x is not None, "result() before any evaluation"
        populations = None
        if self._keep:
            populations = _frozen(np.stack(self._generations))
        return OptimResult(
            x=_frozen(self._best_x.copy()),
            fun=float(self.best_f),
            history=_frozen(np.asarray(self._history, dtype=np.float64)),
            nfev=self.nfev,
            name=name,
            population_history=populations,
        )


# (problem, rng, population, iterations) -> None: one algorithm's generations
Core = Callable[[Problem, np.random.Generator, int, int], None]


def run(
    name: str,
    core: Core,
    objective: Objective,
    bounds: ArrayLike,
    population: Any,
    iterations: Any,
    seed: Any,
    keep_population: bool,
    min_population: int = 1,
    x0: ArrayLike | None = None,
) -> OptimResult:
    """Validate the common arguments, run ``core`` on a fresh :class:`Problem`, freeze the result.

    ``x0``, every optimiser's option: start points, ``(k, dim)`` (or one point, ``(dim,)``)
    inside the box, at most ``population`` of them. Generation 0 evaluates them in place of
    its first ``k`` random points, so the result is never worse than the best of them (e.g.
    a controller's untuned gains: a tuning that finds nothing better returns them). None:
    every point of generation 0 is random.

    Raises:
        ValueError: naming the first bad argument.
    """
    population = positive_int(population, "population", min_population)
    iterations = positive_int(iterations, "iterations")
    problem = Problem(objective, bounds, keep_population, x0)
    if problem.starts.shape[0] > population:
        raise ValueError(f"x0 has {problem.starts.shape[0]} points, more than the population "
                         f"{population}")
    core(problem, make_rng(seed), population, iterations)
    return problem.result(name)


def ranks(f: FloatArray) -> FloatArray:
    """Rank of each fitness in its batch: how many members are strictly better (0 for the best).

    Depends on ``f`` only through comparisons, so ``ranks(c * f + d) == ranks(f)`` for any
    ``c > 0`` and ``d`` (up to rounding that makes two distinct values equal). Tied members
    share the lowest rank; failed members (``inf``) all rank after every finite one.

    Args:
        f: ``(n,)`` fitness, lower is better; non-finite values count as ``+inf``.

    Returns:
        ``(n,)`` ranks as floats in ``[0, n - 1]``.
    """
    g = np.where(np.isfinite(f), f, np.inf)
    return np.searchsorted(np.sort(g), g, side="left").astype(np.float64)


def clip_unit(u: FloatArray) -> FloatArray:
    """Clip unit coordinates into ``[0, 1]`` in place and return them."""
    return np.clip(u, 0.0, 1.0, out=u)


def progress(t: int, iterations: int) -> float:
    """Fraction of the run done at generation ``t`` (1-based): 0 at the first, 1 at the last."""
    return 0.0 if iterations == 1 else (t - 1) / (iterations - 1)
