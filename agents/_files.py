"""Plots a run saves: checked for size before they are drawn, written whole or not at all."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from contour_gym.files import write_atomically
from contour_gym.limits import check_size

MAX_PLOT_BYTES = 1e9  # a plot's pixels (RGBA) in memory at most
MAX_PLOT_SIDE = 1 << 16  # pixels on a side at most (matplotlib's Agg draws no more)


def check_plot(inches: Sequence[float], dpi: float) -> None:
    """Refuse (ValueError) a plot of ``inches`` (width, height) at ``dpi`` too large to draw.

    Past :data:`MAX_PLOT_SIDE` pixels on a side, or :data:`MAX_PLOT_BYTES` (or the memory
    available) of pixels.
    """
    width, height = (float(x) * dpi for x in inches)
    what = f"a {width:.0f} x {height:.0f} pixel plot (dpi {dpi:g})"
    if max(width, height) > MAX_PLOT_SIDE:
        raise ValueError(f"{what} is more than {MAX_PLOT_SIDE} pixels on a side: lower --dpi")
    check_size(4.0 * width * height, what, "--dpi", cap=MAX_PLOT_BYTES)


def save_figure(fig: Any, target: Path, dpi: float = 120.0) -> None:
    """Save a matplotlib figure whole or not at all; the format from the file name.

    Raises:
        ValueError: for a size at ``dpi`` past :data:`MAX_PLOT_SIDE` pixels on a side or
            :data:`MAX_PLOT_BYTES` (or the memory available), before it is drawn.
    """
    check_plot(fig.get_size_inches(), dpi)
    fmt = target.suffix[1:] or "png"
    write_atomically(target, lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))
