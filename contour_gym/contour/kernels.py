"""Compiled building blocks for your own estimator (see :mod:`contour_gym.contour.base`).

* ``eval_path(kind, s0, data, s)``: the path's point, dP/ds and d2P/ds2 at arc length ``s``
  (9 floats), from the path table every foot function receives.
* ``line_foot(p0, p1, p2, ax, ay, az, ux, uy, uz)``: foot of the tool on the line through a
  with direction u.
* ``far_off(p0, p1, p2, rx, ry, rz, tx, ty, tz, kx, ky, kz, max_turn)``: whether the tracking
  error spans more than ``max_turn`` rad of the path's turning (a linearisation at the
  reference no longer describes the path: give up and let the exact search answer).
* ``FAIL``: the return tuple of a foot function that gives up.

All are numba functions; call them from your ``@numba.njit`` foot function.
"""

from __future__ import annotations

from contour_gym.contour._estimators import FAIL, far_off, line_foot
from contour_gym.paths._geom import eval_path

__all__ = ["FAIL", "eval_path", "far_off", "line_foot"]
