"""Check a twin on what it was not fitted to: a held-out stretch of the log, or another log.

:func:`split_at_rest` cuts a log where the machine stands still (so that the held-out part
starts at rest, as a replay does); :func:`following` replays a log on a plant beside the
measured following error, :func:`nrmse` compares them, :func:`report_figure` draws them;
:func:`verdict` says what a user can do.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.twin.identified import tuning_copies
from agents.twin.replay import replay, replay_loop
from contour_gym.logs import ServoLog
from contour_gym.machines import identified_of, plant_of, undetermined_of
from contour_gym.presets import resolve_preset

Array = NDArray[np.float64]

REST_SAMPLES = 5  # samples of an unchanged command that count as a stop (a program's exact stop)
GOOD = 0.10  # a held-out NRMSE under this fits
DRIFT = 2.0  # held-out NRMSE over this times the fit's: the structure misses something


def split_at_rest(log: ServoLog, fraction: float = 2.0 / 3.0) -> tuple[ServoLog, ServoLog]:
    """The log cut at the rest nearest ``fraction`` of it: (fit part, held-out part).

    Raises:
        ValueError: when the command never rests for :data:`REST_SAMPLES` samples in the
            middle half of the log (record a stop, or give a second log to hold out).
    """
    cmd = np.stack([a.cmd for a in log.axes], axis=1)
    still = np.r_[False, np.all(np.diff(cmd, axis=0) == 0.0, axis=1)]
    run = np.convolve(still.astype(float), np.ones(REST_SAMPLES), mode="full")[: len(still)]
    n = len(log.time)
    rests = np.flatnonzero(run >= REST_SAMPLES)
    rests = rests[(rests > n // 4) & (rests < 3 * n // 4)]
    if rests.size == 0:
        raise ValueError(f"{log.source}: the machine never stands still in the middle of the log "
                         "(hold out a second log instead: give two or more)")
    cut = int(rests[np.argmin(np.abs(rests - fraction * n))])
    t = log.time
    return log.window(t[0], t[cut]), log.window(t[cut], math.inf)


def following(log: ServoLog, plant: Any, ideal: bool = False) -> dict[str, tuple[Array, Array]]:
    """Per axis that moved: (measured, twin's) following error, command minus position, m.

    The twin's is the log's command replayed on ``plant`` (:func:`~agents.twin.replay.replay`).
    """
    x = replay(replay_loop(log, plant, ideal=ideal), log)[0]
    out = {}
    for a, stage_axis in enumerate(resolve_preset(plant).stage.axes):
        axis = log.axis(stage_axis.name)
        if axis.name not in log.still:
            out[axis.name] = (axis.cmd - axis.fb, axis.cmd - x[:, a])
    return out


def nrmse(errors: dict[str, tuple[Array, Array]]) -> dict[str, float]:
    """Per axis: RMS(twin's following error - measured) / RMS(measured)."""
    return {name: float(math.sqrt(np.mean((twin - measured) ** 2)
                                  / max(np.mean(measured**2), 1e-30)))
            for name, (measured, twin) in errors.items()}


def following_nrmse(log: ServoLog, plant: Any, ideal: bool = False) -> dict[str, float]:
    """Per axis that moved: RMS(twin's following error - measured) / RMS(measured), replayed."""
    return nrmse(following(log, plant, ideal))


def report_figure(fitted: tuple[ServoLog, dict[str, tuple[Array, Array]]],
                  held: tuple[ServoLog, dict[str, tuple[Array, Array]]]) -> Any:
    """The report's plot: measured and twin following error (um) against time.

    One row per axis; the fitted log on the left, the held-out one on the right.
    """
    import matplotlib.pyplot as plt

    names = list(held[1])
    fig, grid = plt.subplots(len(names), 2, figsize=(11, 2.4 * len(names) + 0.6),
                             squeeze=False, sharex="col")
    for col, (log, errors) in enumerate((fitted, held)):
        t = log.time - log.time[0]
        for row, name in enumerate(names):
            ax = grid[row, col]
            measured, twin = errors[name]
            ax.plot(t, measured * 1e6, lw=0.8, label="measured")
            ax.plot(t, twin * 1e6, lw=0.8, ls="--", label="twin")
            score = nrmse({name: errors[name]})[name]
            ax.set_title(f"{name}, {('fitted', 'held out')[col]}: NRMSE {100 * score:.3g} %",
                         fontsize=9)
            ax.set_ylabel("following error (um)")
        grid[-1, col].set_xlabel("time (s)")
    grid[0, 0].legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    return fig


def verdict(fit: dict[str, float], held: dict[str, float],
            undetermined: dict[str, list[str]] | None = None,
            random: Sequence[str] = ()) -> str:
    """What the fit and held-out NRMSE mean, in a line a user can act on.

    ``undetermined`` (:meth:`~agents.twin.identified.Identified.undetermined`) adds which values not
    to read as the machine's. ``random`` names the axes under a random disturbance: their
    measured following error holds the response to the one that acted, which a replay cannot
    draw again, so their NRMSE is judged apart (it says how much of the error that makes).
    """
    judged = [a for a in held if a not in random]
    if judged:
        said = _judged(max(fit[a] for a in judged), max(held[a] for a in judged))
    else:
        said = "every axis's following error holds the machine's random disturbance"
    noisy = [a for a in held if a in random]
    if noisy:
        said += (f"; {', '.join(noisy)}: the held-out NRMSE ("
                 f"{', '.join(f'{100 * held[a]:.3g} %' for a in noisy)}) is mostly the random "
                 "disturbance's, which a replay cannot draw again, not the fit's: judge the "
                 "twin there by simulated runs (peaks, cycle) against the machine's")
    loose = [f"{axis}.{name}" for axis, names in (undetermined or {}).items() for name in names]
    if loose:
        said += (f"; the logs do not determine {', '.join(loose)} (they trade off: the twin may "
                 "behave like the machine, but do not read those as its values)")
    return said


def _judged(worst_fit: float, worst_held: float) -> str:
    # the verdict of the axes whose measured error a replay can match
    if worst_held > DRIFT * max(worst_fit, 1e-3) and worst_held > GOOD:
        return (f"the held-out error is {worst_held / max(worst_fit, 1e-3):.1f}x the fit's: the "
                "structure misses something (another friction law, a disturbance, the delay); "
                "check the log and try another --like")
    if worst_held > GOOD:
        return (f"fits to {100 * worst_held:.2g} % on held-out data: usable, but record a "
                "longer log with more reversals to tighten it")
    return f"fits to {100 * worst_held:.2g} % on held-out data"


def caution(plant: Any, copies: int = 0) -> list[str]:
    """What to print after tuning or training on ``plant``: a caution, or nothing.

    A line naming the values its logs left undetermined when ``plant`` is a twin's machine
    file that records such values (:func:`contour_gym.machines.undetermined_of`), and how
    many ``copies`` of it within their uncertainty the tuning ran on too.
    """
    loose = undetermined_of(plant)
    if not loose:
        return []
    names = ", ".join(f"{axis}.{n}" for axis, ns in loose.items() for n in ns)
    within = (f"tuned on it and {copies} copies drawn within those values' uncertainty; "
              if copies else "what is tuned or trained on it can do worse on the machine "
              "than on the twin; ")
    return [f"caution: the logs {plant} was identified from do not determine {names} (its "
            f"report says why): {within}run it on the machine before you keep it"]


def copies_of(plant: Any, count: int) -> list[dict[str, Any]]:
    """Copies of a twin's machine file to tune on beside it (none for another plant).

    :func:`~agents.twin.identified.tuning_copies` of its ``identified`` record: ``count``
    of them when its logs left values undetermined.

    Raises:
        ValueError: for a negative ``count``.
    """
    if count < 0:
        raise ValueError(f"--copies must be 0 or more, got {count}")
    record = identified_of(plant)
    if not record or count == 0:
        return []
    twin, _ = plant_of(plant)
    assert isinstance(twin, dict)  # a machine file's content
    return tuning_copies(twin, record.get("values", {}), record.get("std", {}),
                         record.get("undetermined", {}), count)


__all__ = [
    "caution", "copies_of", "following", "following_nrmse", "nrmse", "report_figure",
    "split_at_rest", "verdict",
]
