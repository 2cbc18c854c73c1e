"""The outcome of a tuning run (:func:`agents.tune.runner.tune`): :class:`TuneResult`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from agents.tune.setters import pid_gains
from contour_gym.presets import resolve_preset

if TYPE_CHECKING:
    from agents.tune.protocols import Protocol

INJECTED = {
    "control": "added to each axis's control signal (the drive's command, in the unit of the "
               "effort your servo log records: 'control unit' below)",
    "reference": "added to each axis's commanded position",
}


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


def carry_to_machine(params: Mapping[str, float], protocol: Protocol, plant: Any) -> list[str]:
    """Lines that say how to run tuned CCC parameters on the machine ``plant`` models.

    Args:
        params: The tuned parameters by name, in their own units.
        protocol: The protocol that tuned them (its law, setter and units).
        plant: The machine (a plant spec: :func:`~contour_gym.presets.resolve_preset`).

    Returns:
        The lines: the law, where its output acts (the machine's ``ccc_injection``) and its
        parameters with their units; for the ``pid_factors`` setter, the PID CCC gains
        themselves in the machine's units.
    """
    preset = resolve_preset(plant)
    base = preset.ccc_gains.as_tuple()
    per = "control unit" if preset.ccc_injection == "control" else "m"
    lines = [f"on the machine ({preset.name}): the CCC law {protocol.ccc_law!r}, its output "
             f"{INJECTED[preset.ccc_injection]}, distributed to the axes by the coupling gains "
             "of the path's direction at the foot point"]
    if protocol.setter == "pid_factors":
        kp, ki, kd = pid_gains([list(params.values())], base)[0]
        return lines + [f"  kp = {kp:.6g} {per}/m", f"  ki = {ki:.6g} {per}/(m s)",
                        f"  kd = {kd:.6g} {per} s/m",
                        f"  (the machine's own: kp {base[0]:.6g}, ki {base[1]:.6g}, "
                        f"kd {base[2]:.6g})",
                        f"to simulate with them, add to the machine file: ccc_gains: "
                        f"{{kp: {kp:.6g}, ki: {ki:.6g}, kd: {kd:.6g}}}"]
    units = {p.name: p.unit for p in protocol.params}
    lines += [f"  {name} = {value:.6g} {units.get(name, '')}".rstrip()
              for name, value in params.items()]
    lines.append(f"  (units of kp, ki, kd: those of the machine's own PID CCC gains, kp "
                 f"{base[0]:.6g} {per}/m, ki {base[1]:.6g}, kd {base[2]:.6g})")
    return lines
