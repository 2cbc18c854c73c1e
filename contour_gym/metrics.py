"""Contouring metrics, used by tests, the harness, optimisers, envs and plots.

Every metric is a function of a few running sums (``ErrorSums``), so the loop kernel can
accumulate them without storing traces, and a recorded trace gives identical numbers through
:func:`sums_from_trace`. All values are SI (m, s); reports convert to um/mm.

Definitions (per batch member; tick-sampled over the motion, i.e. from the first tick to the
tick the reference reaches the end of the path):

* ``max/mean/rms_contour_error``: max, mean and RMS of |eps| over ticks and contours.
* ``cea``: 000's contour error average, the mean modulus of eps (equals the mean).
* ``p_e``: 003 eq. 39, sum over axes of the mean |tracking error|.
* ``p_eps``: 003 eq. 40, sum over contours of the mean |eps| (003 samples at 10 Hz; we use
  every servo tick).
* ``max/mean/rms_tracking_error``: per axis, shape (B, n_axes).
* ``chattering``: total variation of the saturated control signal, summed over axes.
* ``cycle_time``: time for the reference to traverse the path, s (``inf`` if unfinished).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass
class ErrorSums:
    """Running sums of one or several windows of ticks, per batch member.

    Attributes:
        contour: (B, C, 4): sum |eps|, sum eps^2, max |eps|, number of ticks.
        axis: (B, A, 4): sum |e|, sum e^2, max |e|, total variation of u.
    """

    contour: Array
    axis: Array

    @classmethod
    def zeros(cls, batch: int, n_contours: int, n_axes: int) -> ErrorSums:
        """Empty sums."""
        return cls(np.zeros((batch, n_contours, 4)), np.zeros((batch, n_axes, 4)))


def sums_from_trace(eps: Array, tracking: Array, u: Array, u0: Array | None = None) -> ErrorSums:
    """Build the sums from recorded arrays.

    Args:
        eps: Contour error, (B, T, C) (or (T, C)).
        tracking: Tracking error r - p per axis, (B, T, A).
        u: Saturated control, (B, T, A).
        u0: Control before the first tick (default zero), (B, A).

    Returns:
        The sums over the T ticks.
    """
    eps, tracking, u = (np.asarray(x, dtype=float) for x in (eps, tracking, u))
    if eps.ndim == 2:
        eps, tracking, u = eps[None], tracking[None], u[None]
    prev = np.zeros_like(u[:, :1]) if u0 is None else np.asarray(u0, dtype=float)[:, None]
    tv = np.abs(np.diff(np.concatenate([prev, u], axis=1), axis=1)).sum(axis=1)
    ae, at = np.abs(eps), np.abs(tracking)
    contour = np.stack(
        [
            ae.sum(1),
            (eps**2).sum(1),
            ae.max(1, initial=0.0),
            np.full(ae.sum(1).shape, eps.shape[1]),
        ],
        axis=-1,
    )
    axis = np.stack([at.sum(1), (tracking**2).sum(1), at.max(1, initial=0.0), tv], axis=-1)
    return ErrorSums(contour.astype(float), axis)


def metrics_from_sums(sums: ErrorSums, cycle_time: Array | float) -> dict[str, Array]:
    """All metrics of the module docstring from running sums.

    Args:
        sums: The sums.
        cycle_time: (B,) or scalar cycle time, s.

    Returns:
        Name -> array of shape (B,), or (B, n_axes) for the per-axis tracking metrics.
    """
    c, a = sums.contour, sums.axis
    n = np.maximum(c[..., 3], 1.0)  # ticks per contour, (B, C)
    n_axis = n[:, :1]
    mean_abs_c = c[..., 0] / n
    return {
        "max_contour_error": c[..., 2].max(axis=1),
        "mean_contour_error": c[..., 0].sum(1) / n.sum(1),
        "rms_contour_error": np.sqrt(c[..., 1].sum(1) / n.sum(1)),
        "cea": c[..., 0].sum(1) / n.sum(1),
        "p_eps": mean_abs_c.sum(1),
        "p_e": (a[..., 0] / n_axis).sum(1),
        "max_tracking_error": a[..., 2],
        "mean_tracking_error": a[..., 0] / n_axis,
        "rms_tracking_error": np.sqrt(a[..., 1] / n_axis),
        "chattering": a[..., 3].sum(1),
        "cycle_time": np.broadcast_to(np.asarray(cycle_time, dtype=float), c.shape[:1]).copy(),
    }


SCALAR_KEYS = (
    "max_contour_error",
    "mean_contour_error",
    "rms_contour_error",
    "cycle_time",
    "cea",
    "p_e",
    "p_eps",
    "chattering",
)


def member_metrics(metrics: dict[str, Array], b: int) -> dict[str, float]:
    """The scalar metrics of batch member ``b`` as plain floats (for info dicts and reports)."""
    return {k: float(metrics[k][b]) for k in SCALAR_KEYS}
