"""Plots: the path with the actual contour's error magnified, and contour error vs time.

mm and um appear here only (SI inside).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from numpy.typing import NDArray

from contour_gym.loop import Trace
from contour_gym.paths import Path


def magnified(
    path: Path, positions: NDArray[np.float64], s_hint: NDArray[np.float64], factor: float
) -> NDArray[np.float64]:
    """Move each position away from its foot point on ``path`` by ``factor`` (004's 200x plot).

    Args:
        path: The contour.
        positions: (T, dim) actual positions in path coordinates, m.
        s_hint: (T,) reference arc length per position (to keep the traversed branch).
        factor: Magnification of the error.

    Returns:
        (T, dim) points ``q + factor (p - q)`` with ``q`` the foot point.
    """
    s, _ = path.nearest(positions, s_hint=s_hint)
    foot = path.point(s)
    return foot + factor * (positions - foot)


def contour_figure(
    path: Path,
    runs: Mapping[str, Trace],
    *,
    axes: tuple[int, ...] = (0, 1),
    offset: tuple[float, ...] = (0.0, 0.0),
    magnify: float = 200.0,
    member: int = 0,
) -> Figure:
    """Two panels: path vs magnified actual contour (mm), and |contour error| vs time (um).

    Args:
        path: The contour.
        runs: Label -> trace of one run each.
        axes: The stage axes drawing the first two path coordinates.
        offset: The contour's offset in those coordinates, m.
        magnify: Error magnification of the left panel.
        member: Batch member to plot.

    Returns:
        The figure (caller saves or converts it).
    """
    fig = Figure(figsize=(11, 4.6))
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    dense = path.point(np.linspace(0.0, path.length, 2000))
    left.plot(dense[:, 0] * 1e3, dense[:, 1] * 1e3, "k-", lw=1.0, label="path")
    for label, tr in runs.items():
        live = np.all(np.isfinite(tr.x[member]), axis=1)  # rows after the end are NaN
        x = tr.x[member][live]
        pos = x[:, list(axes)] - np.asarray(offset)
        if path.dim == 3:
            pos = np.column_stack([pos, x[:, 2]])
        big = magnified(path, pos, tr.s[member][live], magnify)
        left.plot(big[:, 0] * 1e3, big[:, 1] * 1e3, lw=1.0, label=f"{label} (error x{magnify:g})")
        err = np.abs(tr.eps[member][live]).max(axis=1) * 1e6
        right.plot(tr.t[live], err, lw=1.0, label=label)
    left.set(xlabel="x (mm)", ylabel="y (mm)", title=f"{path.name}: contour", aspect="equal")
    right.set(xlabel="time (s)", ylabel="|contour error| (um)", title="contour error")
    for ax in (left, right):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def figure_to_array(fig: Figure) -> NDArray[np.uint8]:
    """Render a figure into an (H, W, 3) uint8 RGB array."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.ascontiguousarray(np.asarray(canvas.buffer_rgba())[..., :3])
