"""Kernel template: one controller's compiled law over a batch (see :class:`AxisControllers`)."""

from __future__ import annotations

import numba

from contour_gym.jit.slots import COMP_COMMIT, COMP_OUTPUT, CTRL_COMMIT, CTRL_CONTROL


@numba.njit(cache=True)
def control_all(ctrl, comp, p, s, cp, cs, ins, ts, out):
    """``out[b, a]`` = control plus compensation; ``ins``: (4, B, A) r, r', r'', y.

    ``ctrl`` and ``comp`` are the codes of the controller and the compensation (their slots).
    """
    n_axes = ins.shape[2]
    for b in range(ins.shape[1]):
        for a in range(n_axes):
            r, r_dot, r_ddot, y = ins[0, b, a], ins[1, b, a], ins[2, b, a], ins[3, b, a]
            i = b * n_axes + a
            u = CTRL_CONTROL(ctrl, p, s, i, r, r_dot, r_ddot, y, ts)
            out[b, a] = u + COMP_OUTPUT(comp, cp, cs, i, r_dot, y, ts)


@numba.njit(cache=True)
def commit_all(ctrl, comp, p, s, cp, cs, ins, ts, u_total, u_max):
    """Commit every member's state with its total (unsaturated) control."""
    n_axes = ins.shape[2]
    for b in range(ins.shape[1]):
        for a in range(n_axes):
            r, r_dot, r_ddot, y = ins[0, b, a], ins[1, b, a], ins[2, b, a], ins[3, b, a]
            i = b * n_axes + a
            u_comp = COMP_OUTPUT(comp, cp, cs, i, r_dot, y, ts)
            applied = min(max(u_total[b, a], -u_max[a]), u_max[a])
            CTRL_COMMIT(ctrl, p, s, i, r, r_dot, r_ddot, y, ts, u_total[b, a], applied, u_comp,
                        u_max[a])
            COMP_COMMIT(comp, cp, cs, i, r_dot, y, ts)
