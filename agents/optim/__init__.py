"""Population optimisers for tuning controllers: the papers' swarms and two library baselines.

Every optimiser takes a batch objective (``(n, dim) -> (n,)``, lower is better), a box and a
budget, and returns an :class:`OptimResult`. Use :func:`minimize` with a name from
:data:`OPTIMIZERS`, or call the functions directly:

| name | optimiser |
|---|---|
| ``pso`` | standard PSO, linearly decreasing inertia (paper 000 eq. 12) |
| ``improved_pso`` | paper 000 improved PSO (eqs. 12-14, 13-14 reconstructed) |
| ``abc`` | Karaboga's bee colony (paper 003 sec. 4), 1/(1+rank) fitness |
| ``improved_abc`` | paper 003 IABC (eqs. 22-25), 1/(1+rank) fitness |
| ``foa`` | Pan's fruit-fly optimisation, box-bounded form |
| ``improved_foa`` | paper 002 improved FOA (eqs. 5-11) |
| ``de`` | ``scipy.optimize.differential_evolution`` |
| ``cma`` | ``cma.CMAEvolutionStrategy`` (ask/tell) |

Units: every optimiser takes the same path on ``f`` and on ``c * f`` (``c > 0``; all but
``improved_foa`` also on ``f + d``), so an objective in SI units, e.g. contour errors of
~1e-5 m, is searched as it would be in micrometres. This needed departures from the papers
(ABC and IABC rate food sources by ``1 / (1 + rank)`` instead of ``1 / (1 + f)``; the improved
FOA drops eq. 9's ``1 / Smellbest`` and makes its "trapped" variance test relative) and from the
libraries' defaults (DE never stops on scipy's convergence test; CMA-ES is told ranks); see each
module.
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
