"""Gymnasium wrappers around :class:`ContourTask`: a single env and a native vector env."""

from __future__ import annotations

from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium.error import ResetNeeded
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numpy.typing import NDArray

from contour_gym.envs.config import EnvConfig
from contour_gym.envs.core import ContourTask, member_rngs

RENDER_MODES = ["human", "rgb_array"]


def check_actions(action: Any, shape: tuple[int, ...]) -> NDArray[np.floating[Any]]:
    """An action checked: real numbers of ``shape`` (ValueError; finiteness: the kernel)."""
    if type(action) is np.ndarray and action.dtype.kind == "f":  # the usual case: no copy
        if action.shape != shape:
            raise ValueError(f"action must have shape {shape}, got {action.shape}")
        return action
    try:
        raw = np.asarray(action)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"action must be real numbers, got {action!r}") from exc
    if raw.dtype.kind not in "iuf":  # complex (never cast to its real part), text, objects
        raise ValueError(f"action must be real numbers, got {action!r}")
    a = raw.astype(np.float64)
    if a.shape != shape:
        raise ValueError(f"action must have shape {shape}, got {a.shape}")
    return a


def _check_render_mode(render_mode: str | None) -> None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(
            f"unknown render_mode {render_mode!r}; accepted: {', '.join(RENDER_MODES)}"
        )


def _figure(task: ContourTask, kind: str, member: int = 0) -> NDArray[np.uint8]:
    from contour_gym.render import contour_figure, figure_to_array

    contour = task.stage.contours[0]
    fig = contour_figure(  # the member's episode under way (or just ended), not earlier ones
        task.loop.paths[member], {kind: task.loop.episode_trace(member)}, axes=contour.axes[:2],
        offset=(contour.offset or (0.0, 0.0))[:2],
    )
    return figure_to_array(fig)


class GainsMap:
    """CCC gains <-> actions of a CCC env, single or vector (reference policies speak in gains)."""

    task: ContourTask

    def action_to_gains(self, action: Any) -> NDArray[np.float64]:
        """CCC gains (C, 3) of an action (3C,); see :meth:`ContourTask.action_to_gains`."""
        return self.task.action_to_gains(np.asarray(action))

    def gains_to_action(self, gains: Any) -> NDArray[np.float64]:
        """The action (3C,) that sets CCC gains (C, 3) (or (3,) for every contour)."""
        g = np.broadcast_to(np.asarray(gains, dtype=float), (self.task.n_contours, 3))
        return self.task.gains_to_action(g)


# the v1 observation table (up to the task's own key) and its notes: both env specs' text
OBSERVATION_V1 = """\
    ``-v1`` ids (and the classes' default, ``observation="v1"``): what a controller can know on
    any path, and nothing that names the path or the place on it (``progress`` only with
    ``observe_progress=True``):

    | key | shape | meaning | unit and scale |
    |---|---|---|---|
    | contour_error | (C,) | estimated contour error, signed in 2-D | m / tol |
    | contour_error_change | (C,) | its change over the last decision | m / tol |
    | tracking_error | (A,) | reference minus encoder reading per axis | m / tol |
    | speed | (3,) | v / programmed feed, v / feed limit, feed override | - |
    | curvature | (1+P,) | curvature at s_ref and ``preview`` ahead | 1/m x 1 cm |
    | turning | (P,) | the tangent's turn from s_ref to each ``preview`` | rad / pi |
    | corner | (2,) | the next corner within H: distance, turn | m / H, rad / pi |
    | path_end | (1,) | distance to the path's end, capped at H | m / H |
    | curvature_peak | (W,) | peak curvature in each window ahead | log10(1 + kappa x 1 m) / 4 |
"""
OBSERVATION_V1_NOTES = """\
    ``v`` is the reference's speed along the path, the feed limit the machine's
    (``max_feedrate``; the nominal feedrate where the preset has none); curvature and the turn
    are signed in 2-D (+ = left). H = max(``preview``) is the horizon: a *corner* is a segment
    join whose tangent turns by more than 0.02 rad, observed as (1, 0) when none lies within
    H. ``curvature_peak`` (only with ``curvature_windows``, W + 1 edges ahead): in each window,
    the largest curvature at its ends and every 0.125 mm between, so that a short tight curve
    shows as long as it lies in a window, where the ``preview`` points see it only as it passes
    one of them.
"""


class ContourEnv(GainsMap, gym.Env):
    """Base of the single envs; subclasses set ``kind`` and document the spec."""

    kind: ClassVar[str]
    metadata = {"render_modes": RENDER_MODES, "render_fps": 10}  # noqa: RUF012 (gymnasium convention)

    def __init__(
        self,
        render_mode: str | None = None,
        max_episode_steps: int | None = None,
        **kwargs: Any,
    ) -> None:
        _check_render_mode(render_mode)
        if max_episode_steps is not None:  # the env's own limit (see EnvConfig.step_limit)
            kwargs["step_limit"] = max_episode_steps
        self.config = EnvConfig.from_kwargs(kwargs)
        self.render_mode = render_mode
        self.task = ContourTask(self.config, 1, self.kind, record=render_mode is not None)
        self.action_space = self.task.action_space()
        self._action_shape = (self.task.n_actions,)
        self.observation_space = self.task.observation_space()
        self.max_episode_steps = self.task.max_episode_steps
        self._needs_reset = True

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, Any]]:
        """Start an episode at the path start (see the class docstring).

        ``options["keep_paths"]`` is the vector env's (it acts on auto-resets, which a single env
        has none of): accepted so that a vector env's options pass through wrappers such as
        Gymnasium's ``SyncVectorEnv``, and the path is drawn as without it.

        Raises:
            ValueError: for a ``keep_paths`` that is not a bool, or another option.
        """
        _check_options(options, ("keep_paths",))
        _keep_paths(options)
        super().reset(seed=seed)
        self.task.reset_members(np.array([0]), [self.np_random])
        self._needs_reset = False
        return self.task.observe(0), self.task.info(0, ended=False)

    def step(
        self, action: Any
    ) -> tuple[dict[str, NDArray[np.float32]], float, bool, bool, dict[str, Any]]:
        """Hold the action for ``decision_ticks`` servo ticks (see the class docstring)."""
        if self._needs_reset:
            raise ResetNeeded("call reset() before step(), also after an episode has ended")
        self.task.step(check_actions(action, self._action_shape)[None])
        reward, terminated, truncated, _ = self.task.member_result(0)
        self._needs_reset = terminated or truncated
        info = self.task.info(0, ended=self._needs_reset)
        return self.task.observe(0), reward, terminated, truncated, info

    def render(self) -> NDArray[np.uint8] | None:
        """The episode under way, error magnified 200x (rgb_array, or shown in a window)."""
        if self.render_mode is None:
            gym.logger.warn("render() needs render_mode='rgb_array' or 'human'")
            return None
        image = _figure(self.task, self.kind)
        if self.render_mode == "rgb_array":
            return image
        _show(image)
        return None


def _show(image: NDArray[np.uint8]) -> None:
    import matplotlib.pyplot as plt

    plt.figure("contour-gym")
    plt.clf()
    plt.imshow(image)
    plt.axis("off")
    plt.pause(0.001)


VECTOR_RESET_OPTIONS = ("reset_mask", "keep_paths")


def _check_options(options: dict[str, Any] | None, known: tuple[str, ...]) -> None:
    """Refuse reset options other than ``known``, naming them and what is accepted."""
    if options is None:
        return
    if not isinstance(options, dict):
        raise ValueError(f"reset options must be a dict, got {options!r}")
    unknown = sorted(set(options) - set(known), key=str)
    if unknown:
        takes = f"it takes {', '.join(known)}"
        raise ValueError(f"unknown reset option(s) {unknown}: {takes}")


def _reset_mask(options: dict[str, Any] | None, n: int) -> NDArray[np.bool_] | None:
    """``options["reset_mask"]`` checked (bool (n,) with a True), or None when absent."""
    mask = (options or {}).get("reset_mask")
    if mask is None:
        return None
    if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (n,)
            and mask.any()):
        raise ValueError(f"options['reset_mask'] must be a bool array ({n},) with a True, "
                         f"got {mask!r}")
    return mask


def _keep_paths(options: dict[str, Any] | None) -> bool:
    """``options["keep_paths"]`` checked (a bool; False when absent)."""
    keep = (options or {}).get("keep_paths", False)
    if not isinstance(keep, (bool, np.bool_)):
        raise ValueError(f"options['keep_paths'] must be a bool, got {keep!r}")
    return bool(keep)


class ContourVectorEnv(GainsMap, VectorEnv):
    """Base of the native vector envs: one batched array program over ``num_envs`` members.

    Autoreset is NEXT_STEP: the step after a member's episode ends returns its reset
    observation and info with reward 0 and ignores its action. Member ``i`` of
    ``reset(seed=s)`` is seeded ``s + i``, like a single env reset with that seed, so a vector
    env equals a loop of single envs bit for bit, infos included (batched as Gymnasium's
    ``VectorEnv._add_info`` batches the members' infos, every key with its ``_key`` mask).
    A member whose episode ended and that is reset by ``reset(options={"reset_mask": ...})``
    before the next step starts its new episode there (as a same-step caller, e.g. an SB3
    ``VecEnv`` adapter, does) and is not reset again by the auto-reset. On random paths, a
    full reset with ``options={"keep_paths": True}`` makes each auto-reset until the next full
    reset restart the member on the path it ran, drawing none: for an evaluation that uses
    each member's first episode only (:func:`agents.evaluate.run_episodes`), the paths nobody
    runs are not drawn.

    ``num_threads`` (a constructor argument beside ``num_envs``): the threads the members step
    on, each over a contiguous part of the batch (the kernel holds no GIL). None (default):
    every CPU this process may use, one thread per 16 members at most
    (:func:`contour_gym.loop.threads.default_threads`), timed against one thread over the first
    steps and the faster kept (:class:`contour_gym.loop.threads.ThreadChoice`); 1: the calling
    thread only. The numbers do not depend on it, bit for bit.
    """

    kind: ClassVar[str]
    metadata = {  # noqa: RUF012 (gymnasium convention)
        "render_modes": ["rgb_array"],
        "autoreset_mode": AutoresetMode.NEXT_STEP,
    }

    def __init__(
        self,
        num_envs: int = 1,
        max_episode_steps: int | None = None,
        render_mode: str | None = None,
        num_threads: int | None = None,
        **kwargs: Any,
    ) -> None:
        if not isinstance(num_envs, int) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive int, got {num_envs!r}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"unknown render_mode {render_mode!r}; accepted: rgb_array")
        if max_episode_steps is not None:  # Gymnasium's vector convention: the env's own limit
            kwargs["step_limit"] = max_episode_steps
        self.config = EnvConfig.from_kwargs(kwargs)
        self.num_envs, self.render_mode = num_envs, render_mode
        self.task = ContourTask(self.config, num_envs, self.kind, record=render_mode is not None,
                                threads=num_threads)
        self.max_episode_steps = self.task.max_episode_steps
        self.single_action_space = self.task.action_space()
        self.single_observation_space = self.task.observation_space()
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self._prev_done = np.zeros(num_envs, dtype=bool)
        self._started = False
        self._keep_paths = False  # options["keep_paths"] of the last full reset

    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, NDArray[np.float32]], dict[str, Any]]:
        """Reset every member (or ``options["reset_mask"]``'s), member ``i`` seeded ``seed + i``.

        A list of seeds gives member ``i`` the seed ``seed[i]`` (None: an unpredictable one).
        A partial reset (Gymnasium's ``reset_mask``: a bool array (num_envs,), as a caller that
        starts ended members in the step they end uses it) leaves the other members as they
        are, and without a seed continues each reset member's generator, as the auto-reset and
        a single env's ``reset()`` do. The observation and info are every member's.

        ``options["keep_paths"]`` (a full reset's): see the class docstring.

        Raises:
            ValueError: for a reset mask that is not a bool array (num_envs,) with a True, a
                ``keep_paths`` that is not a bool, or another option.
            ResetNeeded: for a partial reset without a seed before the first full reset.
        """
        _check_options(options, VECTOR_RESET_OPTIONS)
        mask = _reset_mask(options, self.num_envs)
        keep = _keep_paths(options)
        if mask is None:
            members = np.arange(self.num_envs)
            rngs = member_rngs(seed, self.num_envs)
            self._keep_paths = keep
        else:
            if seed is None and not self._started:
                raise ResetNeeded("a partial reset without a seed needs a full reset() first")
            members = np.flatnonzero(mask)
            seeded = None if seed is None else member_rngs(seed, self.num_envs)
            rngs = [self.task.rngs[i] if seeded is None else seeded[i] for i in members]
        self.task.reset_members(members, rngs)
        self._prev_done[members] = False
        self._started = True
        return self.task.observe(), self.task.batch_info(np.zeros(self.num_envs, dtype=bool))

    def step(
        self, actions: Any
    ) -> tuple[
        dict[str, NDArray[np.float32]],
        NDArray[np.float64],
        NDArray[np.bool_],
        NDArray[np.bool_],
        dict[str, Any],
    ]:
        """Step every member; members whose episode ended last step are reset instead."""
        if not self._started:
            raise ResetNeeded("call reset() before step()")
        a = check_actions(actions, (self.num_envs, self.task.n_actions))
        restart = self._prev_done.copy()
        if restart.any():
            idx = np.flatnonzero(restart)
            self.task.reset_members(idx, [self.task.rngs[i] for i in idx],
                                    keep_paths=self._keep_paths)
        self.task.step(a, restart)
        reward, terminated, truncated, _ = self.task.results()
        self._prev_done = terminated | truncated
        return self.task.observe(), reward, terminated, truncated, self.task.batch_info(
            self._prev_done)

    def render(self) -> tuple[Any, ...] | None:
        """An rgb_array per member, of its episode under way (render_mode='rgb_array')."""
        if self.render_mode is None:
            return None
        return tuple(_figure(self.task, self.kind, b) for b in range(self.num_envs))
