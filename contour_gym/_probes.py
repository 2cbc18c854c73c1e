"""Kernel template: probes that compile the servo loop's shared pieces on their own.

The loop kernel *calls* the exact search (:func:`ground_truth_from`) and each estimator's core
(compiled once, shared by every kernel). Calling them here, with the arguments built exactly as
:func:`contour_gym._loopkernel.run_ticks` builds them (so with the same types), compiles and
caches them in a process of their own, in parallel with other warm-ups
(:mod:`contour_gym._precompile`); the loop's compile then loads them from the cache.
"""

from __future__ import annotations

import numba

from contour_gym._blob import borrow
from contour_gym._loopstate import loop_arrays, path_arrays
from contour_gym._slots import EST_FOOT
from contour_gym.contour._kernel import ground_truth_from


@numba.njit(cache=True)
def searches(run, fb, fl, ib, il, pk, pb, pl, dim):
    """The exact search from the machine's foot point, as the loop calls it (if ``run``).

    The probes exist to be compiled: with ``run`` False they return before any call.
    """
    P = path_arrays(borrow(pk), borrow(pb), pl)
    if not run:
        return 0.0
    return ground_truth_from(P.kind, P.s0, P.data, P.bound, dim, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                             0.0)[0]  # fmt: skip


@numba.njit(cache=True)
def estimators(n, fb, fl, ib, il, pk, pb, pl):
    """Every estimator ``0 .. n - 1`` of the slot ``EST_FOOT``, as the loop calls them.

    Compiled for every estimator the slot holds, whatever ``n`` (0: compile only).
    """
    A = loop_arrays(borrow(fb), fl, borrow(ib), il)
    P = path_arrays(borrow(pk), borrow(pb), pl)
    total = 0.0
    for code in range(n):
        foot = EST_FOOT(code, A.est_p, P.kind, P.s0, P.data, P.bound, 0.0, 0.0, 0.0, 0.0,
                        A.hist[0])  # fmt: skip
        total += foot[1]
    return total
