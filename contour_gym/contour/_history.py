"""Per-member ring buffer of the reference arc lengths of the previous servo ticks.

Layout of one member's row ``hist`` (``N_HIST + 1`` floats): ``hist[0]`` is the head index,
``hist[1:]`` the ring. The loop pushes the reference arc length after the estimator has run,
so during tick k :func:`history_at` ``(hist, 0)`` is the reference of tick k - 1. A fresh
(all-zero) buffer reads 0 before the start: the reference rested at s = 0.
"""

from __future__ import annotations

import numba

N_HIST = 128  # past reference arc lengths kept per member


@numba.njit(cache=True)
def history_push(hist, s):
    """Append arc length ``s`` to the ring buffer ``hist`` (hist[0] = head, hist[1:] = ring)."""
    head = int(hist[0]) + 1
    if head >= N_HIST:
        head = 0
    hist[0] = head
    hist[1 + head] = s


@numba.njit(cache=True)
def history_at(hist, i):
    """Reference arc length ``i + 1`` ticks ago (0 <= i < N_HIST); 0 before the start."""
    j = int(hist[0]) - i
    if j < 0:
        j += N_HIST
    return hist[1 + j]


@numba.njit(cache=True)
def ref_arc(hist, s, j):
    """Arc length of interpolation point ``j``.

    ``j >= 1``: the reference ``j`` ticks ago; ``j == 0``: the current reference ``s``;
    ``j < 0``: ``-j`` ticks ahead, extrapolated with the last interpolation step (the
    interpolator's next points; only used when the tool leads the reference).
    """
    if j >= 1:
        return history_at(hist, j - 1)
    return s - j * (s - history_at(hist, 0))
