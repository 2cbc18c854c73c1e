"""The batched core both env kinds share: B members on one ServoLoop.

The single envs run it with B = 1 and the native vector envs with B = num_envs, so a vector
env equals a loop of single envs by construction: every member owns its generator (seeded
the way ``gymnasium.Env.reset(seed)`` seeds ``np_random``), its randomisation draws, its loop
noise stream and its clock. The per-step arithmetic is compiled (:mod:`._kernel`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from numpy.typing import NDArray

from contour_gym._blob import Blob
from contour_gym.api import make_scenario
from contour_gym.envs import _kernel as EK
from contour_gym.envs.config import EnvConfig
from contour_gym.metrics import member_metrics
from contour_gym.plant import _kernel as PK
from contour_gym.servo import _kernel as SK

Array = NDArray[np.float64]
CCC, FEEDRATE = "ccc", "feedrate"


class ContourTask:
    """Batched state, actions, observations and rewards of the contouring envs.

    Args:
        config: The environment arguments.
        batch: Number of members.
        kind: ``"ccc"`` (actions are CCC gains) or ``"feedrate"`` (actions are dF).
        record: Keep per-tick traces (for rendering).
    """

    def __init__(self, config: EnvConfig, batch: int, kind: str, record: bool = False) -> None:
        self.config, self.batch, self.kind = config, batch, kind
        self.scenario = make_scenario(config.plant, config.path, config.feedrate)
        preset, path = self.scenario.preset, self.scenario.path
        self.path, self.stage = path, preset.stage
        self.n_contours, self.n_axes = len(self.stage.contours), self.stage.n_axes
        self.g0 = np.asarray(config.ccc_gains or preset.ccc_gains.as_tuple(), dtype=float)
        self.loop = self.scenario.loop(
            batch_size=batch,
            ccc_gains=self.g0 if kind == FEEDRATE else None,
            record=record,
            estimator=config.estimator,
            estimator_options=config.estimator_options,
            axis_controller=config.axis_controller,
            controller_options=config.controller_options,
        )
        self.f_nominal = self.scenario.feedrate
        self.f_bounds = np.asarray(config.feedrate_range) * self.f_nominal
        kp0 = self.g0[0] if self.g0[0] > 0 else preset.ccc_gains.kp
        ki0 = self.g0[1] if self.g0[1] > 0 else kp0 * 10.0
        r = config.gain_range
        log_lo, log_hi = (
            np.log([kp0 / r, ki0 / r, kp0 * 1e-5]),
            np.log([kp0 * r, ki0 * r, kp0 * 1e-2]),
        )
        # the CCC env starts from the preset gains clipped into its action range (kd = 0 sits
        # at the log scale's floor); the feedrate env holds them as given
        self.g_start = np.clip(self.g0, np.exp(log_lo), np.exp(log_hi)) if kind == CCC else self.g0
        self.rngs: list[np.random.Generator] = [np.random.default_rng(0)] * batch
        self.feed = self.loop.ip_p[:, 0]  # view: commanded feedrate per member
        self._kind_code = EK.KIND_CCC if kind == CCC else EK.KIND_FEEDRATE
        self._nominal_progress = self.f_nominal * config.decision_ticks * self.stage.ts
        self._sizes = self._observation_sizes()
        n_obs = sum(self._sizes.values())
        shapes = {
            "action": (batch, self.n_actions), "skip": (batch,), "log_lo": (3,), "log_hi": (3,),
            "lookahead": (len(config.lookahead),), "eps_prev": (batch, self.n_contours),
            "s_before": (batch,), "obs": (batch, n_obs), "ref": (batch, self.n_axes),
            "vel": (batch, self.n_axes), "reward": (batch,), "terminated": (batch,),
            "failure": (batch,),
        }  # fmt: skip
        self._blob = Blob([(name, shapes[name]) for name in EK.ENV_ARRAYS])
        self._attach_views()
        self._v["log_lo"][...], self._v["log_hi"][...] = log_lo, log_hi
        self._v["lookahead"][...] = config.lookahead
        # env_step's leading arguments, constant for this task (Python scalars: numba's
        # dispatcher types them fastest)
        self._step_args = (
            self._kind_code, float(config.max_feedrate_change * self.f_nominal),
            float(self.f_bounds[0]), float(self.f_bounds[1]), self._blob.buffer,
            self._blob.layout, float(config.tolerance), float(config.hard_limit),
            float(config.failure_penalty), float(self._nominal_progress), float(self.f_nominal),
            int(self.path.dim),
        )  # fmt: skip
        self._axis_map = [
            (c.axes[j], j, c.offset[j] if c.offset else 0.0)
            for c in self.stage.contours
            for j in range(c.dim)
        ]

    def _attach_views(self) -> None:
        v = self._v = self._blob.views
        self._action, self._skip, self._reward = v["action"], v["skip"], v["reward"]
        self._terminated, self._failure = v["terminated"], v["failure"]

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._attach_views()  # views alias the unpickled buffer again
        self.feed = self.loop.ip_p[:, 0]

    def __getstate__(self) -> dict[str, Any]:
        views = ("_v", "_action", "_skip", "_reward", "_terminated", "_failure", "feed")
        return {k: val for k, val in self.__dict__.items() if k not in views}

    # ---------------------------------------------------------------- spaces
    @property
    def n_actions(self) -> int:
        """Action length: 3 gains per contour, or one feedrate change."""
        return 3 * self.n_contours if self.kind == CCC else 1

    def action_space(self) -> spaces.Box:
        """The single-member action space."""
        return spaces.Box(-1.0, 1.0, (self.n_actions,), np.float32)

    def observation_space(self) -> spaces.Dict:
        """The single-member observation space (see the env docstrings for units)."""
        lim = EK.OBS_LIMIT
        return spaces.Dict(
            {k: spaces.Box(-lim, lim, (n,), np.float32) for k, n in self._sizes.items()}
        )

    def _observation_sizes(self) -> dict[str, int]:
        # key order is the column order _kernel._observe writes
        last = ("gains", 3 * self.n_contours) if self.kind == CCC else ("feedrate", 2)
        return {
            "contour_error": self.n_contours,
            "contour_error_change": self.n_contours,
            "tracking_error": self.n_axes,
            "reference_velocity": self.n_axes,
            "curvature": 1 + len(self.config.lookahead),
            "progress": 1,
            last[0]: last[1],
        }

    # ------------------------------------------------------- gains <-> actions
    def action_to_gains(self, action: Array) -> Array:
        """Map actions in [-1, 1], shape (..., 3C), to CCC gains (..., C, 3) on a log scale."""
        a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        a = a.reshape(*a.shape[:-1], self.n_contours, 3)
        lo, hi = self._v["log_lo"], self._v["log_hi"]
        return np.exp(lo + 0.5 * (a + 1.0) * (hi - lo))

    def gains_to_action(self, gains: Array) -> Array:
        """Inverse of :meth:`action_to_gains`; gains outside the range map outside [-1, 1]."""
        g = np.asarray(gains, dtype=float)
        if np.any(g <= 0) or not np.all(np.isfinite(g)):
            raise ValueError(f"gains must be finite and > 0 to have an action, got {g}")
        lo, hi = self._v["log_lo"], self._v["log_hi"]
        a = 2.0 * (np.log(g) - lo) / (hi - lo) - 1.0
        return a.reshape(*g.shape[:-2], -1)

    # ----------------------------------------------------------------- reset
    def reset_members(self, members: NDArray[np.intp], rngs: list[np.random.Generator]) -> None:
        """Start new episodes for ``members`` with their generators ``rngs``."""
        seeds = []
        for b, rng in zip(members, rngs, strict=True):
            self.rngs[b] = rng
            self._randomize(int(b), rng)
            seeds.append(int(rng.integers(2**63 - 1)))
        self.loop.reset(seeds, members=members)
        self._v["eps_prev"][members] = 0.0
        self._v["skip"][members] = 1.0  # observe them without a reward
        if self.kind == CCC:
            self.loop.ccc_p[members, :, SK.CP_KP : SK.CP_KD + 1] = self.g_start
            start = self.gains_to_action(
                np.broadcast_to(self.g_start, (len(members), self.n_contours, 3))
            )
            self._v["action"][members] = np.clip(start, -1.0, 1.0)
        else:
            self.feed[members] = self.f_nominal
        self._finish()
        self._v["skip"][members] = 0.0

    def _randomize(self, b: int, rng: np.random.Generator) -> None:
        ranges = self.config.randomization()
        if ranges is None:
            return
        shape = (self.n_axes,)
        factors = {
            k: 1.0 + rng.uniform(-ranges[k], ranges[k], shape)
            for k in ("mass", "damping", "force_constant")
        }
        for k in ("friction", "disturbance"):
            factors[k] = rng.uniform(ranges[k][0], ranges[k][1], shape)
        self.loop.set_plant_scaling([b], **factors)

    # ------------------------------------------------------------------ step
    def step(self, actions: Array, skip: NDArray[np.bool_] | None = None) -> None:
        """One decision: apply actions (B, n) (clipped), run ``decision_ticks`` ticks.

        Members in ``skip`` neither act nor advance (vector env auto-reset). Read the
        outcome with :meth:`results` or :meth:`member_result`.
        """
        if skip is None:
            self._action[...] = actions
            self._skip[...] = 0.0
        else:
            self._action[~skip] = actions[~skip]
            self._skip[...] = skip
        loop = self.loop
        if loop._noise.active and not np.isfinite(self._action).all():
            # checked before prepare(), which draws noise: a rejected action leaves no trace
            raise ValueError(f"actions must be finite, got {actions}")
        call = loop.prepare(
            self.config.decision_ticks, None if skip is None else np.flatnonzero(skip)
        )
        if not EK.env_step(*self._step_args, *loop.kernel_args(call)):
            raise ValueError(f"actions must be finite, got {actions}")  # nothing was run
        loop.complete(call)

    def results(self) -> tuple[Array, NDArray[np.bool_], NDArray[np.bool_]]:
        """Rewards (B,), terminated (B,) and failure (B,) of the last decision (copies)."""
        return self._reward.copy(), self._terminated != 0.0, self._failure != 0.0

    def member_result(self, b: int) -> tuple[float, bool, bool]:
        """Reward, terminated and failure of member ``b`` after the last decision."""
        return (
            float(self._reward[b]),
            bool(self._terminated[b] != 0.0),
            bool(self._failure[b] != 0.0),
        )

    def _finish(self) -> None:
        cfg, loop, t = self.config, self.loop, self.path.table
        EK.finish_step(
            self._kind_code, t.kind, t.s0, t.data, self.path.dim, self.path.length,
            loop._fblob.buffer, loop._fblob.layout, loop._iblob.buffer, loop._iblob.layout,
            self._blob.buffer, self._blob.layout, cfg.tolerance, cfg.hard_limit,
            cfg.failure_penalty, self._nominal_progress, self.f_nominal,
        )  # fmt: skip

    # ----------------------------------------------------------- observation
    def observe(self, member: int | None = None) -> dict[str, NDArray[np.float32]]:
        """Observations as documented in the env docstrings (fresh arrays).

        Args:
            member: None for every member (arrays (B, n)), or one member's (arrays (n,)).
        """
        obs = self._v["obs"]
        flat = (obs if member is None else obs[member]).astype(np.float32)
        out, col = {}, 0
        for key, n in self._sizes.items():
            out[key] = flat[..., col : col + n]
            col += n
        return out

    # ------------------------------------------------------------------ info
    def info(self, b: int, failure: bool, ended: bool) -> dict[str, Any]:
        """Info of member ``b`` after a step (SI units)."""
        loop = self.loop
        out: dict[str, Any] = {
            "contour_error": loop.contour_error[b].copy(),
            "contour_error_estimate": loop.contour_error_estimate[b].copy(),
            "tracking_error": self._v["ref"][b] - loop.ax_s[b, :, PK.ST_X],
            "feedrate": float(self.feed[b]),
            "s": float(loop.s[b]),
            "failure": bool(failure),
        }
        if ended:
            out["metrics"] = member_metrics(loop.metrics(), b)
        return out


def member_rngs(seed: int | None, count: int) -> list[np.random.Generator]:
    """Generators for ``count`` members as ``gymnasium`` seeds envs: member i gets ``seed + i``."""
    return [seeding.np_random(None if seed is None else seed + i)[0] for i in range(count)]
