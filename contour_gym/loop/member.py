"""What the env and the tasks may read of the loop's members, and set: the loop's one boundary.

The loop keeps its state in arrays of its own layout (:mod:`contour_gym.loop.state`); what a
caller outside the loop may see of it is :data:`Members`, one named tuple of views that
:func:`members` makes from the loop's blobs, indexed by member (and contour or axis):

==================  ==========  ==========================================================
field               shape       what
==================  ==========  ==========================================================
``s``               (B,)        the reference's arc length, m
``v``               (B,)        the reference's speed, m/s
``block``           (B,)        the reference's segment (the program's block), as a float
``override``        (B,)        feed override, a fraction of the programmed feeds (*set*)
``status``          (B,)        :data:`RUNNING`, :data:`FAILED`, :data:`PAUSED` or
                                :data:`ARRIVED` (int)
``progress``        (B, C)      arc length of the machine's foot point (unwrapped), m
``estimate``        (B, C)      contour error the CCC saw at the last tick, m
``error_sum``       (B, C)      sum of the true ``|contour error|`` over the last call's ticks
``ticks``           (B, C)      ticks counted in ``error_sum`` (the last call's)
``error_peak``      (B, C)      largest true ``|contour error|`` over the last call's ticks
``position``        (B, A)      true axis position, m
``measured``        (B, A)      measured axis position at the last tick (encoder, noise), m
``effort_travel``   (B, A)      total variation of the axis command over the last call
``effort_max``      (B, A)      the axis command's limit (the drive's saturation)
``contour_axes``    (C, 3)      the axis of each contour coordinate (-1 past its dimension)
``contour_offset``  (C, 3)      each contour's origin in the axes' frame, m
``path_at``         (B, 3)      where each member's path lies in the path bank (int)
``ccc_gains``       (B, C, 3)   each contour's CCC gains kp, ki, kd (*set*)
==================  ==========  ==========================================================

Every field but the two marked *set* is typed read-only: a task that writes one does not
compile. A new quantity a caller needs is one field here (its name, and the view it is).

A member's path is in the loop's path bank: :func:`path_bank` views the bank,
:func:`member_path` carves member ``b``'s :data:`~contour_gym.loop.state.PathArrays` from it
(``member_path(bank, m.path_at, b)``) and :func:`next_path` carves only when the path changes.
"""

from __future__ import annotations

from collections import namedtuple

import numba

from contour_gym._blob import readonly, view1, view2, view3
from contour_gym.loop.state import (
    FLOAT_AT,
    FT,
    INT_AT,
    LS,
    STATUS_ARRIVED,
    STATUS_FAILED,
    STATUS_OK,
    STATUS_PAUSED,
    loop_arrays,
    member_path,
    next_path,
    path_bank,
)
from contour_gym.metrics import AA, AC
from contour_gym.motion import IP, IS
from contour_gym.plant._kernel import AX, ST

RUNNING, FAILED, PAUSED, ARRIVED = STATUS_OK, STATUS_FAILED, STATUS_PAUSED, STATUS_ARRIVED

Members = namedtuple(
    "Members",
    ("s", "v", "block", "override", "status", "progress", "estimate", "error_sum", "ticks",
     "error_peak", "position", "measured", "effort_travel", "effort_max", "contour_axes",
     "contour_offset", "path_at", "ccc_gains"),
)


@numba.njit(cache=True, inline="always")
def members(floats, float_layout, ints, int_layout):
    """The :data:`Members` record of the loop whose blobs these are (views, made in place)."""
    ip_s = view2(floats, float_layout, FLOAT_AT.ip_s)
    acc_c = readonly(view3(floats, float_layout, FLOAT_AT.acc_c))
    acc_a = readonly(view3(floats, float_layout, FLOAT_AT.acc_a))
    return Members(
        readonly(ip_s[:, IS.s]),
        readonly(ip_s[:, IS.v]),
        readonly(ip_s[:, IS.seg]),
        view2(floats, float_layout, FLOAT_AT.ip_p)[:, IP.ovr],
        readonly(view1(ints, int_layout, INT_AT.status)),
        readonly(view3(floats, float_layout, FLOAT_AT.foot)[:, :, FT.progress]),
        readonly(view3(floats, float_layout, FLOAT_AT.last)[:, :, LS.est]),
        acc_c[:, :, AC.abs],
        acc_c[:, :, AC.n],
        acc_c[:, :, AC.max],
        readonly(view3(floats, float_layout, FLOAT_AT.ax_s)[:, :, ST.x]),
        readonly(view2(floats, float_layout, FLOAT_AT.y_last)),
        acc_a[:, :, AA.tv],
        readonly(view3(floats, float_layout, FLOAT_AT.ax_p)[:, :, AX.u_max]),
        readonly(view2(ints, int_layout, INT_AT.c_axes)),
        readonly(view2(floats, float_layout, FLOAT_AT.c_off)),
        readonly(view2(ints, int_layout, INT_AT.p_at)),
        view3(floats, float_layout, FLOAT_AT.ccc_p)[:, :, :3],
    )


@numba.njit(cache=True, inline="always")
def loop_and_members(floats, float_layout, ints, int_layout, part):
    """The loop's own views (for its ``run_members``, with ``part``'s scratch) and its record.

    A caller hands the first to the loop's run untouched and reads only the second.
    """
    loop = loop_arrays(floats, float_layout, ints, int_layout, part)
    return loop, members(floats, float_layout, ints, int_layout)


__all__ = [
    "ARRIVED", "FAILED", "PAUSED", "RUNNING", "Members", "loop_and_members", "member_path",
    "members", "next_path", "path_bank",
]
