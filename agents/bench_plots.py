"""The bench's plots of a scenario (:mod:`agents.bench`): the contour magnified, the feedrate.

See :mod:`agents.bench` for what each plot shows.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

from agents._files import save_figure
from agents.suites import ScenarioSpec
from contour_gym.envs.base import ContourVectorEnv
from contour_gym.envs.core import FEEDRATE
from contour_gym.loop import Trace


def auto_magnify(extent: float, worst: float) -> float:
    """The 1-2-5 step that draws an error ``worst`` at 5 % of ``extent`` (at least 1).

    >>> auto_magnify(0.04, 6e-6), auto_magnify(0.02, 4.6e-5), auto_magnify(0.01, 1.0)
    (200.0, 20.0, 1.0)
    """
    if not (worst > 0.0 and math.isfinite(worst)):
        return 1.0
    target = 0.05 * extent / worst
    if target <= 1.0:
        return 1.0
    decade = 10.0 ** math.floor(math.log10(target))
    return max(m * decade for m in (1.0, 2.0, 5.0) if m * decade <= target)


def scenario_plots(
    scenario: ScenarioSpec, traces: Mapping[str, Trace], env: Any, folder: Path
) -> list[Path]:
    """Write a scenario's plots into ``folder``; returns the files.

    ``<scenario>_contour.png``: the path and each policy's magnified contour beside
    |contour error| against time; ``<scenario>_feedrate.png`` (feedrate scenarios): feedrate
    against path length.

    Args:
        scenario: The scenario.
        traces: Policy label -> its trace (of the first seed).
        env: An env of the scenario (its path and contour placement).
        folder: Where to write.
    """
    from contour_gym.render import contour_figure, feedrate_figure

    task = cast(ContourVectorEnv, env.unwrapped).task
    contour = task.stage.contours[0]
    dense = task.path.point(np.linspace(0.0, task.path.length, 500))
    extent = float(np.ptp(dense[:, :2], axis=0).max())
    worst = max((float(np.nanmax(np.abs(tr.eps))) for tr in traces.values() if tr.eps.size),
                default=0.0)
    magnify = scenario.magnify or auto_magnify(extent, worst)
    fig = contour_figure(task.path, traces, axes=contour.axes[:2],
                         offset=(contour.offset or (0.0, 0.0))[:2], magnify=magnify)
    fig.suptitle(f"{scenario.name} ({scenario.env_id})")
    files = [folder / f"{scenario.name}_contour.png"]
    save_figure(fig, files[0], dpi=100)
    if scenario.task == FEEDRATE:
        fig = feedrate_figure(traces, title=f"{scenario.name} ({scenario.env_id}): feedrate")
        files.append(folder / f"{scenario.name}_feedrate.png")
        save_figure(fig, files[-1], dpi=100)
    return files
