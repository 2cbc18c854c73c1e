"""The batched core both env kinds share: B members on one ServoLoop.

The single envs run it with B = 1 and the native vector envs with B = num_envs, so a vector
env equals a loop of single envs by construction: every member owns its generator (seeded
the way ``gymnasium.Env.reset(seed)`` seeds ``np_random``), its randomisation draws, its loop
noise stream and its clock. The per-step arithmetic is compiled (:mod:`._kernel`, specialised
to the loop's components and the reward).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import Any, cast

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from numpy.typing import NDArray

from contour_gym import jit
from contour_gym._blob import Blob
from contour_gym._envstate import EC, ENV_CONFIG, ENV_FLOATS, OBS_LIMIT, OBSERVATIONS
from contour_gym._validate import seed_value
from contour_gym.api import Scenario
from contour_gym.envs._paths import reset_draws
from contour_gym.envs.config import EnvConfig, draw_plant_scaling
from contour_gym.jit import Family, precompile, tiers
from contour_gym.jit.stack import on_reserved_stack
from contour_gym.loop import REASON_HARD_LIMIT
from contour_gym.metrics import member_metrics
from contour_gym.paths import Path
from contour_gym.presets import resolve_preset
from contour_gym.rewards import (
    COMPONENTS,
    REWARD_FAMILY,
    REWARDS,
    CompiledReward,
    component_bounds,
    components_dict,
    reward_range,
)
from contour_gym.tasks import TASK_FAMILY, Task, task_named
from contour_gym.tasks.ccc import GainMap

Array = NDArray[np.float64]
OUTCOME = ("reward", "terminated", "truncated", "failure")  # a decision's outcome, in order
CCC, FEEDRATE = "ccc", "feedrate"  # the built-in tasks' names (contour_gym.tasks)
EPISODE_MARGIN = 2.0  # the step limit is this times the planned decisions (+ 10)


class ContourTask:
    """Batched state, actions, observations and rewards of the contouring envs.

    Args:
        config: The environment arguments.
        batch: Number of members.
        kind: The task (:mod:`contour_gym.tasks`), or its registered name: ``"ccc"`` (actions
            are CCC gains), ``"feedrate"`` (actions change the feed override), or your own.
        record: Keep per-tick traces (for rendering).
        threads: Threads the members step on (:class:`contour_gym.loop.ServoLoop`'s).
    """

    def __init__(
        self, config: EnvConfig, batch: int, kind: str | Task, record: bool = False,
        threads: int | None = 1,
    ) -> None:
        self.task_kind: Task = task_named(kind)
        self.config, self.batch, self.kind = config, batch, self.task_kind.name
        self.scenario = self._make_scenario()
        preset = self.scenario.preset
        self.stage, self.preset = preset.stage, preset
        self.n_contours, self.n_axes = len(self.stage.contours), self.stage.n_axes
        self.tolerance = config.tolerance_for(preset)
        self.hard_limit = config.hard_limit_for(preset)
        if self.hard_limit <= self.tolerance:
            raise ValueError(f"hard_limit must exceed tolerance, got {self.hard_limit!r}")
        self.g0 = np.asarray(config.ccc_gains or preset.ccc_gains.as_tuple(), dtype=float)
        self.loop = self.scenario.loop(
            batch_size=batch, ccc_gains=self.task_kind.fixed_ccc_gains(config), record=record,
            ccc_weights=config.ccc_weights, threads=threads,
        )
        self.ovr_bounds = np.asarray(config.feedrate_range, dtype=float)
        self.gain_map = GainMap.for_env(config, preset, self.g0)
        self.rngs: list[np.random.Generator] = [np.random.default_rng(0)] * batch
        self._sizes = self._observation_sizes()
        ends = np.cumsum(list(self._sizes.values()))
        self._obs_cols = [(key, slice(int(end - n), int(end)))  # ints: numpy's slice faster
                          for (key, n), end in zip(self._sizes.items(), ends, strict=True)]
        self._reward, weights = self._resolve_reward()
        self._fixed_limit = config.step_limit
        self.max_episode_steps = config.step_limit or self._step_limit()
        if record:  # an episode's record is kept until the member's next reset
            self.loop.check_record(
                self.max_episode_steps * config.decision_ticks,
                f"{batch} members recording episodes of up to {self.max_episode_steps} steps",
                "render fewer members (num_envs), or set max_episode_steps")
        self._build_blob(weights)
        self._specialise()

    # --------------------------------------------------------------- building
    def _make_scenario(self) -> Scenario:
        # the scenario; on random paths (path_options set), on a first draw from default_rng(0)
        config = self.config
        self.path_options: dict[str, Any] | None = None
        if not config.random_paths:
            return config.scenario()
        preset = resolve_preset(config.plant)
        self.path_options = config.path_options_for(preset, self.task_kind.path_defaults(preset))
        return config.random_scenario(np.random.default_rng(0), self.task_kind)

    @property
    def path(self) -> Path:
        """The env's path: member 0's (every member's on a fixed path; ``loop.paths``: each)."""
        return self.loop.path

    def _resolve_reward(self) -> tuple[CompiledReward | Callable[..., Any], Array]:
        spec = self.config.reward
        if spec is None:
            spec = self.task_kind.default_reward
        if isinstance(spec, str):
            reward: CompiledReward | Callable[..., Any] = REWARDS.get(spec)
            weights = reward.weights.row(**self.config.reward_weights)  # type: ignore[union-attr]
        elif callable(spec):
            if self.config.reward_weights:
                raise ValueError("reward_weights apply to compiled rewards; a Python reward "
                                 "takes its own parameters")
            reward, weights = spec, np.zeros(0)
        else:
            raise ValueError(f"reward must be a registered name or a callable, got {spec!r}")
        return reward, weights

    @property
    def reward_name(self) -> str:
        """The reward's name (a compiled reward's registry name, else the callable's)."""
        if isinstance(self._reward, CompiledReward):
            return self._reward.name
        return getattr(self._reward, "__name__", type(self._reward).__name__)

    def _compiled_reward(self) -> CompiledReward:
        if isinstance(self._reward, CompiledReward):
            return self._reward
        return REWARDS.get("ccc")  # compiled but never called: the Python reward runs

    def _compiling(self) -> contextlib.AbstractContextManager[None]:
        # a progress line while the env kernel compiles in this process (a user's component)
        show = not self._stepped and jit.needs_compile(self.kernel)
        return jit.compiling(f"the env step for {self.loop.describe()}", show)

    def _specialise(self) -> None:
        # the env kernel on the loop's run, with this task's reward among the family's; the
        # loop's kernel and this one are chosen together (contour_gym.jit.tiers)
        uses: dict[Family, list[Any]] = {
            REWARD_FAMILY: [self._compiled_reward()], TASK_FAMILY: [self.task_kind]
        }
        slots, codes = jit.bind(uses)
        self._econfig[EC.reward] = codes[REWARD_FAMILY.name][0]
        self._econfig[EC.task] = codes[TASK_FAMILY.name][0]
        own_loop, builtins_loop = self.loop.kernels()
        if builtins_loop is None or not jit.is_generic(slots):
            self.kernel = _env_kernel(self.loop.kernel, slots)  # a user's component
        else:
            own = _env_kernel(own_loop, jit.bind(uses, own=True)[0])

            def builtins() -> ModuleType:
                kernel = _env_kernel(builtins_loop(), slots)
                precompile.ensure("env")  # once per installation, in worker processes
                return kernel

            self.kernel = tiers.choose(own, builtins, "env", self)
            self.loop.use_kernel(own_loop if self.kernel is own else builtins_loop())
        self._stepped = False

    def compile_own(self) -> None:
        """Step once on this task's own kernels (a background worker: ``jit.tiers``)."""
        self.reset_members(np.array([0]), [np.random.default_rng(0)])
        self.step(np.zeros((self.batch, self.n_actions)))

    def _step_limit(self, member: int | None = None) -> int:
        # the step limit of member's path (default: of the longest of the members' paths)
        slowest = self.task_kind.override_range(self)[0]
        planned = self.loop.planned_time(override=slowest, member=member)
        decisions = planned / (self.config.decision_ticks * self.stage.ts)
        return int(math.ceil(EPISODE_MARGIN * decisions)) + 10

    def set_step_limit(self, steps: int) -> None:
        """Truncate episodes after ``steps`` decisions (the failure rule follows it)."""
        if not isinstance(steps, int) or steps < 1:
            raise ValueError(f"step_limit must be a positive int, got {steps!r}")
        self.max_episode_steps = self._fixed_limit = steps
        self._v["n_max"][...] = steps

    def _member_constants(self, members: NDArray[np.intp]) -> None:
        # each member's nominal feedrate, progress scale and step limit (from its own path on
        # random paths: its highest programmed feed and its planned time)
        v, own = self._v, self.path_options is not None
        for b in members:
            nominal = self.loop.programmed_feedrate(b) if own else self.loop.nominal_feedrate
            v["f_nom"][b] = nominal
            v["nominal"][b] = nominal * self.config.decision_ticks * self.stage.ts
            limit = self._fixed_limit or (self._step_limit(b) if own else None)
            v["n_max"][b] = limit or self.max_episode_steps

    def _build_blob(self, weights: Array) -> None:
        b, n_obs = self.batch, sum(self._sizes.values())
        shapes = {
            "action": (b, self.n_actions), "skip": (b,), "g_max": (3,), "g_log": (3,),
            "lookahead": (len(self._ahead()),), "eps_prev": (b, self.n_contours),
            "s_before": (b,), "obs": (b, n_obs), "ref": (b, self.n_axes), "vel": (b, self.n_axes),
            "raw": (b,), "reward": (b,), "terminated": (b,), "truncated": (b,), "failure": (b,),
            "comp": (b, COMPONENTS.size), "weights": (max(weights.size, 1),), "steps": (b,),
            "ret": (b,), "track": (b, self.n_axes), "feedrate": (b,), "nominal": (b,),
            "f_nom": (b,), "n_max": (b,), "peak": (b,),
            "windows": (max(len(self.config.curvature_windows), 1),), "prior": (b,),
        }
        self._blob = Blob([(name, shapes[name]) for name in ENV_FLOATS])
        self._attach_views()
        v = self._v
        v["g_max"][...], v["g_log"][...] = self.gain_map.g_max, self.gain_map.g_log
        v["lookahead"][...] = self._ahead()
        v["windows"][: len(self.config.curvature_windows)] = self.config.curvature_windows
        v["weights"][: weights.size] = weights
        lo, hi = component_bounds(self.hard_limit / self.tolerance, self._max_progress())
        self.reward_range = reward_range(self._reward, weights, lo, hi)
        self._econfig = ENV_CONFIG.row(
            dovr=self.config.max_feedrate_change, ovr_lo=self.ovr_bounds[0],
            ovr_hi=self.ovr_bounds[1], tol=self.tolerance, hard=self.hard_limit,
            penalty=self.config.failure_penalty, r_lo=min(self.reward_range[0], 0.0),
            r_hi=self.reward_range[1], dim=self.stage.dim,
            python_reward=float(not isinstance(self._reward, CompiledReward)),
            observation=OBSERVATIONS.index(self.config.observation),
            f_max=self._machine_feedrate(), horizon=max(self.config.preview),
            progress_obs=float(self.config.observe_progress), **self._target_columns(),
        )
        self._leading = (self._blob.buffer, self._blob.layout, self._econfig)  # never move
        self._quiet = contextlib.nullcontext()
        self._member_constants(np.arange(b))

    def _target_columns(self) -> dict[str, float]:
        # the feedrate task's target-override action (EnvConfig.feedrate_target), if asked for
        target = self.config.feedrate_target
        if target is None:
            return {}
        t_lo, t_mid, t_hi = (float(t) for t in target)
        a_c, reach, v_end, end_reach = (*(self.config.feedrate_limit or (0.0, 0.0)), 0.0, 0.0)[:4]
        return {"target": 1.0, "t_lo": t_lo, "t_mid": t_mid, "t_hi": t_hi, "lim_a": float(a_c),
                "lim_reach": float(reach), "lim_vend": float(v_end),
                "lim_rend": float(end_reach),
                "lim_span": float(self.config.limit_span or 0.0)}

    def _machine_feedrate(self) -> float:
        # the machine's feedrate limit (the v1 observation's speed scale); without one, the
        # nominal feedrate
        limit = float(self.preset.max_feedrate)
        return limit if math.isfinite(limit) else float(self.loop.nominal_feedrate)

    def _ahead(self) -> tuple[float, ...]:
        # the arc lengths ahead the observation looks at (the kernel's "lookahead" array)
        return self.config.lookahead if self.config.observation == "v0" else self.config.preview

    def _max_progress(self) -> float:
        # the fastest progress per step: the highest feed (rapids included) at the top override
        top = self.task_kind.override_range(self)[1]
        own = self.path_options is not None  # on random paths, the first's own nominal
        nominal = self.loop.programmed_feedrate(0) if own else self.loop.nominal_feedrate
        return float(max(top, 1.0) * np.max(self.loop.program.feed) / nominal)

    @property
    def g_max(self) -> Array:
        """The largest CCC gains (kp, ki, kd) of the action map (:class:`GainMap`)."""
        return self.gain_map.g_max

    @property
    def arrays(self) -> dict[str, Array]:
        """The env's per-member arrays by name (``contour_gym._envstate.ENV_FLOATS``), as views."""
        return self._v

    def _attach_views(self) -> None:
        v = self._v = self._blob.views
        self._action, self._skip, self._reward_out = v["action"], v["skip"], v["reward"]
        self._info_views: dict[int, tuple[Any, ...]] = {}  # _member_views, made on first use
        self._skipping = bool(self._skip.any())  # skip holds a mask of the last step's

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        if isinstance(self._reward, str):  # a compiled reward, pickled by name
            self._reward = REWARDS.get(self._reward)
        self._attach_views()  # views alias the unpickled buffer again
        self._specialise()

    def __getstate__(self) -> dict[str, Any]:
        drop = ("_v", "_action", "_skip", "_reward_out", "kernel")
        state = {k: val for k, val in self.__dict__.items() if k not in drop}
        if isinstance(self._reward, CompiledReward):
            state["_reward"] = self._reward.name
        return state

    # ---------------------------------------------------------------- spaces
    @property
    def n_actions(self) -> int:
        """Action length (the task's: 3 gains per contour, one feedrate change, ...)."""
        return self.task_kind.n_actions(self.n_contours)

    def action_space(self) -> spaces.Box:
        """The single-member action space."""
        return spaces.Box(-1.0, 1.0, (self.n_actions,), np.float32)

    def observation_space(self) -> spaces.Dict:
        """The single-member observation space (see the env docstrings for units)."""
        lim = OBS_LIMIT
        return spaces.Dict(
            {k: spaces.Box(-lim, lim, (n,), np.float32) for k, n in self._sizes.items()}
        )

    def _observation_sizes(self) -> dict[str, int]:
        # key order is the column order _kernel._observe writes; the task's own key last
        errors = {"contour_error": self.n_contours, "contour_error_change": self.n_contours,
                  "tracking_error": self.n_axes}
        if self.config.observation == "v0":
            middle = {"reference_velocity": self.n_axes,
                      "curvature": 1 + len(self.config.lookahead), "progress": 1}
        else:
            n = len(self.config.preview)
            windows = max(len(self.config.curvature_windows) - 1, 0)
            middle = {"speed": 3, "curvature": 1 + n, "turning": n, "corner": 2, "path_end": 1,
                      **({"curvature_peak": windows} if windows else {}),
                      **({"progress": 1} if self.config.observe_progress else {})}
        return {**errors, **middle,
                self.task_kind.tail: self.task_kind.tail_size(self.n_contours)}

    # ------------------------------------------------------- gains <-> actions
    def action_to_gains(self, action: Array) -> Array:
        """Map actions in [-1, 1], shape (..., 3C), to CCC gains (..., C, 3) (env docstring)."""
        return self.gain_map.to_gains(action, self.n_contours)

    def gains_to_action(self, gains: Array) -> Array:
        """Inverse of :meth:`action_to_gains`; gains above the range map above 1.

        Raises:
            ValueError: for negative or non-finite gains.
        """
        return self.gain_map.to_action(gains)

    # ----------------------------------------------------------------- reset
    def reset_members(
        self, members: NDArray[np.intp], rngs: list[np.random.Generator], keep_paths: bool = False
    ) -> None:
        """Start new episodes for ``members`` with their generators ``rngs``.

        ``keep_paths``: on random paths, each member runs its path again (none is drawn).
        """
        seeds, paths = [], []
        options = None if keep_paths else self.path_options
        for b, rng in zip(members, rngs, strict=True):
            self.rngs[b] = rng
            self._randomize(int(b), rng)
            seed, path = reset_draws(rng, self.stage, options)
            seeds.append(seed)
            if path is not None:
                paths.append(path)
        if paths:
            self.loop.set_paths(paths, members=members)
            self._member_constants(members)
        self.loop.reset(seeds, members=members)
        v = self._v
        for name in ("eps_prev", "steps", "ret", "reward", "terminated", "truncated", "failure",
                     "comp", "peak"):
            v[name][members] = 0.0
        self.task_kind.reset(self, members)
        args = (*self._kernel_blobs(), np.asarray(members, dtype=np.int64))
        if self._stepped:
            self.kernel.observe(*args)
            return
        with self._compiling():  # the first call may compile: below a reserved stack
            on_reserved_stack(self.kernel.observe, *args)

    def _kernel_blobs(self) -> tuple[Any, ...]:
        loop = self.loop
        fb, fl, ib, il = loop.blobs()
        return (self._blob.buffer, self._blob.layout, fb, fl, ib, il, *loop.path_blobs(),
                self._econfig)

    def _randomize(self, b: int, rng: np.random.Generator) -> None:
        ranges = self.config.randomization()
        if ranges is not None:
            self.loop.set_plant_scaling([b], **draw_plant_scaling(ranges, self.n_axes, rng))

    # ------------------------------------------------------------------ step
    def step(
        self, actions: NDArray[np.floating[Any]], skip: NDArray[np.bool_] | None = None
    ) -> None:
        """One decision: apply actions (B, n) (clipped), run ``decision_ticks`` ticks.

        Members in ``skip`` neither act nor advance (vector env auto-reset). Read the
        outcome with :meth:`results` or :meth:`member_result`.
        """
        if skip is None:
            self._action[...] = actions
            if self._skipping:
                self._skip[...] = 0.0
                self._skipping = False
        else:
            self._action[~skip] = actions[~skip]
            self._skip[...] = skip
            self._skipping = True
        skipped = None if skip is None else np.flatnonzero(skip)
        with self._quiet if self._stepped else self._compiling():
            ran = self.loop.advance(self.config.decision_ticks, skipped, self.kernel.env_step,
                                    self._leading)
        if not ran:
            raise ValueError(f"actions must be finite, got {actions}")  # nothing was run
        if not self._stepped:  # the env kernel is in numba's cache now
            jit.mark_compiled(self.kernel)
            self._stepped = True
            tiers.start_pending()
        if not isinstance(self._reward, CompiledReward):
            self._python_rewards()

    def _python_rewards(self) -> None:
        live = self._skip == 0.0
        reward = cast(Callable[[dict[str, Array]], Any], self._reward)
        values = np.asarray(reward(components_dict(self._v["comp"])), dtype=np.float64)
        if values.shape != (self.batch,) or not np.all(np.isfinite(values[live])):
            raise ValueError(
                f"the Python reward must return {self.batch} finite values, got {values!r}"
            )
        self._v["raw"][...] = values
        self.kernel.apply_rewards(*self._kernel_blobs()[:6], self._econfig)

    def results(self) -> tuple[Array, NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
        """Rewards (B,), terminated, truncated and failure (B,) of the last decision (copies)."""
        v = self._v
        return (v["reward"].copy(), v["terminated"] != 0.0, v["truncated"] != 0.0,
                v["failure"] != 0.0)

    def member_result(self, b: int) -> tuple[float, bool, bool, bool]:
        """Reward, terminated, truncated and failure of member ``b`` after the last decision."""
        views = self._info_views.get(b) or self._member_views(b)
        reward, terminated, truncated, failure = views[-1].tolist()
        return reward, terminated != 0.0, truncated != 0.0, failure != 0.0

    # ----------------------------------------------------------- observation
    def observe(self, member: int | None = None) -> dict[str, NDArray[np.float32]]:
        """Observations as documented in the env docstrings (fresh arrays).

        Args:
            member: None for every member (arrays (B, n)), or one member's (arrays (n,)).
        """
        obs = self._v["obs"]
        if member is None:
            flat = obs.astype(np.float32)
            return {key: flat[:, cols] for key, cols in self._obs_cols}
        flat = obs[member].astype(np.float32)
        return {key: flat[cols] for key, cols in self._obs_cols}

    # ------------------------------------------------------------------ info
    def _step_info(self) -> dict[str, Any]:
        """The per-step info of every member, batched arrays (B, ...)."""
        loop, v = self.loop, self._v
        comp = v["comp"]
        return {
            "contour_error": loop.contour_error.copy(),
            "contour_error_estimate": loop.contour_error_estimate.copy(),
            "tracking_error": v["track"].copy(),
            "feedrate": v["feedrate"].copy(),
            "s": loop.s.copy(),
            "failure": v["failure"] != 0.0,
            "reward_components": {name: comp[:, j].copy()
                                  for j, name in enumerate(COMPONENTS.names)},
        }

    def _member_info(self, b: int) -> dict[str, Any]:
        """Member ``b``'s per-step info: its arrays, Python floats and bools (as batched)."""
        views = self._info_views.get(b) or self._member_views(b)
        true, est, track, s, v, comp, _ = views
        return {
            "contour_error": true.copy(),
            "contour_error_estimate": est.copy(),
            "tracking_error": track.copy(),
            "feedrate": float(v["feedrate"][b]),
            "s": float(s[b]),
            "failure": bool(v["failure"][b] != 0.0),
            # one schema's names and columns (zip's strict keyword alone cost 2 % of a step)
            "reward_components": dict(zip(COMPONENTS.names, comp.tolist())),  # noqa: B905
        }

    def _member_views(self, b: int) -> tuple[Any, ...]:
        # the arrays member b's info reads, made once (the blobs never move)
        loop, v = self.loop, self._v
        # reward, terminated, truncated and failure are consecutive (B,) arrays of the blob
        start = ENV_FLOATS.index("reward")
        assert ENV_FLOATS[start : start + len(OUTCOME)] == OUTCOME
        first, n = self._blob.layout[self._blob.index["reward"], 0], self.batch
        outcome = self._blob.buffer[first + b : first + 4 * n : n]
        views = (loop.contour_error[b], loop.contour_error_estimate[b], v["track"][b], loop.s, v,
                 v["comp"][b], outcome)
        self._info_views[b] = views
        return views

    def _end_metrics(self) -> dict[str, Any]:
        loop = self.loop
        m = loop.metrics()
        out: dict[str, Any] = {k: m[k].copy() for k in member_metrics(m, 0)}
        out["finished"] = loop.done
        # why an episode failed: the loop's reason, else the env's hard limit
        hard = (self._v["failure"] != 0.0) & ~loop.failed
        out["failure_reason"] = np.where(hard, REASON_HARD_LIMIT, loop.failure_reason)
        return out

    def info(self, b: int, ended: bool) -> dict[str, Any]:
        """Info of member ``b`` after a step or reset (SI units; see the env docstrings)."""
        out = self._member_info(b)
        if ended:
            out["metrics"] = {k: _python(val[b]) for k, val in self._end_metrics().items()}
        return out

    def batch_info(self, ended: NDArray[np.bool_]) -> dict[str, Any]:
        """The vector env's info: each key batched with its ``_key`` mask.

        As Gymnasium's ``VectorEnv._add_info`` builds it from the members' infos (``metrics``
        only where a member's episode ended).
        """
        everyone = np.ones(self.batch, dtype=bool)
        info = _masked(self._step_info(), everyone)
        if ended.any():
            metrics = {k: np.where(ended, val, np.zeros_like(val))
                       for k, val in self._end_metrics().items()}
            info["metrics"], info["_metrics"] = _masked(metrics, ended), ended.copy()
        return info


def _python(value: Any) -> Any:
    # one member's value(s): numpy scalars as Python floats and bools, arrays copied
    if isinstance(value, dict):
        return {k: _python(v) for k, v in value.items()}
    if isinstance(value, np.ndarray) and value.ndim > 0:
        return value.copy()
    if isinstance(value, np.bool_):
        return bool(value)
    return float(value)


def _masked(values: dict[str, Any], mask: NDArray[np.bool_]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, val in values.items():
        out[key] = _masked(val, mask) if isinstance(val, dict) else val
        out[f"_{key}"] = mask.copy()
    return out


def _env_kernel(loop_kernel: ModuleType, slots: dict[str, Any]) -> ModuleType:
    """The env kernel module on ``loop_kernel``'s run with the reward ``slots``."""
    return jit.specialise(
        "contour_gym.envs._kernel", {"RUN_MEMBERS": loop_kernel.run_members, **slots}
    )


def member_rngs(
    seed: int | Sequence[int | None] | None, count: int
) -> list[np.random.Generator]:
    """Generators for ``count`` members as ``gymnasium`` seeds vector envs.

    An int seeds member i with ``seed + i``; a list gives each member its own seed (None: an
    unpredictable one), as Gymnasium's ``VectorEnv.reset(seed=[...])`` allows.

    Raises:
        ValueError: naming a seed that is not a non-negative int (or None in a list), or a
            list of another length than ``count``.
    """
    if seed is None or not isinstance(seed, (Sequence, np.ndarray)) or isinstance(seed, str):
        seeds: list[Any] = [None if seed is None else seed_value(seed) + i for i in range(count)]
    else:
        if len(seed) != count:
            raise ValueError(f"seed must be one int or {count} seeds (one per member), "
                             f"got {len(seed)}: {seed!r}")
        seeds = [None if s is None else seed_value(s) for s in seed]
    return [seeding.np_random(s)[0] for s in seeds]

