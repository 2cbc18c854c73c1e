"""Task kinds you can swap: what an env's actions set, and the observation's last key.

An env's task is a strategy object (:class:`Task`): its action length and the compiled
mapping of actions onto the loop (CCC gains, the feed override), the observation's last key,
its default reward, the feed override range its episodes run at (for the step limit and the
reward's bounds) and its episode start. The env core has no branch on the task.

Built in: ``"ccc"`` (:mod:`contour_gym.tasks.ccc`: ``contour_gym/CCC-v0``) and ``"feedrate"``
(:mod:`contour_gym.tasks.feedrate`: ``contour_gym/Feedrate-v0``). A new task kind is one module:
a :class:`Task` subclass, two compiled functions (the observation's written with
:data:`put_observation`) and :func:`register_task`; an env class
selects it by name (``class MyEnv(ContourEnv): kind = "my_task"``). Its compiled functions
join the env's kernel like a user's reward: one compile of their own.
"""

from __future__ import annotations

from contour_gym._envstate import EC, put
from contour_gym.tasks import ccc, feedrate  # noqa: F401 (registration)
from contour_gym.tasks.base import (
    TASK_FAMILY,
    TASKS,
    Task,
    TaskConfig,
    TaskEnv,
    register_task,
    task_named,
)

put_observation = put  # a task's observe writes its columns with it (clipped like the others)
ENV_COLUMNS = EC  # the env constants' columns, by name: ``ec[ENV_COLUMNS.dovr]``

__all__ = [
    "ENV_COLUMNS",
    "TASKS",
    "TASK_FAMILY",
    "Task",
    "TaskConfig",
    "TaskEnv",
    "put_observation",
    "register_task",
    "task_named",
]
