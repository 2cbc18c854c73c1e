"""Per-member ring buffer of the reference arc lengths of the previous servo ticks.

Layout of one member's row ``hist`` (:data:`HIST_WIDTH` floats): ``hist[0]`` is the head
index, ``hist[1 : N_HIST + 1]`` the ring. The loop pushes the reference arc length after the
estimator has run, so during tick k :func:`history_at` ``(hist, 0)`` is the reference of
tick k - 1. A fresh (all-zero) buffer reads 0 before the start: the reference rested at s = 0.

After the ring, the row remembers the last :data:`PATH_MEMO` path points evaluated through
:func:`eval_path_memo` (``hist[N_HIST + 1]`` is the next slot to overwrite; each slot holds a
valid flag, the arc length and the 9 values). A point is a pure function of its arc length on
the member's path, so a remembered one is exact; a zeroed row remembers nothing. Within a
tick the loop's reference and every contour's estimator ask for the same points (the
contours of a dual gantry share the path).
"""

from __future__ import annotations

import math

from contour_gym._callee import callee
from contour_gym.paths._geom import eval_path

N_HIST = 128  # past reference arc lengths kept per member
PATH_MEMO = 3  # path points a row remembers (this tick's reference, the last one, a chord's end)
_SLOT = 11  # valid flag, arc length, the 9 values of eval_path
_MEMO = N_HIST + 2  # first slot
HIST_WIDTH = _MEMO + PATH_MEMO * _SLOT


@callee(forceinline=True)
def eval_path_memo(kind, s0, data, s, hist):
    """:func:`~contour_gym.paths._geom.eval_path` at ``s``, remembered in the row ``hist``.

    The same arc length, bit for bit (the sign of a zero included), gives the remembered
    values; another evaluates and overwrites the oldest slot. Typed once and inlined by LLVM
    (``forceinline``).
    """
    sign = math.copysign(1.0, s)
    for k in range(PATH_MEMO):
        o = _MEMO + k * _SLOT
        if hist[o] == 1.0 and hist[o + 1] == s and math.copysign(1.0, hist[o + 1]) == sign:
            return (hist[o + 2], hist[o + 3], hist[o + 4], hist[o + 5], hist[o + 6],
                    hist[o + 7], hist[o + 8], hist[o + 9], hist[o + 10])
    r = eval_path(kind, s0, data, s)
    k = int(hist[N_HIST + 1])
    o = _MEMO + k * _SLOT
    hist[o], hist[o + 1] = 1.0, s
    for i in range(9):
        hist[o + 2 + i] = r[i]
    hist[N_HIST + 1] = (k + 1) % PATH_MEMO
    return r


@callee
def history_push(hist, s):
    """Append arc length ``s`` to the ring buffer ``hist`` (hist[0] = head, hist[1:] = ring)."""
    head = int(hist[0]) + 1
    if head >= N_HIST:
        head = 0
    hist[0] = head
    hist[1 + head] = s


@callee
def history_at(hist, i):
    """Reference arc length ``i + 1`` ticks ago (0 <= i < N_HIST); 0 before the start."""
    j = int(hist[0]) - i
    if j < 0:
        j += N_HIST
    return hist[1 + j]


@callee
def ref_arc(hist, s, j):
    """Arc length of interpolation point ``j``.

    ``j >= 1``: the reference ``j`` ticks ago; ``j == 0``: the current reference ``s``;
    ``j < 0``: ``-j`` ticks ahead, extrapolated with the last interpolation step (the
    interpolator's next points; only used when the tool leads the reference).
    """
    if j >= 1:
        return history_at(hist, j - 1)
    return s - j * (s - history_at(hist, 0))
