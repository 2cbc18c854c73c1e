"""Contouring metrics, used by tests, the harness, optimisers, envs and plots.

Every metric is a function of a few running sums (:class:`ErrorSums`), so the loop kernel can
accumulate them without storing traces, and a recorded trace gives identical numbers through
:func:`sums_from_trace`. All values are SI (m, s); reports convert to um/mm.

Definitions (per batch member), over the ticks from the start until the machine is in position
at the path end (the *arrival*), counting only ticks whose foot point lies on a cutting segment
while the reference is on one (at an exact stop: the block that ended there), so rapids and
other non-cutting moves of a G-code part never count, nor does a machine overshooting a rapid's
end past the next cut's start before that cut begins; on a plain path every segment cuts:

* ``max/mean/rms_contour_error``: max, mean and RMS of |eps| over ticks and contours.
* ``max/mean/rms_contour_error_per_contour``: the same per contour, shape (B, C) (003's
  tables report |eps_1| and |eps_2|; its fitness, eq. 38, sums their RMS values).
* ``cea``: 000's contour error average, the mean modulus of eps (equals the mean).
* ``p_e``: 003 eq. 39, ``(1/R) sum_k sum_axes |e(k)|``, and ``p_eps``: 003 eq. 40,
  ``(1/R) sum_k sum_contours |eps(k)|``, over the R samples taken every ``sample_every`` ticks
  (003 samples at 10 Hz; the presets say what they use, every tick by default).
* ``max/mean/rms_tracking_error``: per axis, shape (B, n_axes).
* ``peak_tracking_error``: the largest of the per-axis ``max_tracking_error``, shape (B,) (the
  one tracking figure of the episode's scalar metrics).
* ``chattering``: total variation of the saturated control command, summed over axes.
* ``cycle_time``: time from the start to the arrival, s (``inf`` if the member did not arrive).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from contour_gym._schema import state_schema

# the columns of the sums (the loop's kernel fills them: contour_gym.loop.kernel)
ACC_C = state_schema("contour sums", "abs", "sq", "max", "n", "s_abs", "s_n")
AC = ACC_C.col
ACC_A = state_schema("axis sums", "abs", "sq", "max", "tv", "s_abs")
AA = ACC_A.col

Array = NDArray[np.float64]


@dataclass
class ErrorSums:
    """Running sums of one or several windows of ticks, per batch member.

    Attributes:
        contour: (B, C, 6): sum |eps|, sum eps^2, max |eps|, ticks, and the sampled sum |eps|
            and sample count (:data:`ACC_C`).
        axis: (B, A, 5): sum |e|, sum e^2, max |e|, total variation of u, sampled sum |e|
            (:data:`ACC_A`).
    """

    contour: Array
    axis: Array

    @classmethod
    def zeros(cls, batch: int, n_contours: int, n_axes: int) -> ErrorSums:
        """Empty sums."""
        return cls(np.zeros((batch, n_contours, ACC_C.size)), np.zeros((batch, n_axes, ACC_A.size)))


def sums_from_trace(
    eps: Array, tracking: Array, u: Array, u0: Array | None = None, sample_every: int = 1
) -> ErrorSums:
    """Build the sums from recorded arrays (every tick counted).

    Args:
        eps: Contour error, (B, T, C) (or (T, C)).
        tracking: Tracking error r - p per axis, (B, T, A).
        u: Saturated control, (B, T, A).
        u0: Control before the first tick (default zero), (B, A).
        sample_every: Ticks between the samples of P_e and P_eps (from the first tick).

    Returns:
        The sums over the T ticks.
    """
    eps, tracking, u = (np.asarray(x, dtype=float) for x in (eps, tracking, u))
    if eps.ndim == 2:
        eps, tracking, u = eps[None], tracking[None], u[None]
    prev = np.zeros_like(u[:, :1]) if u0 is None else np.asarray(u0, dtype=float)[:, None]
    tv = np.abs(np.diff(np.concatenate([prev, u], axis=1), axis=1)).sum(axis=1)
    ae, at = np.abs(eps), np.abs(tracking)
    picks = np.arange(eps.shape[1]) % sample_every == 0
    contour = np.zeros(eps.shape[:1] + eps.shape[2:] + (ACC_C.size,))
    contour[..., AC.abs], contour[..., AC.sq] = ae.sum(1), (eps**2).sum(1)
    contour[..., AC.max], contour[..., AC.n] = ae.max(1, initial=0.0), eps.shape[1]
    contour[..., AC.s_abs], contour[..., AC.s_n] = ae[:, picks].sum(1), picks.sum()
    axis = np.zeros(tracking.shape[:1] + tracking.shape[2:] + (ACC_A.size,))
    axis[..., AA.abs], axis[..., AA.sq] = at.sum(1), (tracking**2).sum(1)
    axis[..., AA.max], axis[..., AA.tv] = at.max(1, initial=0.0), tv
    axis[..., AA.s_abs] = at[:, picks].sum(1)
    return ErrorSums(contour, axis)


def metrics_from_sums(sums: ErrorSums, cycle_time: Array | float) -> dict[str, Array]:
    """All metrics of the module docstring from running sums.

    Args:
        sums: The sums.
        cycle_time: (B,) or scalar cycle time, s.

    Returns:
        Name -> array of shape (B,), (B, n_axes) for the per-axis tracking metrics, or
        (B, C) for the per-contour ones.
    """
    c, a = sums.contour, sums.axis
    n = np.maximum(c[..., AC.n], 1.0)  # ticks per contour, (B, C)
    n_axis = n[:, :1]
    ns = np.maximum(c[..., AC.s_n], 1.0)  # samples per contour
    return {
        "max_contour_error": c[..., AC.max].max(axis=1),
        "mean_contour_error": c[..., AC.abs].sum(1) / n.sum(1),
        "rms_contour_error": np.sqrt(c[..., AC.sq].sum(1) / n.sum(1)),
        "cea": c[..., AC.abs].sum(1) / n.sum(1),
        "p_eps": (c[..., AC.s_abs] / ns).sum(1),
        "p_e": (a[..., AA.s_abs] / ns[:, :1]).sum(1),
        "max_contour_error_per_contour": c[..., AC.max].copy(),
        "mean_contour_error_per_contour": c[..., AC.abs] / n,
        "rms_contour_error_per_contour": np.sqrt(c[..., AC.sq] / n),
        "max_tracking_error": a[..., AA.max].copy(),
        "mean_tracking_error": a[..., AA.abs] / n_axis,
        "rms_tracking_error": np.sqrt(a[..., AA.sq] / n_axis),
        "peak_tracking_error": a[..., AA.max].max(axis=1, initial=0.0),
        "chattering": a[..., AA.tv].sum(1),
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
    "peak_tracking_error",
    "chattering",
)


def member_metrics(metrics: dict[str, Array], b: int) -> dict[str, float]:
    """The scalar metrics of batch member ``b`` as plain floats (for info dicts and reports)."""
    return {k: float(metrics[k][b]) for k in SCALAR_KEYS}
