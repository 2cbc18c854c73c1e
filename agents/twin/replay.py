"""A log's commands replayed through the closed loop of a plant: what the twin would measure.

The logged command of the contour's axes becomes a path (from where the first sample measured
the machine, the commanded points joined by lines) carrying a time law on the log's time grid
(:class:`~contour_gym.paths.TimeLaw`), so that the loop's reference at tick ``k`` is the
command of sample ``k``. Run on a plant, the
loop's axes then follow the logged command as the machine's did: their positions, compared to
the logged feedback, are the output error an identification minimises. A loop of many
members replays the log on many candidate plants at once.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym.api import make_scenario
from contour_gym.logs import ServoLog
from contour_gym.loop import ServoLoop
from contour_gym.loop.threads import available_cpus
from contour_gym.paths import Path, TimeLaw, polyline
from contour_gym.presets import resolve_preset

Array = NDArray[np.float64]


def command_path(log: ServoLog, plant: Any) -> Path:
    """The log's commands on ``plant``'s first contour's axes, as a path with its time law.

    The path is in the contour's coordinates: the commands less the contour's offsets.

    Raises:
        ValueError: for a log without one of those axes, or not on the plant's servo tick.
    """
    stage = resolve_preset(plant).stage
    names = [stage.axes[i].name for i in stage.contours[0].axes]
    missing = [n for n in names if n not in log.names]
    if missing:
        raise ValueError(f"{log.source}: no command of axis {missing[0]!r}; the machine's "
                         f"contour runs on axes {', '.join(names)}")
    if not np.isclose(log.period, stage.ts, rtol=1e-6):
        raise ValueError(f"{log.source}: a sample every {log.period:.6g} s; the machine's servo "
                         f"tick is {stage.ts:.6g} s (give a log of one sample per tick)")
    # the machine at rest where sample 0 measured it, then sample k's command at the end of
    # tick k (the loop reads the law at (k + 1) ts); less the contour's offsets, which the
    # loop adds back (003's gantry: y1 at the path's y + 70 mm)
    offset = np.asarray(stage.contours[0].offset or np.zeros(len(names)))
    start = np.array([[log.axis(n).fb[0] for n in names]])
    points = np.vstack([start, np.stack([log.axis(n).cmd for n in names], axis=1)]) - offset
    moves = np.r_[True, np.any(np.diff(points, axis=0) != 0.0, axis=1)]
    path = polyline(points[moves])
    s = np.repeat(path.table.s0, np.diff(np.r_[np.flatnonzero(moves), len(points)]))
    return path.with_time_law(TimeLaw(stage.ts, s, np.gradient(s, stage.ts), "logged command"))


def replay_loop(log: ServoLog, plant: Any, members: int = 1, **options: Any) -> ServoLoop:
    """A recording loop of ``members`` copies of ``plant`` on the log's commands, at reset.

    The loop draws no random disturbance (001's): the one that acted on the logged run cannot
    be drawn again, and a second draw would only add its own error to the replay's; the
    deterministic parts (steps, sines, ripple, friction) act as in the plant.
    """
    scenario = make_scenario(plant, command_path(log, plant), **options)
    # a replay is one long call per member: a second thread pays from two members on
    threads = min(available_cpus(), members)
    loop = scenario.loop(batch_size=members, record=True, threads=threads)
    loop.set_plant_scaling(np.arange(members), random_disturbance=0.0)
    loop.reset(0)
    return loop


def replay(loop: ServoLoop, log: ServoLog) -> Array:
    """Run ``loop`` (:func:`replay_loop`) over the log; (B, N, A) each member's axis positions."""
    loop.step(len(log.time))
    return loop.trace().x


__all__ = ["command_path", "replay", "replay_loop"]
