"""The slots of the kernel templates, as stubs: what each component must look like.

The templates (:mod:`contour_gym.loop.kernel`, :mod:`contour_gym.envs._kernel`,
:mod:`contour_gym.servo._bank`, :mod:`contour_gym.contour._many`) import these names from here
so that they read, lint and type-check as ordinary modules; :func:`contour_gym.jit.specialise`
drops that import statement and binds each name instead. The stubs are never compiled.

A *dispatched* slot (:data:`DISPATCHED`) takes a component code first: the kernel binds it to
a tuple of components (every built-in one, or just the run's when a run uses a component of
the user's) and calls component ``code`` (:func:`contour_gym.jit.dispatcher_source`). A
registered component itself has the stub's signature without the code.
"""

# ruff: noqa: N802, ARG001
from __future__ import annotations

import numba

# slot -> (its arguments after the code, whether it returns a value)
DISPATCHED: dict[str, tuple[str, bool]] = {
    "CTRL_CONTROL": ("p, s, i, r, r_dot, r_ddot, y, ts", True),
    "CTRL_COMMIT": ("p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max", False),
    "EST_FOOT": ("p, kind, s0, data, bound, p0, p1, p2, s, hist", True),
    "FRICTION": ("ax, fr, ad, bd, st, i, u, f_ext, h", False),
    "COMP_OUTPUT": ("p, s, i, r_dot, y, ts", True),
    "COMP_COMMIT": ("p, s, i, r_dot, y, ts", False),
    "CCC_OUTPUT": ("p, s, data, q, row, e, ts", True),
    "CCC_COMMIT": ("p, s, data, q, row, e, ts, out, saturated", False),
    "CCC_RELEASE": ("p, s, data, q, row, ts", False),
    "REWARD": ("comp, w", True),
    "TASK_APPLY": ("m, env, ec, b", False),
    "TASK_OBSERVE": ("m, path, env, ec, b, col", True),
}


@numba.njit(cache=True, inline="always")
def CTRL_CONTROL(code, p, s, i, r, r_dot, r_ddot, y, ts):
    """Axis controller: control of this tick (:mod:`contour_gym.servo.base`).

    Filled by :data:`contour_gym.servo.base.CONTROLLER_FAMILY`.
    """
    return 0.0


@numba.njit(cache=True, inline="always")
def CTRL_COMMIT(code, p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max):
    """Axis controller: state update once the tick's control is known.

    Filled by :data:`contour_gym.servo.base.CONTROLLER_FAMILY`.
    """


@numba.njit(cache=True, inline="always")
def EST_FOOT(code, p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Estimator: ``(ok, qx, qy, qz, tx, ty, tz, e2)`` (:mod:`contour_gym.contour`).

    Filled by :data:`contour_gym.contour.base.ESTIMATOR_FAMILY`.
    """
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@numba.njit(cache=True, inline="always")
def no_foot(p, kind, s0, data, bound, p0, p1, p2, s, hist):
    """Binds EST_FOOT for the exact search (``ground_truth``), which has no foot function."""
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


@numba.njit(cache=True, inline="always")
def no_compensation(p, s, i, r_dot, y, ts):
    """Binds COMP_OUTPUT and COMP_COMMIT when no axis compensates friction."""
    return 0.0


@numba.njit(cache=True, inline="always")
def FRICTION(code, ax, fr, ad, bd, st, i, u, f_ext, h):
    """Friction law ``code``: one plant substep (:mod:`contour_gym.plant.friction`).

    Filled by :data:`contour_gym.plant.friction.base.FRICTION_FAMILY`.
    """


@numba.njit(cache=True, inline="always")
def COMP_OUTPUT(code, p, s, i, r_dot, y, ts):
    """Friction compensation: this tick's share (:mod:`contour_gym.servo.compensation`).

    Filled by :data:`contour_gym.servo.compensation.COMPENSATION_FAMILY`.
    """
    return 0.0


@numba.njit(cache=True, inline="always")
def COMP_COMMIT(code, p, s, i, r_dot, y, ts):
    """Friction compensation: state update.

    Filled by :data:`contour_gym.servo.compensation.COMPENSATION_FAMILY`.
    """


@numba.njit(cache=True, inline="always")
def CCC_OUTPUT(code, p, s, data, q, row, e, ts):
    """CCC law: output for contour row ``q`` on error ``e`` (:mod:`contour_gym.ccc`).

    Filled by :data:`contour_gym.ccc.CCC_FAMILY`.
    """
    return 0.0


@numba.njit(cache=True, inline="always")
def CCC_COMMIT(code, p, s, data, q, row, e, ts, out, saturated):
    """CCC law: state update. Filled by :data:`contour_gym.ccc.CCC_FAMILY`."""


@numba.njit(cache=True, inline="always")
def CCC_RELEASE(code, p, s, data, q, row, ts):
    """CCC law: state update while the reference waits for the axes (after the commit).

    Filled by :data:`contour_gym.ccc.CCC_FAMILY`.
    """


@numba.njit(cache=True)
def RUN_MEMBERS(n, k0, config_row, loop, bank, noise, rec, lo, hi):
    """The loop's run on its views, bound to the loop's own ``run_members`` (env core)."""


@numba.njit(cache=True, inline="always")
def REWARD(code, comp, w):
    """Reward of one member from its components and weights (:mod:`contour_gym.rewards`).

    Filled by :data:`contour_gym.rewards.REWARD_FAMILY`.
    """
    return 0.0


@numba.njit(cache=True, inline="always")
def TASK_APPLY(code, m, env, ec, b):
    """Task: member ``b``'s clipped action sets what it acts on (:mod:`contour_gym.tasks`).

    Filled by :data:`contour_gym.tasks.base.TASK_FAMILY`.
    """


@numba.njit(cache=True, inline="always")
def TASK_OBSERVE(code, m, path, env, ec, b, col):
    """Task: member ``b``'s own observation columns from ``col``; the column after them.

    Filled by :data:`contour_gym.tasks.base.TASK_FAMILY`.
    """
    return col
