"""Plots of a tuning run: the convergence curve and, for the PSO family, the schedules.

``convergence.png`` is the best-so-far fitness after every generation; ``schedules.png`` the
``(w, c1, c2)`` of every generation as :func:`agents.optim.pso.schedules` computes them.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from agents._files import save_figure
from agents.tune.result import TuneResult


def write_plots(result: TuneResult, folder: str | os.PathLike[str]) -> list[Path]:
    """Write ``convergence.png`` and, for the PSO family, ``schedules.png`` into ``folder``.

    Returns:
        The files written.
    """
    from matplotlib.figure import Figure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    gens = np.arange(1, len(result.history) + 1)
    fig = Figure(figsize=(6.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(gens, np.asarray(result.history) * 1e6, drawstyle="steps-post")
    ax.set(xlabel="generation", ylabel=f"best fitness ({result.settings['fitness']}, um)",
           title=f"tune {result.protocol}: {result.optimizer}, seed {result.seed}")
    ax.grid(True, alpha=0.3)
    written = [folder / "convergence.png"]
    save_figure(fig, written[0])
    sched = result.settings.get("schedules")
    if sched is not None:
        arr = np.asarray(sched)
        fig = Figure(figsize=(6.0, 4.0), layout="constrained")
        ax = fig.add_subplot()
        for j, label in enumerate(("w", "c1", "c2")):
            ax.plot(np.arange(1, len(arr) + 1), arr[:, j], label=label)
        ax.set(xlabel="generation", ylabel="coefficient",
               title=f"{result.optimizer}: inertia weight and learning factors")
        ax.legend()
        ax.grid(True, alpha=0.3)
        written.append(folder / "schedules.png")
        save_figure(fig, written[-1])
    return written
