"""The batched core both env kinds share: B members on one ServoLoop.

The single envs run it with B = 1 and the native vector envs with B = num_envs, so a vector
env equals a loop of single envs by construction: every member owns its generator (seeded
the way ``gymnasium.Env.reset(seed)`` seeds ``np_random``), its randomisation draws, its loop
noise stream and its clock.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from numpy.typing import NDArray

from contour_gym import motion
from contour_gym.api import make_scenario
from contour_gym.envs.config import EnvConfig
from contour_gym.metrics import ErrorSums, member_metrics
from contour_gym.plant import _kernel as PK

Array = NDArray[np.float64]
CCC, FEEDRATE = "ccc", "feedrate"
CURVATURE_SCALE = 0.01  # m: curvature is observed as kappa * 1 cm
TRACKING_SCALE = 1e-3  # m: tracking errors are observed in mm
FEEDRATE_PENALTY = 10.0  # feedrate env: penalty per tolerance of excess error
OBS_LIMIT = 1e4  # every scaled observation is clipped to +-OBS_LIMIT


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
        self.log_lo = np.log([kp0 / r, ki0 / r, kp0 * 1e-5])
        self.log_hi = np.log([kp0 * r, ki0 * r, kp0 * 1e-2])
        # the CCC env starts from the preset gains clipped into its action range (kd = 0 sits
        # at the log scale's floor); the feedrate env holds them as given
        self.g_start = np.clip(self.g0, np.exp(self.log_lo), np.exp(self.log_hi)) if kind == CCC else self.g0
        self.rngs: list[np.random.Generator] = [np.random.default_rng(0)] * batch
        self.gains = np.repeat(self.g_start[None, None], batch, 0).repeat(self.n_contours, 1)
        self.feed = np.full(batch, self.f_nominal)
        self.eps_prev = np.zeros((batch, self.n_contours))
        self.action = np.zeros((batch, self.n_actions), dtype=np.float32)
        self._axis_map = [(c.axes[j], i, j) for i, c in enumerate(self.stage.contours) for j in range(c.dim)]
        self._offsets = [(c.offset[j] if c.offset else 0.0) for c in self.stage.contours for j in range(c.dim)]

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
        sizes = self._observation_sizes()
        return spaces.Dict(
            {k: spaces.Box(-OBS_LIMIT, OBS_LIMIT, (n,), np.float32) for k, n in sizes.items()}
        )

    def _observation_sizes(self) -> dict[str, int]:
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
        a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0).reshape(*np.shape(action)[:-1], -1, 3)
        return np.exp(self.log_lo + 0.5 * (a + 1.0) * (self.log_hi - self.log_lo))

    def gains_to_action(self, gains: Array) -> Array:
        """Inverse of :meth:`action_to_gains`; gains outside the range map outside [-1, 1]."""
        g = np.asarray(gains, dtype=float)
        if np.any(g <= 0) or not np.all(np.isfinite(g)):
            raise ValueError(f"gains must be finite and > 0 to have an action, got {g}")
        a = 2.0 * (np.log(g) - self.log_lo) / (self.log_hi - self.log_lo) - 1.0
        return a.reshape(*g.shape[:-2], -1)

    # ----------------------------------------------------------------- reset
    def reset_members(self, members: NDArray[np.intp], rngs: list[np.random.Generator]) -> None:
        """Start new episodes for ``members`` with their generators ``rngs``."""
        seeds = []
        for b, rng in zip(members, rngs):
            self.rngs[b] = rng
            self._randomize(int(b), rng)
            seeds.append(int(rng.integers(2**63 - 1)))
        self.loop.reset(seeds, members=members)
        self.gains[members] = self.g_start
        self.feed[members] = self.f_nominal
        self.eps_prev[members] = 0.0
        start = self.gains_to_action(self.gains[members]) if self.kind == CCC else 0.0
        self.action[members] = np.clip(start, -1.0, 1.0)
        self._push_settings()

    def _randomize(self, b: int, rng: np.random.Generator) -> None:
        ranges = self.config.randomization()
        if ranges is None:
            return
        shape = (self.n_axes,)
        factors = {k: 1.0 + rng.uniform(-ranges[k], ranges[k], shape) for k in ("mass", "damping", "force_constant")}
        for k in ("friction", "disturbance"):
            factors[k] = rng.uniform(ranges[k][0], ranges[k][1], shape)
        self.loop.set_plant_scaling([b], **factors)

    def _push_settings(self) -> None:
        if self.kind == CCC:
            self.loop.set_ccc_gains(self.gains)
        else:
            self.loop.set_feedrate(self.feed)

    # ------------------------------------------------------------------ step
    def apply(self, actions: Array, skip: NDArray[np.bool_]) -> None:
        """Apply clipped actions (B, n) to the members not in ``skip``."""
        a = np.clip(actions, -1.0, 1.0)
        live = ~skip
        if self.kind == CCC:
            self.gains[live] = self.action_to_gains(a[live])
        else:
            df = a[live, 0] * self.config.max_feedrate_change * self.f_nominal
            self.feed[live] = np.clip(self.feed[live] + df, *self.f_bounds)  # 004 eq. 3.3
        self.action[live] = a[live]
        self._push_settings()

    def advance(self, skip: NDArray[np.bool_]) -> tuple[ErrorSums, Array]:
        """Run one decision; returns the window sums and each member's progress (m)."""
        s_before = self.loop.s.copy()
        self.eps_prev = np.where(skip[:, None], self.eps_prev, self.loop.contour_error_estimate)
        window = self.loop.step(self.config.decision_ticks, skip=np.flatnonzero(skip))
        return window, self.loop.s - s_before

    def reward(self, window: ErrorSums, progress: Array) -> tuple[Array, NDArray[np.bool_], NDArray[np.bool_]]:
        """Rewards (B,), terminated (B,) and failure (B,) of the decision just run.

        CCC: ``-mean(|eps|) / tolerance`` over the decision's ticks and contours.
        Feedrate: ``ds / (F_nom T_dec) - 10 max(0, max|eps| - tol) / tol``.
        Either way a failure subtracts ``failure_penalty``.
        """
        cfg = self.config
        c = window.contour
        max_eps = c[..., 2].max(axis=1)
        if self.kind == CCC:
            reward = -(c[..., 0].sum(1) / np.maximum(c[..., 3].sum(1), 1.0)) / cfg.tolerance
        else:
            nominal = self.f_nominal * cfg.decision_ticks * self.stage.ts
            excess = np.maximum(max_eps - cfg.tolerance, 0.0) / cfg.tolerance
            reward = progress / nominal - FEEDRATE_PENALTY * excess
        failure = self.loop.failed | (max_eps > cfg.hard_limit)
        reward = np.where(failure, -cfg.failure_penalty, np.nan_to_num(reward, nan=0.0, posinf=0.0, neginf=0.0))
        terminated = failure | self.loop.done
        return reward, terminated, failure

    # ----------------------------------------------------------- observation
    def _to_axes(self, coords: Array, offset: bool) -> Array:
        out = np.zeros((coords.shape[0], self.n_axes))
        for (axis, _, j), off in zip(self._axis_map, self._offsets):
            out[:, axis] = coords[:, j] + (off if offset else 0.0)
        return out

    def _curvature(self, s: Array) -> Array:
        if self.path.dim == 2:
            return np.asarray(self.path.signed_curvature(s))  # type: ignore[attr-defined]
        return np.asarray(self.path.curvature(s))

    def observe(self) -> dict[str, NDArray[np.float32]]:
        """Observations (B, ...) as documented in the env docstrings."""
        cfg, loop = self.config, self.loop
        s, v = loop.s, loop.ip_s[:, motion.IS_V]
        ref = self._to_axes(self.path.point(s).reshape(len(s), -1), offset=True)
        vel = self._to_axes(self.path.tangent(s).reshape(len(s), -1) * v[:, None], offset=False)
        ahead = np.minimum(s[:, None] + np.array((0.0, *cfg.lookahead)), self.path.length)
        curv = self._curvature(ahead.ravel()).reshape(ahead.shape) * CURVATURE_SCALE
        eps = loop.contour_error_estimate
        obs = {
            "contour_error": eps / cfg.tolerance,
            "contour_error_change": (eps - self.eps_prev) / cfg.tolerance,
            "tracking_error": (ref - loop.measured_position) / TRACKING_SCALE,
            "reference_velocity": vel / self.f_nominal,
            "curvature": curv,
            "progress": (s / self.path.length)[:, None],
        }
        if self.kind == CCC:
            obs["gains"] = self.action
        else:
            obs["feedrate"] = np.column_stack([self.feed, v]) / self.f_nominal
        return {k: np.clip(val, -OBS_LIMIT, OBS_LIMIT).astype(np.float32) for k, val in obs.items()}

    # ------------------------------------------------------------------ info
    def info(self, b: int, failure: bool, ended: bool) -> dict[str, Any]:
        """Info of member ``b`` after a step (SI units)."""
        loop = self.loop
        x = loop.ax_s[b, :, PK.ST_X]
        ref = self._to_axes(self.path.point(loop.s[b : b + 1]).reshape(1, -1), offset=True)[0]
        out: dict[str, Any] = {
            "contour_error": loop.contour_error[b].copy(),
            "contour_error_estimate": loop.contour_error_estimate[b].copy(),
            "tracking_error": ref - x,
            "feedrate": float(self.feed[b]) if self.kind == FEEDRATE else float(self.f_nominal),
            "s": float(loop.s[b]),
            "failure": bool(failure),
        }
        if ended:
            out["metrics"] = member_metrics(loop.metrics(), b)
        return out


def member_rngs(seed: int | None, count: int) -> list[np.random.Generator]:
    """Generators for ``count`` members as ``gymnasium`` seeds envs: member i gets ``seed + i``."""
    return [seeding.np_random(None if seed is None else seed + i)[0] for i in range(count)]
