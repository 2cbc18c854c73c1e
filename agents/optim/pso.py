"""Particle swarm optimisation: the standard inertia-weight PSO and the improved PSO of paper 000.

Both share one swarm loop and differ only in the schedule of ``(w, c1, c2)`` over the run.

Bounds: positions live in unit coordinates; a particle that would leave ``[0, 1]`` in a
coordinate is clipped to the wall and that velocity component is set to zero ("absorbing
wall"). Velocities are clamped to ``[-v_max, v_max]`` (fraction of the box width) and start at
zero. Budget: ``nfev = population * (iterations + 1)`` (generation 0 is the random swarm).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from agents.optim._base import (
    FloatArray,
    Objective,
    OptimResult,
    Problem,
    clip_unit,
    positive_int,
    progress,
    run,
)
from contour_gym.params import choice, finite, positive

# (fraction of the run done) -> (w, c1, c2)
Schedule = Callable[[float], tuple[float, float, float]]


def _swarm(
    problem: Problem,
    rng: np.random.Generator,
    population: int,
    iterations: int,
    schedule: Schedule,
    v_max: float,
) -> None:
    """Run the velocity/position update of paper 000 eq. (12) for ``iterations`` generations."""
    u, f = problem.initial(rng, population)
    v = np.zeros_like(u)
    best_u, best_f = u.copy(), f.copy()
    for t in range(1, iterations + 1):
        w, c1, c2 = schedule(progress(t, iterations))
        g = best_u[int(np.argmin(best_f))]
        r1 = rng.random(u.shape)
        r2 = rng.random(u.shape)
        v = np.clip(w * v + c1 * r1 * (best_u - u) + c2 * r2 * (g - u), -v_max, v_max)
        u = u + v
        v[(u < 0.0) | (u > 1.0)] = 0.0
        clip_unit(u)
        f = problem.evaluate(u)
        improved = f < best_f
        best_u[improved] = u[improved]
        best_f[improved] = f[improved]
        problem.end_generation()


def pso(
    objective: Objective,
    bounds: ArrayLike,
    *,
    population: int,
    iterations: int,
    seed: int | np.random.Generator,
    w_start: float = 0.9,
    w_end: float = 0.4,
    c1: float = 2.0,
    c2: float = 2.0,
    v_max: float = 0.2,
    keep_population: bool = False,
    x0: ArrayLike | None = None,
) -> OptimResult:
    """Standard PSO with a linearly decreasing inertia weight (Shi & Eberhart 1999).

    Paper 000 ("Traditional PSO algorithm", eq. 12): ``v <- w v + c1 r1 (p_i - x) +
    c2 r2 (g - x)``, ``x <- x + v`` with ``dt = 1``, ``r1, r2 ~ U(0, 1)`` per coordinate,
    ``p_i`` the particle's best and ``g`` the swarm's best. Here ``w`` falls linearly from
    ``w_start`` at the first generation to ``w_end`` at the last; ``c1``, ``c2`` are fixed.

    Args:
        objective: Batch objective ``(n, dim) -> (n,)``, lower is better.
        bounds: ``(dim, 2)`` array-like of ``[low, high]``.
        population: Number of particles (evaluations per generation).
        iterations: Number of generations after the initial swarm.
        seed: Int or ``numpy.random.Generator``; the only source of randomness.
        w_start: Inertia weight at the first generation.
        w_end: Inertia weight at the last generation.
        c1: Cognitive learning factor.
        c2: Social learning factor.
        v_max: Velocity clamp as a fraction of the box width.
        keep_population: Return every evaluated point in ``population_history``.
        x0: Start points ``(k, dim)`` in the box, evaluated first in generation 0 in place
            of ``k`` random points (:func:`agents.optim._base.run`); None: all random.

    Returns:
        The run's :class:`OptimResult`.
    """
    schedule = partial(
        linear_coefficients,
        w_start=finite(w_start, "w_start"),
        w_end=finite(w_end, "w_end"),
        c1=finite(c1, "c1"),
        c2=finite(c2, "c2"),
    )
    core = partial(_swarm, schedule=schedule, v_max=positive(v_max, "v_max"))
    return run("pso", core, objective, bounds, population, iterations, seed, keep_population, x0=x0)


def linear_coefficients(
    tau: float, w_start: float = 0.9, w_end: float = 0.4, c1: float = 2.0, c2: float = 2.0
) -> tuple[float, float, float]:
    """Inertia weight and learning factors of the standard PSO (:func:`pso`).

    Args:
        tau: Fraction of the run done, 0 at the first generation and 1 at the last.
        w_start: Inertia weight at the first generation.
        w_end: Inertia weight at the last generation.
        c1: Cognitive learning factor (constant).
        c2: Social learning factor (constant).

    Returns:
        ``(w, c1, c2)`` with ``w = w_start - (w_start - w_end) tau``.
    """
    return w_start - (w_start - w_end) * tau, c1, c2


def improved_coefficients(
    tau: float,
    w_start: float = 0.9,
    w_end: float = 0.4,
    alpha: float = 3.4,
    beta: float = 0.07,
    c_start: float = 0.5,
    c_end: float = 1.0,
    t_ref: float = 100.0,
) -> tuple[float, float, float]:
    """Inertia weight and learning factors of the improved PSO (paper 000 eqs. 13-14, rebuilt).

    Eqs. 13 and 14 were lost in extraction; reconstructed here:

    * eq. 13 (inertia, "nonlinear decreasing strategy"): a decreasing logistic curve
      ``w(t) = w_end + (w_start - w_end) / (1 + exp(beta t - alpha))``. Why this form: with
      the published constants and ``T = 100`` it does what the text asks and nothing the text
      does not: it starts at ``w(0) = 0.884`` (about ``w_start``), ends at ``w(100) = 0.413``
      (about ``w_end``) and turns at ``t = alpha / beta = 48.6``, mid-run. The common
      exponential form ``w_end + (w_start - w_end) exp(-alpha (t / T)^beta)`` with the same
      constants drops to ``w = 0.44`` at ``t = 1``, which no "decreasing strategy" intends.
      The paper's Figure 6 (the curves) was not extracted, so the shape is not checked
      against it. For a run of another length the
      paper's clock is rescaled: ``t = t_ref * tau``, ``tau`` the fraction of the run done,
      ``t_ref = 100``, so the curve keeps its shape.
    * eq. 14 (learning factors "with the inertia weight", between ``c_start`` and ``c_end``,
      large ``c1`` / small ``c2`` early, the opposite late): with
      ``lam = (w - w_end) / (w_start - w_end)`` (about 1 early, about 0 late),
      ``c1 = c_start + (c_end - c_start) lam`` and ``c2 = c_end - (c_end - c_start) lam``.
      ``c1`` thus falls from ``c_end`` to ``c_start`` and ``c2`` rises from ``c_start`` to
      ``c_end`` along the same nonlinear (logistic-in-time) curve as ``w``, and ``c1 + c2``
      stays ``c_start + c_end``. Linear in ``w`` is the simplest coupling consistent with the
      text; the nonlinearity in time comes from eq. 13.

    Args:
        tau: Fraction of the run done, 0 at the first generation and 1 at the last.
        w_start: Inertia weight scale at the start.
        w_end: Inertia weight scale at the end.
        alpha: Logistic offset of eq. 13.
        beta: Logistic rate of eq. 13, per paper generation.
        c_start: Value ``c1`` ends at and ``c2`` starts at.
        c_end: Value ``c1`` starts at and ``c2`` ends at.
        t_ref: Paper generations the run is mapped onto.

    Returns:
        ``(w, c1, c2)`` with ``w = w_end + (w_start - w_end) / (1 + exp(beta t - alpha))``,
        ``t = tau t_ref``, ``lam = (w - w_end) / (w_start - w_end)``,
        ``c1 = c_start + (c_end - c_start) lam`` and ``c2 = c_end - (c_end - c_start) lam``.
    """
    w = w_end + (w_start - w_end) / (1.0 + float(np.exp(beta * tau * t_ref - alpha)))
    lam = (w - w_end) / (w_start - w_end)
    return w, c_start + (c_end - c_start) * lam, c_end - (c_end - c_start) * lam


def improved_pso(
    objective: Objective,
    bounds: ArrayLike,
    *,
    population: int,
    iterations: int,
    seed: int | np.random.Generator,
    w_start: float = 0.9,
    w_end: float = 0.4,
    alpha: float = 3.4,
    beta: float = 0.07,
    c_start: float = 0.5,
    c_end: float = 1.0,
    t_ref: float = 100.0,
    v_max: float = 0.2,
    keep_population: bool = False,
    x0: ArrayLike | None = None,
) -> OptimResult:
    """Improved PSO of paper 000: learning factors driven by a nonlinear inertia weight.

    Paper 000, "Improved PSO algorithm", eqs. 12-14, parameters from step (a): ``w_start =
    0.9``, ``w_end = 0.4``, ``alpha = 3.4``, ``beta = 0.07``, ``c_start = 0.5``, ``c_end = 1``
    with ``T = 100`` generations. The velocity/position update is eq. 12 (as :func:`pso`).

    Eqs. 13 and 14 were lost in extraction: :func:`improved_coefficients` gives the
    reconstruction and why.

    Measured (tests/test_optim.py, 50 particles, 100 generations, 5 seeds): faster and more
    precise than :func:`pso` on sphere and 2-D Rosenbrock, about even on 5-D Rosenbrock, worse
    on 5-D Rastrigin (``c1 + c2 = 1.5`` makes the swarm contract early).

    Args:
        objective: Batch objective ``(n, dim) -> (n,)``, lower is better.
        bounds: ``(dim, 2)`` array-like of ``[low, high]``.
        population: Number of particles (evaluations per generation); paper: 50.
        iterations: Number of generations after the initial swarm; paper: 100.
        seed: Int or ``numpy.random.Generator``; the only source of randomness.
        w_start: Inertia weight scale at the start.
        w_end: Inertia weight scale at the end.
        alpha: Logistic offset of eq. 13.
        beta: Logistic rate of eq. 13, per paper generation.
        c_start: Learning-factor value ``c1`` ends at and ``c2`` starts at.
        c_end: Learning-factor value ``c1`` starts at and ``c2`` ends at.
        t_ref: Paper generations the curve of eq. 13 spans (the paper's ``T``).
        v_max: Velocity clamp as a fraction of the box width.
        keep_population: Return every evaluated point in ``population_history``.
        x0: Start points ``(k, dim)`` in the box, evaluated first in generation 0 in place
            of ``k`` random points (:func:`agents.optim._base.run`); None: all random.

    Returns:
        The run's :class:`OptimResult`.
    """
    schedule = _improved_schedule(w_start, w_end, alpha, beta, c_start, c_end, t_ref)
    core = partial(_swarm, schedule=schedule, v_max=positive(v_max, "v_max"))
    return run("improved_pso", core, objective, bounds, population, iterations, seed,
               keep_population, x0=x0)


_COEFFICIENTS: dict[str, Callable[..., tuple[float, float, float]]] = {
    "pso": linear_coefficients,
    "improved_pso": improved_coefficients,
}


def _improved_schedule(
    w_start: float, w_end: float, alpha: float, beta: float, c_start: float, c_end: float,
    t_ref: float,
) -> Schedule:
    """:func:`improved_coefficients` with checked options (ValueError naming a bad one)."""
    w0, w1 = finite(w_start, "w_start"), finite(w_end, "w_end")
    if w0 <= w1:
        raise ValueError(f"w_start must be > w_end, got w_start={w_start!r}, w_end={w_end!r}")
    return partial(
        improved_coefficients,
        w_start=w0,
        w_end=w1,
        alpha=finite(alpha, "alpha"),
        beta=finite(beta, "beta"),
        c_start=finite(c_start, "c_start"),
        c_end=finite(c_end, "c_end"),
        t_ref=positive(t_ref, "t_ref"),
    )


def schedules(name: str, iterations: int, **options: Any) -> FloatArray:
    """The ``(w, c1, c2)`` a PSO run uses at each of its generations, as the run computes them.

    Args:
        name: ``"pso"`` or ``"improved_pso"``.
        iterations: Generations of the run (after the initial swarm), >= 1.
        **options: The optimiser's keyword options (as given to :func:`pso` or
            :func:`improved_pso`); those that do not shape the schedule (``v_max``,
            ``keep_population``) are ignored.

    Returns:
        ``(iterations, 3)`` array: row ``t - 1`` holds ``(w, c1, c2)`` of generation ``t``.

    Raises:
        ValueError: for a name other than the two PSO variants or a bad ``iterations``.

    >>> schedules("pso", 3)[:, 0].tolist()
    [0.9, 0.65, 0.4]
    """
    coefficients = _COEFFICIENTS[choice(name, "PSO variant", _COEFFICIENTS)]
    iterations = positive_int(iterations, "iterations")
    shaping = set(inspect.signature(coefficients).parameters) - {"tau"}
    kwargs = {k: float(v) for k, v in options.items() if k in shaping}
    return np.array(
        [coefficients(progress(t, iterations), **kwargs) for t in range(1, iterations + 1)],
        dtype=np.float64,
    )


__all__ = [
    "improved_coefficients",
    "improved_pso",
    "linear_coefficients",
    "pso",
    "schedules",
]
