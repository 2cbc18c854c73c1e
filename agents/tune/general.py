"""Protocols for any machine: tune your own machine's (or its twin's) CCC, not a paper's.

``"pid"`` searches the PID CCC's gains as factors of the machine's own
(:func:`agents.tune.setters.pid_gains`: ``kp`` and ``ki`` scaled, a derivative time added) on
the machine's paper path and two random paths (on a 3-D machine, whose random paths the library
does not draw, its paper path alone), for the smallest worst peak contour error relative to the
machine's own gains' on each; a candidate that chatters more than twice the machine's own gains
fails, and generation 0 holds those gains, so the result is never worse than them there. Run
it on a machine file::

    contour-gym tune pid --plant my_machine.yaml

which prints the gains in the machine's units (``kp`` and ``ki`` per metre of contour error,
in the unit the machine's CCC acts in) to carry to its controller.
"""

from __future__ import annotations

from agents.tune.protocols import Protocol, TuneParam, register_protocol
from agents.tune.setters import PID_FACTOR_NAMES

PID_FACTORS = (
    TuneParam(PID_FACTOR_NAMES[0], 0.1, 100.0, log=True, unit="x the machine's kp"),
    TuneParam(PID_FACTOR_NAMES[1], 0.01, 100.0, log=True, unit="x the machine's ki"),
    TuneParam(PID_FACTOR_NAMES[2], 0.0, 0.005, unit="s"),
)
"""The ``pid`` protocol's box (chosen: ``kp`` and ``ki`` from a tenth and a hundredth of the
machine's to a hundred times, past where each preset's PID CCC makes its loop unstable on its
paper path, so that the largest gains fail; and up to 5 ms of derivative time)."""

RANDOM_SEEDS = (101, 102)
"""The ``pid`` protocol's random paths: those ``env.reset(seed=s)`` runs (a spline and a
polyline with corners), so that the gains hold off the one path they were tuned on."""

_SCENARIOS = {"paper": {"id": "contour_gym/CCC-v1"}} | {
    f"random-{s}": {"id": "contour_gym/CCC-v1", "path": "random", "path_seed": s}
    for s in RANDOM_SEEDS}

register_protocol(Protocol(
    "pid", PID_FACTORS, tuple(_SCENARIOS), fitness="max", ccc_law="pid",
    optimizer="improved_pso", population=16, iterations=15, setter="pid_factors",
    scenario_kwargs=_SCENARIOS, chatter_bound=2.0, relative=True, worst_case=True,
    reference={"kp_factor": 1.0, "ki_factor": 1.0, "td": 0.0}, start_at_reference=True,
    doc="any machine's PID CCC gains (factors of its own, a derivative time added) on its "
    "paper path and two random paths (a 3-D machine: its paper path), for the smallest worst "
    "peak contour error relative to its own gains'; chattering at most twice its own gains' "
    "(chosen); on another machine with --plant",
))
