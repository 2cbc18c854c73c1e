"""The slots of the kernel templates, as stubs: what each component must look like.

The templates (:mod:`contour_gym._loopkernel`, :mod:`contour_gym.envs._kernel`,
:mod:`contour_gym.servo._bank`, :mod:`contour_gym.contour._many`) import these names from here
so that they read, lint and type-check as ordinary modules; :func:`contour_gym._compile.specialise`
drops that import statement and binds each name to a registered component instead. The stubs
are never compiled.
"""

# ruff: noqa: N802, ARG001
from __future__ import annotations

from typing import Any

import numba


@numba.njit(cache=True, inline="always")
def CTRL_CONTROL(p, s, i, r, r_dot, r_ddot, y, ts):
    """Axis controller: control of this tick (:mod:`contour_gym.servo.base`)."""
    return 0.0


@numba.njit(cache=True, inline="always")
def CTRL_COMMIT(p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max):
    """Axis controller: state update once the tick's control is known."""


@numba.njit(cache=True, inline="always")
def EST_FOOT(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Estimator: ``(ok, qx, qy, qz, tx, ty, tz, e2)`` (:mod:`contour_gym.contour`)."""
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


EST_SEARCH: Any = True  # the estimator is the exact search itself (ground truth)


@numba.njit(cache=True, inline="always")
def unused_law(ax, fr, ad, bd, st, i, u, f_ext, h):
    """Binds the friction slots a stage does not use (never called)."""


@numba.njit(cache=True, inline="always")
def no_compensation(p, s, i, r_dot, y, ts):
    """Binds COMP_OUTPUT and COMP_COMMIT when no axis compensates friction."""
    return 0.0


@numba.njit(cache=True, inline="always")
def FRICTION_0(ax, fr, ad, bd, st, i, u, f_ext, h):
    """Friction law in slot 0: one plant substep (:mod:`contour_gym.plant.friction`)."""


FRICTION_1 = FRICTION_0
FRICTION_2 = FRICTION_0
FRICTION_3 = FRICTION_0


@numba.njit(cache=True, inline="always")
def COMP_OUTPUT(p, s, i, r_dot, y, ts):
    """Friction compensation: this tick's share (:mod:`contour_gym.servo.compensation`)."""
    return 0.0


@numba.njit(cache=True, inline="always")
def COMP_COMMIT(p, s, i, r_dot, y, ts):
    """Friction compensation: state update."""


@numba.njit(cache=True, inline="always")
def CCC_OUTPUT(p, s, data, q, row, e, ts):
    """CCC law: output for contour row ``q`` on error ``e`` (:mod:`contour_gym.ccc`)."""
    return 0.0


@numba.njit(cache=True, inline="always")
def CCC_COMMIT(p, s, data, q, row, e, ts, out, saturated):
    """CCC law: state update."""


@numba.njit(cache=True)
def RUN_TICKS(n, k0, cf, fb, fl, ib, il, pk, pb, pl, noise, rec):
    """The specialised loop's run (:mod:`contour_gym._loopkernel`)."""


@numba.njit(cache=True, inline="always")
def REWARD(comp, w):
    """Reward of one member from its components and weights (:mod:`contour_gym.rewards`)."""
    return 0.0
