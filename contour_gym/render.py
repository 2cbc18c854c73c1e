"""Plots: the contour error magnified and vs time, a part by its error, feedrate vs length.

mm and um appear here only (SI inside).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from numpy.typing import NDArray

from contour_gym.loop import Trace
from contour_gym.paths import Path

CONTOUR_INCHES = (11.0, 4.6)  # the size of :func:`contour_figure`, inches
PART_HEIGHT = 4.6  # the height of :func:`part_figure`, inches (its width grows with its runs)


def _path_positions(
    path: Path, trace: Trace, axes: tuple[int, ...], offset: tuple[float, ...], member: int
) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    """The ticks a member ran, and its axis positions there in path coordinates, m.

    ``axes`` and ``offset`` place the first two path coordinates; a 3-D path's z is axis 2.
    """
    live = np.all(np.isfinite(trace.x[member]), axis=1)  # rows after the end are NaN
    x = trace.x[member][live]
    pos = x[:, list(axes)] - np.asarray(offset)
    if path.dim == 3:
        pos = np.column_stack([pos, x[:, 2]])
    return live, pos


def magnified(
    path: Path, positions: NDArray[np.float64], s_ref: NDArray[np.float64], factor: float
) -> NDArray[np.float64]:
    """Move each position away from its foot point on ``path`` by ``factor`` (004's 200x plot).

    Args:
        path: The contour.
        positions: (T, dim) actual positions of one run in tick order, path coordinates, m.
        s_ref: (T,) the reference's arc length at each position.
        factor: Magnification of the error.

    Returns:
        (T, dim) points ``q + factor (p - q)`` with ``q`` the true foot point, as the servo
        loop tracks it (:meth:`~contour_gym.paths.Path.track`).
    """
    s, _ = path.track(positions, s_ref)
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
    fig = Figure(figsize=CONTOUR_INCHES, layout="constrained")
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    dense = path.point(np.linspace(0.0, path.length, 2000))
    left.plot(dense[:, 0] * 1e3, dense[:, 1] * 1e3, "k-", lw=1.0, label="path")
    for label, tr in runs.items():
        live, pos = _path_positions(path, tr, axes, offset, member)
        big = magnified(path, pos, tr.s[member][live], magnify)
        left.plot(big[:, 0] * 1e3, big[:, 1] * 1e3, lw=1.0, label=f"{label} (error x{magnify:g})")
        err = np.abs(tr.eps[member][live]).max(axis=1) * 1e6
        right.plot(tr.t[live], err, lw=1.0, label=label)
    left.set(xlabel="x (mm)", ylabel="y (mm)", title=f"{path.name}: contour", aspect="equal")
    right.set(xlabel="time (s)", ylabel="|contour error| (um)", title="contour error")
    for ax in (left, right):
        ax.grid(alpha=0.3)
    _legend_below(fig, left)  # the right panel's lines have the left's colours, in order
    return fig


def _legend_below(fig: Figure, ax: Axes) -> None:
    """One legend of ``ax``'s lines under the panels.

    Not matplotlib's ``loc="best"``, which counts every data point under each candidate box:
    3.6 s of the 6.4 s three bench scenarios' plots took (profiled).
    """
    lines = ax.get_lines()
    fig.legend(handles=lines, loc="outside lower center", ncols=min(len(lines), 4), fontsize=8)


def feedrate_figure(
    runs: Mapping[str, Trace], *, member: int = 0, title: str = "feedrate"
) -> Figure:
    """Feedrate (mm/min) against path length (mm), one line per run (004's feedrate plots).

    The feedrate is the reference's path speed (the interpolator's, after the override and
    the planning), the path length its arc length.

    Args:
        runs: Label -> trace of one run each.
        member: Batch member to plot.
        title: The panel's title.

    Returns:
        The figure (caller saves or converts it).
    """
    fig = Figure(figsize=(8, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    for label, tr in runs.items():
        live = np.isfinite(tr.s[member]) & np.all(np.isfinite(tr.x[member]), axis=1)
        ax.plot(tr.s[member][live] * 1e3, tr.v[member][live] * 60e3, lw=1.0, label=label)
    ax.set(xlabel="path length (mm)", ylabel="feedrate (mm/min)", title=title)
    ax.grid(alpha=0.3)
    _legend_below(fig, ax)
    return fig


def part_figure(
    path: Path,
    runs: Mapping[str, Trace],
    *,
    axes: tuple[int, ...] = (0, 1),
    offset: tuple[float, ...] = (0.0, 0.0),
    member: int = 0,
    title: str | None = None,
) -> Figure:
    """A part's tool path per run (x-y, mm), the cutting moves coloured by |contour error| (um).

    One panel per run: the machine's actual positions on the cutting moves as a line coloured
    by the |contour error| there, on one colour scale shared by the runs (the colour bar), the
    worst point marked with its value, and the program's rapids and other non-cutting moves
    as thin dashed grey lines. A tick is on a cutting move as the metrics count it
    (:mod:`contour_gym.metrics`): its true foot point (as the loop tracks it,
    :meth:`~contour_gym.paths.Path.track`) lies on a cutting segment and so does the
    reference (at a segment end: the segment that ends there); a path without ``cutting``
    flags cuts everywhere. A 3-D part is drawn from above.

    Args:
        path: The part as the machine runs it (a G-code part mapped onto its axes).
        runs: Label -> trace of one run each.
        axes: The stage axes drawing the first two path coordinates.
        offset: The contour's offset in those coordinates, m.
        member: Batch member to plot.
        title: Name of the part in the panel titles (default: the path's name).

    Returns:
        The figure (caller saves or converts it).
    """
    n = path.table.n_segments
    cutting = np.asarray(getattr(path, "cutting", np.ones(n, dtype=bool)), dtype=bool)
    drawn = {label: _cutting_strokes(path, tr, cutting, axes, offset, member)
             for label, tr in runs.items()}
    top = max((float(err.max()) for _, err in drawn.values() if err.size), default=0.0)
    norm = Normalize(0.0, top if top > 0.0 else 1.0)
    idle = _idle_points(path, cutting) * 1e3
    width, height = np.ptp(path.point(np.linspace(0.0, path.length, 2000))[:, :2], axis=0)
    aspect = float(np.clip(width / max(height, 1e-9), 0.5, 2.5))  # panel shape, as drawn
    inches = (len(drawn) * (3.3 * aspect + 0.7) + 1.0, PART_HEIGHT)
    fig = Figure(figsize=inches, layout="compressed")
    FigureCanvasAgg(fig)
    panels = fig.subplots(1, len(drawn), squeeze=False)[0]
    for ax, (label, (strokes, err)) in zip(panels, drawn.items(), strict=True):
        ax.plot(idle[:, 0], idle[:, 1], "--", lw=0.6, color="0.6", label="rapid / non-cutting")
        lines = LineCollection(list(strokes * 1e3), cmap="viridis", norm=norm, linewidths=1.8)
        lines.set_array(err)
        ax.add_collection(lines)
        _mark_worst(ax, strokes, err)
        ax.autoscale_view()
        ax.set(xlabel="x (mm)", ylabel="y (mm)", title=f"{title or path.name}: {label}",
               aspect="equal")
        ax.grid(alpha=0.3)
    if drawn:
        fig.colorbar(lines, ax=list(panels), label="|contour error| (um)")
        if idle.size:
            fig.legend(handles=panels[0].get_lines()[:1], loc="outside lower center", fontsize=8)
    return fig


def _cutting_strokes(
    path: Path, trace: Trace, cutting: NDArray[np.bool_], axes: tuple[int, ...],
    offset: tuple[float, ...], member: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(N, 2, 2) x-y strokes between consecutive ticks on cutting moves (m), and their error (um).

    A stroke's error is the larger |contour error| of its two ticks (over contours).
    """
    live, pos = _path_positions(path, trace, axes, offset, member)
    foot, _ = path.track(pos, trace.s[member][live])
    t = path.table
    seg = np.clip(np.searchsorted(t.s0, foot, side="right") - 1, 0, t.n_segments - 1)
    ref = np.clip(np.searchsorted(t.s0, trace.s[member][live], side="left") - 1, 0,
                  t.n_segments - 1)
    cut = cutting[seg] & cutting[ref]
    err = np.abs(trace.eps[member][live]).max(axis=1) * 1e6
    both = cut[:-1] & cut[1:]
    strokes = np.stack([pos[:-1, :2], pos[1:, :2]], axis=1)[both]
    return strokes, np.maximum(err[:-1], err[1:])[both]


def _mark_worst(ax: Axes, strokes: NDArray[np.float64], err: NDArray[np.float64]) -> None:
    """Mark the stroke of largest error (a red cross and its value in um)."""
    if not err.size:
        return
    k = int(np.argmax(err))
    x, y = strokes[k, 1, 0] * 1e3, strokes[k, 1, 1] * 1e3
    ax.plot([x], [y], "x", color="red", ms=9, mew=2, zorder=5)
    ax.annotate(f"max {err[k]:.3g} um", (x, y), xytext=(6, 6), textcoords="offset points",
                color="red", fontsize=8, zorder=5)


def _idle_points(path: Path, cutting: NDArray[np.bool_], per_segment: int = 48
                 ) -> NDArray[np.float64]:
    """x-y points along the non-cutting segments (m); a NaN row ends each unbroken run."""
    idle = np.flatnonzero(~cutting)
    s0 = path.table.s0
    pieces = []
    for run in np.split(idle, np.flatnonzero(np.diff(idle) != 1) + 1) if idle.size else ():
        s = np.concatenate([np.linspace(s0[i], s0[i + 1], per_segment) for i in run])
        pieces += [path.point(s)[:, :2], np.full((1, 2), np.nan)]
    return np.concatenate(pieces) if pieces else np.empty((0, 2))


def figure_to_array(fig: Figure) -> NDArray[np.uint8]:
    """Render a figure into an (H, W, 3) uint8 RGB array."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return np.ascontiguousarray(np.asarray(canvas.buffer_rgba())[..., :3])
