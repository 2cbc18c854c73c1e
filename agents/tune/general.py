"""Protocols for any machine: tune your own machine's (or its twin's) CCC, not a paper's.

``"pid"`` searches the PID CCC's gains as factors of the machine's own
(:func:`agents.tune.setters.pid_gains`: ``kp`` and ``ki`` scaled, a derivative time added) on
the machine's paper path, for the smallest peak contour error; a candidate that chatters more
than twice the machine's own gains fails, and generation 0 holds those gains, so the result is
never worse than them there. Run it on a machine file::

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
machine's to a hundred times, where every preset's loop has gone unstable (000's at 30 times,
004's and 002's at 10: such candidates fail), and up to 5 ms of derivative time)."""

register_protocol(Protocol(
    "pid", PID_FACTORS, ("paper",), fitness="max", ccc_law="pid", optimizer="improved_pso",
    population=16, iterations=15, setter="pid_factors",
    scenario_kwargs={"paper": {"id": "contour_gym/CCC-v1"}}, chatter_bound=2.0,
    reference={"kp_factor": 1.0, "ki_factor": 1.0, "td": 0.0}, start_at_reference=True,
    doc="any machine's PID CCC gains (factors of its own, a derivative time added) on its "
    "paper path, for the smallest peak contour error; chattering at most twice its own gains' "
    "(chosen); on another machine with --plant",
))
