"""Rewards you can swap: reward components, compiled defaults, Python rewards.

Every env step computes the same *components* per member (:data:`COMPONENTS`; each also lands in
``info["reward_components"]``, as Gymnasium's MuJoCo envs do):

| component | meaning | range |
|---|---|---|
| contour | mean abs(true contour error) over the decision's ticks / tolerance | [0, H] |
| peak | max abs(true contour error) over the decision's ticks / tolerance | [0, H] |
| chatter | mean over ticks and axes of abs(u_k - u_(k-1)) / u_max | [0, 2] |
| progress | arc length advanced / (nominal feedrate x decision time) | [0, P] |
| excess | max(0, peak - 1): how far the decision's peak broke the tolerance | [0, H - 1] |
| record | the rise of the episode's peak error in the decision, / tolerance | [0, H] |

with ``H = hard_limit / tolerance`` (beyond it the episode fails) and ``P`` the fastest progress
the feedrate range allows; an episode's ``record`` sums to its max contour error in
tolerances. A reward maps them to a number:

* a *compiled* reward (:class:`CompiledReward`, registered in :data:`REWARDS`): an njit
  ``fn(components, weights) -> float`` with named weights; it runs inside the env's compiled
  step. Built in: ``ccc`` (``-(w_contour contour + w_chatter chatter + w_record record)``,
  ``w_record`` 0 unless given: the peak's price, for agents judged by the max error) and
  ``feedrate``
  (``w_progress progress - w_time - w_excess excess``: the time cost of one step makes the
  episode's return ``(L / F_nom - cycle time) / decision time - w_excess sum(excess)`` at the
  default weights, so a faster part scores higher, as 004's objective has it; its ``margin``
  weight, 1 by default, moves where excess starts: ``max(0, peak - margin)``);
* a *Python* reward: any callable ``reward(components: dict[str, (B,) array]) -> (B,) array``,
  called once per step on the batch (slower; for trying ideas).

Each step's reward is clipped to the reward's range (the minimum and maximum over the corners
of the components' box, exact for rewards monotone in each component, or a Python reward's own
``reward_range`` attribute). The env's failure rule uses that range: see the env docstrings.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any, Protocol

import numba
import numpy as np
from numpy.typing import NDArray

from contour_gym._registry import Registry
from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import non_negative, positive
from contour_gym.jit import Family

COMPONENTS = state_schema(
    "reward components", "contour", "peak", "chatter", "progress", "excess", "record"
)
RC = COMPONENTS.col
Array = NDArray[np.float64]


class PythonReward(Protocol):
    """A reward written in Python: called on the batch's components each step."""

    def __call__(self, components: Mapping[str, Array]) -> Array:
        """(B,) rewards from the components, each (B,)."""
        ...


@dataclass(frozen=True)
class CompiledReward:
    """A registered compiled reward.

    Attributes:
        name: Registry name.
        weights: Schema of its named weights (the ``reward_weights`` env argument).
        fn: ``fn(components (N,), weights (W,)) -> float``, compiled.
        doc: The formula and the reasoning behind the default weights.
    """

    name: str
    weights: Schema
    fn: Any = field(repr=False)
    doc: str = ""


REWARDS: Registry[CompiledReward] = Registry("reward")


# the kernels' slot of a compiled reward (contour_gym.jit.slots)
REWARD_FAMILY = Family("reward", {"REWARD": attrgetter("fn")}, REWARDS.components)


def register_reward(reward: CompiledReward, *, replace: bool = False) -> CompiledReward:
    """Register a compiled reward; returns it."""
    return REWARDS.register(reward, replace=replace)


CCC_WEIGHTS = Schema(
    "ccc reward",
    contour=Param(1.0, non_negative, "per tolerance of mean contour error"),
    chatter=Param(10.0, non_negative, "per unit of normalised control variation"),
    record=Param(0.0, non_negative, "per tolerance the decision raises the episode's peak"),
)


_CW = CCC_WEIGHTS.col


@numba.njit(cache=True, inline="always")
def ccc_reward(comp, w):
    """``-(w_contour contour + w_chatter chatter + w_record record)`` (module docstring)."""
    c = _CW
    return -(w[c.contour] * comp[RC.contour] + w[c.chatter] * comp[RC.chatter]
             + w[c.record] * comp[RC.record])


FEEDRATE_WEIGHTS = Schema(
    "feedrate reward",
    progress=Param(1.0, non_negative, "per nominal step of progress"),
    time=Param(1.0, non_negative, "per step taken (the cycle time's price)"),
    excess=Param(30.0, non_negative, "per tolerance the peak error exceeds it"),
    margin=Param(1.0, positive, "the peak, in tolerances, above which excess is paid"),
)


_FW = FEEDRATE_WEIGHTS.col


@numba.njit(cache=True, inline="always")
def feedrate_reward(comp, w):
    """``w_progress progress - w_time - w_excess excess`` (module docstring).

    Excess counts from the ``margin`` weight m: ``max(peak - m, 0)``, the ``excess``
    component itself at m = 1 (the kernel computes it so). Below 1, an agent pays for coming
    within ``1 - m`` of the tolerance, which it then keeps with a margin on machines and
    paths it has not seen.
    """
    c = _FW
    excess = max(comp[RC.peak] - w[c.margin], 0.0)
    return w[c.progress] * comp[RC.progress] - w[c.time] - w[c.excess] * excess


CCC = register_reward(
    CompiledReward(
        "ccc", CCC_WEIGHTS, ccc_reward,
        doc="mean contour error in tolerances plus 10 x the normalised control variation: a "
        "CCC that removes 1 tolerance of error may add 0.1 of u_max of chattering per tick",
    )
)
FEEDRATE = register_reward(
    CompiledReward(
        "feedrate", FEEDRATE_WEIGHTS, feedrate_reward,
        doc="1 per nominal step of progress, minus 1 per step taken, minus 30 per tolerance "
        "of excess peak error: the return is the cycle time saved over the nominal feedrate's, "
        "in decisions, less the excess. 30, not less: a corner breaks the tolerance for only a "
        "few decisions, and at 10 the fastest constant feedrate (twice the tolerance at the "
        "vertex of Feedrate-Corner-v0) out-scored the nominal one that keeps it "
        "(benchmarks/task_difficulty.py)",
    )
)


def component_bounds(hard_over_tol: float, max_progress: float) -> tuple[Array, Array]:
    """Lower and upper bounds of each component (module docstring)."""
    lo = np.zeros(COMPONENTS.size)
    hi = np.zeros(COMPONENTS.size)
    hi[RC.contour] = hi[RC.peak] = hard_over_tol
    hi[RC.chatter] = 2.0
    hi[RC.progress] = max_progress
    hi[RC.excess] = max(hard_over_tol - 1.0, 0.0)
    hi[RC.record] = hard_over_tol
    return lo, hi


def reward_range(
    reward: CompiledReward | Callable[..., Any], weights: Array, lo: Array, hi: Array
) -> tuple[float, float]:
    """The reward's range over the components' box (its corners; module docstring)."""
    declared = getattr(reward, "reward_range", None)
    if declared is not None:
        low, high = (float(x) for x in declared)
        return low, high
    corners = np.array(list(itertools.product(*zip(lo, hi, strict=True))), dtype=float)
    if isinstance(reward, CompiledReward):
        values = np.empty(corners.shape[0])
        _compiled_corners(reward.fn, corners, weights, values)
    else:
        values = np.asarray(reward(components_dict(corners)), dtype=float)
    if not np.all(np.isfinite(values)):
        raise ValueError("the reward is not finite over the components' range")
    return float(values.min()), float(values.max())


def _compiled_corners(fn: Any, corners: Array, w: Array, out: Array) -> None:
    for i in range(corners.shape[0]):
        out[i] = fn(corners[i], w)


def components_dict(rows: Array) -> dict[str, Array]:
    """(B, N) component rows as a name -> (B,) dict."""
    return {name: rows[:, j].copy() for j, name in enumerate(COMPONENTS.names)}


__all__ = [
    "CCC",
    "COMPONENTS",
    "FEEDRATE",
    "REWARDS",
    "CompiledReward",
    "PythonReward",
    "component_bounds",
    "components_dict",
    "register_reward",
    "reward_range",
]
