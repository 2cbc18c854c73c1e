"""The CCC-gain task (``"ccc"``): each action sets the cross-coupled controller's PID gains.

For contour c, ``action[3c:3c+3]`` maps to (kp, ki, kd) by
``g = g_max (R^((a+1)/2) - 1) / (R - 1)`` with ``R = gain_range^2`` (:class:`GainMap`); the
observation ends with ``gains``, the action in force. The feedrate is the scenario's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
from numpy.typing import NDArray

from contour_gym._envstate import put
from contour_gym.tasks.base import Task, TaskConfig, TaskEnv, register_task

Array = NDArray[np.float64]


@numba.njit(cache=True, inline="always")
def action_to_gain(a, g_max, g_log):
    """The gain map: ``g_max (R^((a+1)/2) - 1) / (R - 1)``, ``g_log = ln R``."""
    a = min(max(a, -1.0), 1.0)
    return g_max * (math.exp(0.5 * (a + 1.0) * g_log) - 1.0) / (math.exp(g_log) - 1.0)


@numba.njit(cache=True, inline="always")
def apply_gains(m, env, ec, b):
    """Member ``b``'s CCC gains from its action (:class:`contour_gym.tasks.Task` ``apply``)."""
    for c in range(m.ccc_gains.shape[1]):
        for g in range(3):  # every CCC law starts its parameters with kp, ki, kd
            a = env.action[b, 3 * c + g]
            m.ccc_gains[b, c, g] = action_to_gain(a, env.g_max[g], env.g_log[g])


@numba.njit(cache=True, inline="always")
def observe_gains(m, path, env, ec, b, col):
    """The ``gains`` columns: the action in force."""
    for j in range(env.action.shape[1]):
        col = put(env.obs, b, col, env.action[b, j])
    return col


@dataclass(frozen=True)
class GainMap:
    """Actions in [-1, 1] <-> CCC gains, logarithmic between 0 and ``g_max`` (module docstring).

    Attributes:
        g_max: The largest (kp, ki, kd): ``gain_range`` times the preset's kp and ki (ki: 10
            kp where the preset has none), ``kd_scale`` times its kp.
        g_log: ``ln R`` per gain, ``R = gain_range^2``.
    """

    g_max: Array
    g_log: Array

    @classmethod
    def for_env(cls, config: TaskConfig, preset: Any, g0: Array) -> GainMap:
        """The map of an env with ``config`` on ``preset``, starting at gains ``g0``."""
        kp0 = g0[0] if g0[0] > 0 else preset.ccc_gains.kp
        ki0 = g0[1] if g0[1] > 0 else kp0 * 10.0
        r = config.gain_range
        g_max = np.array([kp0 * r, ki0 * r, kp0 * config.kd_scale])
        return cls(g_max, np.full(3, 2.0 * math.log(r)))

    def to_gains(self, action: Array, n_contours: int) -> Array:
        """Actions (..., 3C), clipped to [-1, 1], as gains (..., C, 3)."""
        a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        a = a.reshape(*a.shape[:-1], n_contours, 3)
        big_r = np.exp(self.g_log)
        return self.g_max * (np.exp(0.5 * (a + 1.0) * self.g_log) - 1.0) / (big_r - 1.0)

    def to_action(self, gains: Array) -> Array:
        """Inverse of :meth:`to_gains`, (..., C, 3) -> (..., 3C); gains above the range map above 1.

        Raises:
            ValueError: for negative or non-finite gains.
        """
        g = np.asarray(gains, dtype=float)
        if np.any(g < 0) or not np.all(np.isfinite(g)):
            raise ValueError(f"gains must be finite and >= 0 to have an action, got {g}")
        big_r = np.exp(self.g_log)
        a = 2.0 * np.log1p(g * (big_r - 1.0) / self.g_max) / self.g_log - 1.0
        return a.reshape(*g.shape[:-2], -1)


@dataclass(frozen=True)
class CCCGains(Task):
    """The CCC-gain task: 3 gains per contour; the observation ends with ``gains``."""

    def n_actions(self, n_contours: int) -> int:
        """Three gains (kp, ki, kd) per contour."""
        return 3 * n_contours

    def tail_size(self, n_contours: int) -> int:
        """The action in force."""
        return 3 * n_contours

    def override_range(self, env: TaskEnv) -> tuple[float, float]:
        """The scenario's feed override throughout (the slowest counted as 1)."""
        return 1.0, env.scenario.feed_override

    def reset(self, env: TaskEnv, members: NDArray[np.intp]) -> None:
        """The env's starting gains ``env.g0``, and the action that maps to them."""
        env.loop.set_ccc_gains(env.g0, members)
        gains = np.broadcast_to(env.g0, (len(members), env.n_contours, 3))
        env.arrays["action"][members] = np.clip(env.gains_to_action(gains), -1.0, 1.0)

    def random_path_control(self, tolerance: float) -> dict[str, Any]:
        """``"G64"`` blending within half the contour tolerance: a CNC's look-ahead.

        The CCC task holds the feed; without look-ahead a random path's sharp corners and
        tight curves would ask the axes for a velocity step (measured on 004's machine:
        520-600 um peaks on 5 of 8 random paths under ``"none"``). The blend deviates from
        the programmed corner by up to ``path_tolerance``, which the contour error counts:
        at G64's 10 um default that alone broke 004's 5 um tolerance; half the tolerance
        leaves the other half to the servo loop.
        """
        return {"path_control": "G64", "path_tolerance": 0.5 * tolerance}


CCC_GAINS = register_task(CCCGains("ccc", "ccc", "gains", apply_gains, observe_gains))
