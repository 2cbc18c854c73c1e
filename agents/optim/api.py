"""One entry point to every optimiser: :func:`minimize` and the :data:`OPTIMIZERS` registry."""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from agents.optim._base import Objective, OptimResult
from agents.optim.abc import abc, improved_abc
from agents.optim.foa import foa, improved_foa
from agents.optim.pso import improved_pso, pso
from agents.optim.wrappers import cma, de
from contour_gym.params import choice

Optimizer = Callable[..., OptimResult]

OPTIMIZERS: dict[str, Optimizer] = {
    "pso": pso,
    "improved_pso": improved_pso,
    "abc": abc,
    "improved_abc": improved_abc,
    "foa": foa,
    "improved_foa": improved_foa,
    "de": de,
    "cma": cma,
}

_COMMON = ("objective", "bounds", "population", "iterations", "seed")


def options_of(name: str) -> tuple[str, ...]:
    """The keyword options optimiser ``name`` accepts besides the common arguments."""
    params = inspect.signature(OPTIMIZERS[choice(name, "optimizer", OPTIMIZERS)]).parameters
    return tuple(p for p in params if p not in _COMMON)


def minimize(
    name: str,
    objective: Objective,
    bounds: ArrayLike,
    *,
    population: int,
    iterations: int,
    seed: int | np.random.Generator,
    **options: Any,
) -> OptimResult:
    """Minimise a batch objective over a box with the optimiser called ``name``.

    Args:
        name: A key of :data:`OPTIMIZERS`: ``pso``, ``improved_pso``, ``abc``,
            ``improved_abc``, ``foa``, ``improved_foa``, ``de`` or ``cma``.
        objective: Maps a ``(n, dim)`` float array to ``(n,)`` fitness, lower is better; called
            with a whole generation (or phase) at once. Non-finite fitness counts as ``+inf``.
            Its units do not matter: ``c * objective`` (``c > 0``) gives the same run (see
            :mod:`agents.optim`).
        bounds: ``(dim, 2)`` array-like of finite ``[low, high]`` with ``low < high``. Every
            point the objective sees is inside.
        population: Evaluations per generation (a positive int; some optimisers need more,
            see their docs).
        iterations: Generations after the initial sample (a positive int).
        seed: Int or ``numpy.random.Generator``; the same seed gives the same result bit for
            bit.
        **options: The optimiser's own keyword options (see its docstring), e.g.
            ``keep_population=True``.

    Returns:
        The :class:`OptimResult`; ``nfev == population * (iterations + 1)``.

    Raises:
        ValueError: for an unknown ``name`` or option, bad bounds, population, iterations,
            seed or option value, naming the value.
    """
    accepted = options_of(name)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(
            f"unknown option(s) {', '.join(unknown)} for {name!r}; accepted: {', '.join(accepted)}"
        )
    optimizer = OPTIMIZERS[name]
    return optimizer(
        objective, bounds, population=population, iterations=iterations, seed=seed, **options
    )
