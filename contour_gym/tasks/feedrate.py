"""The feedrate task (``"feedrate"``): each action changes the feed override.

``action[0]`` in [-1, 1] changes the override by ``action * max_feedrate_change``, kept within
``feedrate_range`` (or, with ``feedrate_target``, sets a target the override moves toward);
the observation ends with ``feedrate``: the override in force and the machine's speed along
the path over the block's programmed feed. CCC gains stay fixed (the env's ``ccc_gains``, or
none).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import NDArray

from contour_gym._envstate import EC, put
from contour_gym.tasks.base import Task, TaskConfig, TaskEnv, register_task

if TYPE_CHECKING:
    from contour_gym.presets import Preset

FEED_RANGE = (0.3, 1.0)  # random paths' programmed feeds, times the machine's feed limit


@numba.njit(cache=True, inline="always")
def apply_override(m, env, ec, b):
    """Member ``b``'s feed override moved by its action, within the env's range.

    The action is the change (in ``max_feedrate_change``), or with ``feedrate_target`` a
    target override on a log scale that the override moves toward, by at most that change
    (taken at once on the episode's first decision: the axes are at rest, and a tight curve
    near the start must not be entered at the scenario's override while the target is far).
    """
    now, change = m.override[b], env.action[b, 0]
    if ec[EC.target] != 0.0:
        a = min(max(change, -1.0), 1.0)
        mid = env.prior[b] if ec[EC.lim_a] != 0.0 else ec[EC.t_mid]
        if ec[EC.lim_span] != 0.0:  # EnvConfig.limit_span: the limit times span^a
            goal = min(max(mid * ec[EC.lim_span] ** a, ec[EC.t_lo]), ec[EC.t_hi])
        elif a >= 0.0:
            goal = mid * (ec[EC.t_hi] / mid) ** a
        else:
            goal = mid * (ec[EC.t_lo] / mid) ** -a
        if env.steps[b] == 0.0:  # the episode's first decision: the axes are still at rest
            m.override[b] = min(max(goal, ec[EC.ovr_lo]), ec[EC.ovr_hi])
            return
        change = min(max((goal - now) / ec[EC.dovr], -1.0), 1.0)
    ovr = now + change * ec[EC.dovr]
    m.override[b] = min(max(ovr, ec[EC.ovr_lo]), ec[EC.ovr_hi])


@numba.njit(cache=True, inline="always")
def observe_feedrate(m, path, env, ec, b, col):
    """The ``feedrate`` columns: override, and speed over the block's programmed feed."""
    f_block = path.feed[int(m.block[b])]
    col = put(env.obs, b, col, m.override[b])
    return put(env.obs, b, col, m.v[b] / f_block)


@dataclass(frozen=True)
class FeedrateOverride(Task):
    """The feedrate task: one action, the override's change; ``feedrate`` ends the observation."""

    def n_actions(self, n_contours: int) -> int:
        """One feed override change."""
        return 1

    def tail_size(self, n_contours: int) -> int:
        """The override, and the speed over the programmed feed."""
        return 2

    def override_range(self, env: TaskEnv) -> tuple[float, float]:
        """The env's ``feedrate_range``."""
        low, high = env.ovr_bounds
        return float(low), float(high)

    def reset(self, env: TaskEnv, members: NDArray[np.intp]) -> None:
        """The scenario's feed override."""
        env.loop.set_feed_override(env.scenario.feed_override, members)

    def path_defaults(self, preset: Preset) -> dict[str, Any]:
        """Random paths carry programmed feeds: ``feed_range`` 0.3 to 1 times the feed limit.

        The limit is the machine's ``max_feedrate`` (the preset's ``feedrate`` where it has
        none): the agent meets parts programmed at many feeds, none beyond what the machine
        can run.
        """
        top = preset.max_feedrate if math.isfinite(preset.max_feedrate) else preset.feedrate
        return {"feed_range": (FEED_RANGE[0] * top, FEED_RANGE[1] * top)}

    def random_path_control(self, tolerance: float) -> dict[str, Any]:
        """``"G61.1"``: the CNC stops at a random path's real corners, the agent sets the rest.

        The override cannot stop the axes (its floor is ``feedrate_range[0]``): under
        ``"none"`` a polyline's corners alone broke 004's 5 um tolerance at every constant
        override from 0.3 to 1 (15-25 um, the ideal model too; measured on 12 random paths),
        under ``"G61.1"`` the corners stay within it and the error follows the feed.
        """
        return {"path_control": "G61.1"}

    def fixed_ccc_gains(self, config: TaskConfig) -> Sequence[float] | None:
        """The env's ``ccc_gains`` if given (the loop then runs CCC), else none."""
        return config.ccc_gains


FEEDRATE_OVERRIDE = register_task(
    FeedrateOverride("feedrate", "feedrate", "feedrate", apply_override, observe_feedrate)
)
