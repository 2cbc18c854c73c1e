"""The outcome of a tuning run (:func:`agents.tune.runner.tune`): :class:`TuneResult`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass(frozen=True)
class TuneResult:
    """Outcome of :func:`~agents.tune.runner.tune`.

    Attributes:
        protocol: Protocol name.
        optimizer: Optimiser name.
        seed: The optimiser's seed.
        params: Best parameters by name, in their own units.
        fitness: Their fitness, m (the protocol's;
            :attr:`~agents.tune.objective.PopulationObjective.penalty` if every candidate
            failed).
        history: Best-so-far fitness after each generation, non-increasing, m.
        per_scenario: Scenario (env id or name) -> the best parameters' fitness there, m.
        nfev: Candidates evaluated.
        wall_time: Seconds the search took.
        settings: Everything else the run was given (budget, box, scales, options, ...).
        out: The run folder, or None.
    """

    protocol: str
    optimizer: str
    seed: int
    params: dict[str, float]
    fitness: float
    history: list[float]
    per_scenario: dict[str, float]
    nfev: int
    wall_time: float
    settings: dict[str, Any]
    out: Path | None = None

    def to_json(self) -> dict[str, Any]:
        """The ``result.json`` content (``"status": "complete"``)."""
        return {
            "status": "complete", "protocol": self.protocol, "optimizer": self.optimizer,
            "seed": self.seed, "params": self.params, "fitness": self.fitness,
            "fitness_unit": "m", "per_scenario": self.per_scenario, "nfev": self.nfev,
            "wall_time_s": self.wall_time, "settings": self.settings,
            "generations": len(self.history), "history": self.history,
        }
