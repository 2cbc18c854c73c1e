"""Tuning protocols: a controller's parameters searched by any optimiser on a paper's scenarios.

A :class:`Protocol` names the parameters it searches and their box, the registered env ids it
runs (its scenarios), its fitness, and its default optimiser and budget; :data:`PROTOCOLS`
holds them by name. :func:`tune` runs one with any optimiser of :mod:`agents.optim` and, given
a folder, writes the run there (``contour-gym tune PROTOCOL`` on the command line)::

    result = tune("000", seed=0, out="runs/tune/000")   # paper 000, improved PSO, 50 x 100
    result.params                                         # {"k_e": ..., "k_de": ..., ...}

The package's modules, each re-exported here:

- :mod:`agents.tune.protocols`: :class:`TuneParam`, :class:`Protocol` and the registry.
- :mod:`agents.tune.papers`: the papers' protocols ``000`` (fuzzy PID CCC, improved PSO) and
  ``003`` (ACC2PID, improved ABC), registered on import.
- :mod:`agents.tune.general`: ``pid``, any machine's PID CCC gains (``--plant``).
- :mod:`agents.tune.fitness`: the fitness functions, the failure penalty and :func:`combine`.
- :mod:`agents.tune.setters`: how a candidate's parameters reach its batch member.
- :mod:`agents.tune.objective`: :class:`PopulationObjective`, a whole population per call on
  threads, each candidate's result its own.
- :mod:`agents.tune.runner`: :func:`tune`, :func:`compare` and the run folder.
- :mod:`agents.tune.result`: :class:`TuneResult`, what a run gives.
- :mod:`agents.tune.plots`: :func:`write_plots`.
"""

from __future__ import annotations

from agents.tune import general  # noqa: F401  (registers the protocol "pid")
from agents.tune.fitness import FITNESS_TERMS, FITNESSES, PENALTY_HARD_LIMITS, combine
from agents.tune.objective import PopulationObjective
from agents.tune.papers import acc2pid_003_params, acc2pid_hand_tuned, fuzzy_pid_000_params
from agents.tune.plots import write_plots
from agents.tune.protocols import (
    PROTOCOLS,
    Protocol,
    TuneParam,
    get_protocol,
    register_protocol,
)
from agents.tune.runner import TuneResult, check_run_folder, compare, tune
from agents.tune.setters import (
    ACC2PID_AXES,
    ACC2PID_COMPENSATORS,
    ACC2PID_NAMES,
    SETTERS,
    acc2pid_rows,
    set_acc2pid,
)

__all__ = [
    "ACC2PID_AXES",
    "ACC2PID_COMPENSATORS",
    "ACC2PID_NAMES",
    "FITNESSES",
    "FITNESS_TERMS",
    "PENALTY_HARD_LIMITS",
    "PROTOCOLS",
    "SETTERS",
    "PopulationObjective",
    "Protocol",
    "TuneParam",
    "TuneResult",
    "acc2pid_003_params",
    "acc2pid_hand_tuned",
    "acc2pid_rows",
    "check_run_folder",
    "combine",
    "compare",
    "fuzzy_pid_000_params",
    "get_protocol",
    "register_protocol",
    "set_acc2pid",
    "tune",
    "write_plots",
]
