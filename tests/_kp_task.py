"""A third task kind, written as a user would: one action per contour sets the CCC's kp alone."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

from contour_gym.envs import CCCEnv, CCCVectorEnv
from contour_gym.tasks import Task, put_observation
from contour_gym.tasks.ccc import action_to_gain


@numba.njit(cache=True, inline="always")
def apply_kp(m, env, ec, b):
    for c in range(m.ccc_gains.shape[1]):
        m.ccc_gains[b, c, 0] = action_to_gain(env.action[b, c], env.g_max[0], env.g_log[0])
        m.ccc_gains[b, c, 1] = 0.0
        m.ccc_gains[b, c, 2] = 0.0


@numba.njit(cache=True, inline="always")
def observe_kp(m, path, env, ec, b, col):
    for j in range(env.action.shape[1]):
        col = put_observation(env.obs, b, col, env.action[b, j])
    return col


@dataclass(frozen=True)
class KpOnly(Task):
    def n_actions(self, n_contours: int) -> int:
        return n_contours

    def tail_size(self, n_contours: int) -> int:
        return n_contours

    def override_range(self, env: Any) -> tuple[float, float]:
        return 1.0, env.scenario.feed_override

    def reset(self, env: Any, members: Any) -> None:
        env.loop.set_ccc_gains(0.0, members)
        env.arrays["action"][members] = -1.0  # kp = 0


KP_ONLY = KpOnly("kp_only", "ccc", "kp", apply_kp, observe_kp)


class KpEnv(CCCEnv):
    """The CCC env's machine and reward with the kp-only task."""

    kind = "kp_only"


class KpVectorEnv(CCCVectorEnv):
    """Vector version of :class:`KpEnv`."""

    kind = "kp_only"


def kp_actions(kp_action: float, n: int) -> np.ndarray:
    """The CCC env's action equal to ``kp_action`` on the kp-only task: ki = kd = 0 (a = -1)."""
    return np.array([kp_action, -1.0, -1.0] * n, dtype=np.float32)
