"""Library optimisers behind the same interface: SciPy's differential evolution and CMA-ES.

Both run in unit coordinates on ``[0, 1]^dim`` and evaluate through the shared
:class:`~agents.optim._base.Problem`, so bounds, failure handling, history and budget are the
same as for the swarm algorithms: generation 0 evaluates ``population`` uniform points, then
``iterations`` generations of ``population`` points each; ``nfev = population * (iterations +
1)``, always: neither library's convergence test can end a run early.

Units: both take the same path on ``c * f + d`` for any ``c > 0`` and ``d``. DE compares
fitness values only, once scipy's convergence test (a standard deviation against absolute and
relative tolerances, where rounding decides whether equal fitness values have zero spread) is
switched off. CMA-ES is told each generation's ranks, not its fitness values, so the values
can reach cma neither through its absolute termination tolerances (``tolfun``,
``tolfunhist``, ``tolflatfitness``; not consulted anyway) nor through ``BoundPenalty``, whose
penalty weight is set from the spread of the told values.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import differential_evolution

from agents.optim._base import FloatArray, Objective, OptimResult, Problem, in_range, ranks, run
from contour_gym.params import choice, positive


def de(
    objective: Objective,
    bounds: ArrayLike,
    *,
    population: int,
    iterations: int,
    seed: int | np.random.Generator,
    strategy: str = "best1bin",
    mutation: float | tuple[float, float] = (0.5, 1.0),
    recombination: float = 0.7,
    keep_population: bool = False,
    x0: ArrayLike | None = None,
) -> OptimResult:
    """Differential evolution: ``scipy.optimize.differential_evolution``.

    Called with ``vectorized=True`` (one objective call per generation), ``init`` set to the
    generation-0 uniform sample (so the population is exactly ``population``; scipy's
    ``popsize`` multiplier cannot give every size), ``maxiter=iterations``, ``polish=False`` (no
    extra evaluations), the run's generator as ``rng``, and ``tol=0``, ``atol=-inf``: scipy's
    convergence test ``std(f) <= atol + tol * |mean(f)|`` can then never pass, so every
    generation is run. (``atol=0`` would stop the run once every member has the same fitness,
    and whether ``std`` of equal values rounds to exactly 0 depends on their scale: a flat
    objective would run its budget at one scale and stop after one generation at another.)
    The run then compares fitness values only and takes the same path on ``c * f + d``,
    ``c > 0``.
    Scipy's own bounds handling applies: a trial coordinate outside ``[0, 1]`` is resampled
    uniformly.

    Args:
        objective: Batch objective ``(n, dim) -> (n,)``, lower is better.
        bounds: ``(dim, 2)`` array-like of ``[low, high]``.
        population: Population size, at least 5 (scipy's minimum).
        iterations: Number of generations after the initial population.
        seed: Int or ``numpy.random.Generator``; the only source of randomness.
        strategy: Scipy's mutation strategy name.
        mutation: Scipy's differential weight (or dithering range).
        recombination: Scipy's crossover probability.
        keep_population: Return every evaluated point in ``population_history``.
        x0: Start points ``(k, dim)`` in the box, evaluated first in generation 0 in place
            of ``k`` random points (:func:`agents.optim._base.run`); None: all random.

    Returns:
        The run's :class:`OptimResult`.
    """
    core = partial(
        _de,
        strategy=strategy,
        mutation=mutation,
        recombination=in_range(recombination, "recombination", 0.0, 1.0),
    )
    return run("de", core, objective, bounds, population, iterations, seed,
               keep_population, 5, x0=x0)


def _de(
    problem: Problem,
    rng: np.random.Generator,
    population: int,
    iterations: int,
    strategy: str,
    mutation: float | tuple[float, float],
    recombination: float,
) -> None:
    def batch(u_t: FloatArray) -> FloatArray:
        # scipy passes (dim, S); its first call is generation 0, the ``init`` sample
        evaluate = problem.evaluate_initial if problem.nfev == 0 else problem.evaluate
        return evaluate(u_t.T)

    def generation_done(intermediate_result: Any) -> None:
        problem.end_generation()

    differential_evolution(
        batch,
        [(0.0, 1.0)] * problem.dim,
        strategy=strategy,
        maxiter=iterations,
        mutation=mutation,
        recombination=recombination,
        rng=rng,
        callback=generation_done,
        polish=False,
        init=problem.seeded(rng.random((population, problem.dim))),
        tol=0.0,
        atol=-np.inf,  # std(f) <= -inf never holds: scipy's convergence stop is off
        updating="deferred",
        vectorized=True,
    )
    problem.pad_history(iterations)  # a no-op unless scipy stops for another reason


def cma(
    objective: Objective,
    bounds: ArrayLike,
    *,
    population: int,
    iterations: int,
    seed: int | np.random.Generator,
    sigma0: float = 0.3,
    boundary: str = "BoundTransform",
    keep_population: bool = False,
    x0: ArrayLike | None = None,
) -> OptimResult:
    """CMA-ES: ``cma.CMAEvolutionStrategy`` driven by ask/tell.

    Runs in unit coordinates with ``bounds=[0, 1]``, ``popsize=population``, ``sigma0`` as a
    fraction of the box width (default 0.3) and the mean started at the best point of the
    generation-0 sample. ``iterations`` ask/tell rounds are made whatever cma's own
    termination criteria (``tolfun``, ``tolx``, ``tolflatfitness``, ...) say: ``es.stop()`` is
    never consulted. Randomness: cma's ``randn`` option draws from the run's generator and its
    ``seed`` option is NaN, so cma never touches ``numpy.random``'s global state.

    Told values: cma is told each member's rank in its generation (the number of strictly
    better members), not its fitness. CMA-ES's update uses only the order, so with
    ``BoundTransform`` the path is the one the raw values would give; what changes is that no
    value-based part of cma (its absolute tolerances, ``BoundPenalty``'s penalty weight, set
    from the spread of the told values) can see the objective's units, so the run is the same
    on ``c * f + d`` for any ``c > 0``. A failed member (``inf``) ranks after every finite one,
    tied with the other failures. In one dimension cma's cap of the std at a third of the box
    is switched off (cma 4.5 raises there).

    Args:
        objective: Batch objective ``(n, dim) -> (n,)``, lower is better.
        bounds: ``(dim, 2)`` array-like of ``[low, high]``.
        population: ``popsize``, at least 2.
        iterations: Number of ask/tell rounds after the initial sample.
        seed: Int or ``numpy.random.Generator``; the only source of randomness.
        sigma0: Initial step size as a fraction of the box width.
        boundary: cma's ``BoundaryHandler``: ``"BoundTransform"`` or ``"BoundPenalty"``.
        keep_population: Return every evaluated point in ``population_history``.
        x0: Start points ``(k, dim)`` in the box, evaluated first in generation 0 in place
            of ``k`` random points (:func:`agents.optim._base.run`); None: all random.

    Returns:
        The run's :class:`OptimResult`.
    """
    core = partial(
        _cma_es,
        sigma0=positive(sigma0, "sigma0"),
        boundary=choice(boundary, "boundary", _BOUNDARIES),
    )
    return run("cma", core, objective, bounds, population, iterations, seed,
               keep_population, 2, x0=x0)


# cma's BoundaryHandler classes by name
_BOUNDARIES = ("BoundTransform", "BoundPenalty")


def _cma_es(
    problem: Problem,
    rng: np.random.Generator,
    population: int,
    iterations: int,
    sigma0: float,
    boundary: str,
) -> None:
    import cma as _cma  # here: with scipy.stats, 0.3 s of every command's start otherwise

    u0, f0 = problem.initial(rng, population)

    def randn(*shape: int) -> FloatArray:
        return rng.standard_normal(shape)

    options = {
        "popsize": population,
        "bounds": [0.0, 1.0],
        # the class: cma 4.5 cannot parse the string "BoundPenalty" ("'str' object has no
        # attribute 'has_bounds'")
        "BoundaryHandler": getattr(_cma, boundary),
        "randn": randn,
        "seed": np.nan,
        "verbose": -9,
        "verb_log": 0,
        "verb_disp": 0,
    }
    if problem.dim == 1:
        # cma 4.5 fails ("not yet initialized") when it caps a 1-D std at maxstd_boundrange
        options["maxstd"] = np.inf
    es = _cma.CMAEvolutionStrategy(u0[int(np.argmin(f0))], sigma0, options)
    for _ in range(iterations):
        asked = es.ask()
        f = problem.evaluate(np.clip(np.asarray(asked, dtype=np.float64), 0.0, 1.0))
        es.tell(asked, ranks(f).tolist())
        problem.end_generation()


__all__ = ["cma", "de"]
