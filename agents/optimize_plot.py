"""The optimised part drawn for a machinist: the new feeds and the error along the part.

:func:`part_figure` runs the new program once more on the machine (as ``contour-gym simulate``
runs it, recorded) and draws the machine's path twice: coloured by the feed each block is
programmed at (mm/min), and by the true contour error there (um), the worst point marked with
its G-code line.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.optimize import OptimizedPart, ccc_gains_of, counted_ticks, machine_loop
from contour_gym.api import make_scenario
from contour_gym.paths import GcodePath, from_gcode

Array = NDArray[np.float64]


def _run(result: OptimizedPart, plant: Any, ccc_gains: Any, read: dict[str, Any]
         ) -> tuple[Array, Array, Array, Any]:
    """The new program's recorded run: positions (T, 2), |error| (T,), tick lines (T,), path."""
    scenario = make_scenario(plant, from_gcode(result.text, **read))
    path: GcodePath = scenario.path  # type: ignore[assignment]
    loop = machine_loop(scenario, [path], [], ccc_gains_of(plant, ccc_gains), record=True)
    loop.run()
    trace = loop.trace()
    contour = scenario.preset.stage.contours[0]
    rows = np.isfinite(trace.s[0]) & np.all(np.isfinite(trace.x[0]), axis=1)
    offset = np.asarray(contour.offset or np.zeros(len(contour.axes)))
    xy = trace.x[0][rows][:, list(contour.axes)[:2]] - offset[:2]
    error, seg = counted_ticks(path, trace, 0, contour)
    lines = np.where(seg >= 0, np.asarray(path.segment_lines)[np.maximum(seg, 0)], -1)
    return xy, error, lines, path


def part_figure(result: OptimizedPart, plant: Any, ccc_gains: Any = "machine",
                **read: Any) -> Any:
    """Two panels of the part on ``plant``: coloured by the new feed and by the error.

    Args:
        result: What :func:`~agents.optimize.optimize_part` gave.
        plant: The machine it was optimised on.
        ccc_gains: The CCC it was optimised with ("machine", None or gains).
        **read: The program's :func:`~contour_gym.paths.from_gcode` options.

    Returns:
        A matplotlib figure (rapids drawn thin and grey; the worst point marked).
    """
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection

    xy, error, lines, _ = _run(result, plant, ccc_gains, read)
    mm = xy * 1e3
    feed = np.array([result.feeds.get(int(k), np.nan) * 6e4 if k >= 0 else np.nan
                     for k in lines])
    pieces = np.stack([mm[:-1], mm[1:]], axis=1)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.4))
    worst = int(np.argmax(np.where(lines >= 0, error, -1.0)))
    for ax, value, label in ((axes[0], feed, "new feed (mm/min)"),
                             (axes[1], error * 1e6, "|contour error| (um)")):
        ax.plot(mm[:, 0], mm[:, 1], color="0.8", lw=0.5)  # rapids and all
        cut = np.isfinite(value[:-1]) & (lines[:-1] >= 0)
        coloured = LineCollection(list(pieces[cut]), cmap="viridis", lw=1.6)
        coloured.set_array(value[:-1][cut])
        ax.add_collection(coloured)
        fig.colorbar(coloured, ax=ax, label=label, shrink=0.85)
        ax.plot(*mm[worst], "rx", ms=10, mew=2)
        right = mm[worst, 0] > np.mean(ax.get_xlim())  # the label on the side with room
        ax.annotate(f"worst {error[worst] * 1e6:.3g} um, line {int(lines[worst])}", mm[worst],
                    textcoords="offset points", xytext=(-8 if right else 8, 8), color="red",
                    fontsize=8, ha="right" if right else "left")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    after = result.after
    fig.suptitle(f"cycle {result.before['cycle_time']:.2f} s -> {after['cycle_time']:.2f} s, "
                 f"peak {after['max_contour_error'] * 1e6:.3g} um", fontsize=10)
    fig.tight_layout()
    return fig


__all__ = ["part_figure"]
