"""Population optimisers for tuning controllers: the papers' swarms and two library baselines.

Every optimiser takes a batch objective (``(n, dim) -> (n,)``, lower is better), a box and a
budget, and returns an :class:`OptimResult`. Use :func:`minimize` with a name from
:data:`OPTIMIZERS`, or call the functions directly:

========================  ==========================================================
``pso``                   standard PSO, linearly decreasing inertia (paper 000 eq. 12)
``improved_pso``          paper 000 improved PSO (eqs. 12-14, 13-14 reconstructed)
``abc``                   Karaboga's artificial bee colony (paper 003 section 4)
``improved_abc``          paper 003 IABC (eqs. 22-25)
``foa``                   Pan's fruit-fly optimisation, box-bounded form
``improved_foa``          paper 002 improved FOA (eqs. 5-11)
``de``                    ``scipy.optimize.differential_evolution``
``cma``                   ``cma.CMAEvolutionStrategy`` (ask/tell)
========================  ==========================================================
"""

from agents.optim._base import Objective, OptimResult
from agents.optim.abc import abc, improved_abc
from agents.optim.api import OPTIMIZERS, minimize, options_of
from agents.optim.foa import foa, improved_foa
from agents.optim.pso import improved_pso, pso
from agents.optim.wrappers import cma, de

__all__ = [
    "OPTIMIZERS",
    "Objective",
    "OptimResult",
    "abc",
    "cma",
    "de",
    "foa",
    "improved_abc",
    "improved_foa",
    "improved_pso",
    "minimize",
    "options_of",
    "pso",
]
