"""The task kind of an env as a strategy: :class:`Task`, the registry and the kernels' slots."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass, field
from operator import attrgetter
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from contour_gym._registry import Registry
from contour_gym.jit import Family

if TYPE_CHECKING:
    from contour_gym.api import Scenario
    from contour_gym.loop import ServoLoop
    from contour_gym.presets import Preset


class TaskEnv(Protocol):
    """What a task reads and sets of the env core (:class:`contour_gym.envs.core.ContourTask`).

    The env core imports the tasks, not the other way round: a task sees the env through
    this.
    """

    @property
    def loop(self) -> ServoLoop:
        """The members' servo loop."""

    @property
    def scenario(self) -> Scenario:
        """The env's scenario (its ``feed_override``)."""

    @property
    def arrays(self) -> dict[str, NDArray[np.float64]]:
        """The env's arrays by name (``"action"``: the last actions, one row per member)."""

    @property
    def n_contours(self) -> int:
        """Contours of the stage."""

    @property
    def g0(self) -> NDArray[np.float64]:
        """The CCC gains (kp, ki, kd) the action map is centred on."""

    @property
    def ovr_bounds(self) -> NDArray[np.float64]:
        """The feed override range (``EnvConfig.feedrate_range``)."""

    def gains_to_action(self, gains: NDArray[np.float64]) -> NDArray[np.float64]:
        """CCC gains (..., C, 3) as the actions that map to them."""


class TaskConfig(Protocol):
    """What a task reads of the env's arguments (:class:`contour_gym.envs.config.EnvConfig`)."""

    @property
    def ccc_gains(self) -> tuple[float, float, float] | None:
        """The gains the CCC action map is centred on (None: the preset's)."""

    @property
    def gain_range(self) -> float:
        """Each CCC gain's largest value as a multiple of the preset's."""

    @property
    def kd_scale(self) -> float:
        """The largest kd as a multiple of the preset's kp, s."""


@dataclass(frozen=True)
class Task(ABC):
    """One task kind: what the actions set, and the observation's own last key.

    The env core (:class:`contour_gym.envs.core.ContourTask`) does everything the task kinds
    share (plant, path, reward components, failure rule, the common observation keys); the
    task supplies the rest, in Python and in the env's compiled step.

    Attributes:
        name: Registry name: the env classes' ``kind`` and the suites' ``task``.
        default_reward: The registered reward used unless the env is given one.
        tail: The key of the task's own observation columns, last in the observation.
        apply: Compiled ``apply(m, env, ec, b)``: member ``b``'s action row
            ``env.action[b]``, already clipped to [-1, 1], sets what it acts on in the loop's
            record ``m`` (:data:`contour_gym.loop.member.Members`: ``m.ccc_gains``,
            ``m.override``; the rest is read-only). ``env`` is the env's arrays
            (``contour_gym._envstate.EnvArrays``) and ``ec`` the env's constants (columns
            :data:`contour_gym.tasks.ENV_COLUMNS`). Bound into the env kernel's ``TASK_APPLY`` slot.
        observe: Compiled ``observe(m, path, env, ec, b, col) -> col``: writes member
            ``b``'s tail columns from ``col`` on with :data:`contour_gym.tasks.put_observation`
            and returns the column after them; ``path`` is the path's arrays. Slot ``TASK_OBSERVE``.
    """

    name: str
    default_reward: str
    tail: str
    apply: Any = field(repr=False)
    observe: Any = field(repr=False)

    @abstractmethod
    def n_actions(self, n_contours: int) -> int:
        """Action length on a stage with ``n_contours`` contours."""

    @abstractmethod
    def tail_size(self, n_contours: int) -> int:
        """Number of columns of the observation's :attr:`tail`."""

    @abstractmethod
    def override_range(self, env: TaskEnv) -> tuple[float, float]:
        """The slowest and fastest feed override an episode may run at.

        The slowest sets the default step limit, the fastest the reward's progress bound.
        """

    @abstractmethod
    def reset(self, env: TaskEnv, members: NDArray[np.intp]) -> None:
        """Set what the actions act on to its episode start for ``members``.

        Called after the loop's reset; may set the starting actions
        (``env.arrays["action"]``), which the first observation shows.
        """

    def path_defaults(self, preset: Preset) -> dict[str, Any]:
        """Defaults of the random path draws on ``preset`` (``EnvConfig.path="random"``).

        Arguments of :func:`contour_gym.paths.random_path` the env's ``path_options`` override;
        none by default.
        """
        return {}

    def random_path_control(self, tolerance: float) -> dict[str, Any]:
        """``path_control`` and ``path_tolerance`` on random paths where the env names none.

        Args:
            tolerance: The env's contour tolerance, m.

        Returns:
            The defaults (none by default: the path's own, ``"none"`` for a random path).
        """
        return {}

    def fixed_ccc_gains(self, config: TaskConfig) -> Sequence[float] | None:
        """CCC gains the loop holds through the episode (None: the preset's, or the task's)."""
        return None


TASKS: Registry[Task] = Registry("task")  # the built-ins register on import (contour_gym.tasks)

# the env kernel's slots of a task (contour_gym.jit.slots)
TASK_FAMILY = Family(
    "task", {"TASK_APPLY": attrgetter("apply"), "TASK_OBSERVE": attrgetter("observe")},
    TASKS.components,
)


def register_task(task: Task, *, replace: bool = False) -> Task:
    """Register a task kind; returns it."""
    return TASKS.register(task, replace=replace)


def task_named(task: str | Task) -> Task:
    """The task itself, or the registered task of that name.

    Raises:
        ValueError: for an unknown name, listing the accepted ones.
    """
    return task if isinstance(task, Task) else TASKS.get(task)
