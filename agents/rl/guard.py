"""A CCC agent guarded through sharp corners and near-cusps: the PID CCC's gains there.

:class:`CornerGuard` (``corner_guard``) hands a CCC agent's gains to the PID CCC
(:class:`~agents.ccc_policies.PIDCCC`, the env's own gains) from ``near`` before a corner
turning more than ``angle`` until ``hold`` decisions after it, and while the path within
``near`` curves tighter than ``curvature``; the agent acts everywhere else. It reads the v1
observation's ``corner`` (distance and turn of the next corner within the preview horizon)
and its curvatures. On 000's machine (G64 blending, 000's ``two_circle`` estimator) the
estimate the CCC acts on is poor through a sharp turn: the general CCC agent raises its gains
on it and the error overshoots after the corner, where the PID CCC's held gains do not. Past a
near-cusp (a rose's tip) its gains swing the error by over 100 um within 30 ms while its
estimate is good. The generalization suite runs ``ppo_000_ccc_general`` guarded; 002's and
004's CNCs stop at sharp corners, and their agents run unguarded.

Chosen, not published: the defaults (2 mm, 85 degrees, 20 decisions: 0.2 s at 000's 1 kHz servo
rate; 5000 1/m: a radius under 0.2 mm), on 64 validation paths of 000's nominal machine
(random seeds 1000000-1000063: no training, tuning or test path) and checked on 128 fresh
paths (seeds 2000000-2000127); docs/measurements.md, "The corner and near-cusp guard", gives
the runs.

:class:`CappedFeedrate` (``capped_feedrate``) passes a feedrate agent's action capped at
``cap``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.ccc_policies import PIDCCC
from agents.policy_base import (
    Actions,
    Observation,
    Policy,
    batch_size,
    make_policy,
    register_policy,
)
from agents.rl import saved  # noqa: F401 (registers the trained agents a guard wraps)
from contour_gym.envs import CURVATURE_SCALE
from contour_gym.envs.core import CCC, FEEDRATE
from contour_gym.params import finite, positive, positive_or_inf


class CornerGuard(Policy):
    """A CCC agent that hands the gains to the PID CCC through sharp corners and near-cusps.

    Args:
        agent: A registered CCC policy's name (a trained agent: ``ppo_000_ccc_general``).
        near: Distance before a corner from which the PID CCC acts, m (> 0).
        angle: The smallest turn of a guarded corner, rad (in (0, pi]).
        hold: Decisions (env steps) the PID CCC keeps acting after the corner (>= 0).
        curvature: Also guard while the path within ``near`` (the observation's curvature at
            the reference and at the previews no farther) curves tighter than this, 1/m
            (> 0; ``inf``: corners only; 5000: a radius under 0.2 mm).

    Each member's hold is its own; :meth:`reset` clears them, a member's automatic reset in
    a vector env does not (a hold running at its episode's end lasts into its next one).

    Raises:
        ValueError: naming the value, for a bad ``near``, ``angle``, ``hold`` or
            ``curvature``, or an unknown agent.
    """

    name = "corner_guard"
    tasks = (CCC,)

    def __init__(self, agent: str = "ppo_000_ccc_general", near: float = 0.002,
                 angle: float = math.radians(85.0), hold: int = 20,
                 curvature: float = 5000.0) -> None:
        self.near = positive(near, "near")
        self.curvature = positive_or_inf(curvature, "curvature")
        if not 0.0 < finite(angle, "angle") <= math.pi:
            raise ValueError(f"angle must be in (0, pi] rad, got {angle!r}")
        if isinstance(hold, bool) or not isinstance(hold, int) or hold < 0:
            raise ValueError(f"hold must be an int >= 0 (decisions), got {hold!r}")
        self.angle, self.hold = float(angle), hold
        self.agent, self.fallback = make_policy(agent), PIDCCC()
        self._horizon = math.nan
        self._within = np.zeros(0, dtype=bool)  # curvature samples within near (reset)
        self._left: np.ndarray | None = None  # per member: decisions the hold still lasts
        self._was_near: np.ndarray | None = None

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The agent's env arguments."""
        return self.agent.env_kwargs

    def reset(self, env: Any = None) -> None:
        """Reset the agent and the PID CCC, and read the env's preview horizon.

        Raises:
            ValueError: without a contour_gym env of the v1 observation.
        """
        config = getattr(getattr(env, "unwrapped", None), "config", None)
        if config is None or config.observation != "v1":
            raise ValueError(f"corner_guard needs a contour_gym env of the v1 observation, "
                             f"got {env!r}")
        self._horizon = float(max(config.preview))
        self._within = np.array([True, *(d <= self.near for d in config.preview)])
        self.agent.reset(env)
        self.fallback.reset(env)
        self._left = self._was_near = None

    def act(self, obs: Observation) -> Actions:
        """The agent's actions; the PID CCC's near a sharp corner or near-cusp, or just past one."""
        if math.isnan(self._horizon):
            raise ValueError("corner_guard reads the env's preview horizon at reset(env): "
                             "call it first")
        if "corner" not in obs:
            raise ValueError(f"corner_guard acts on the v1 Dict observation (its 'corner' key), "
                             f"got keys {sorted(obs)}")
        actions = np.array(self.agent.act(obs), dtype=np.float64)
        n = batch_size(obs)
        if self._left is None or self._was_near is None or self._left.shape[0] != n:
            self._left, self._was_near = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool)
        corner = np.asarray(obs["corner"], dtype=np.float64)
        near = (corner[:, 0] * self._horizon < self.near) & (
            np.abs(corner[:, 1]) * math.pi > self.angle)
        if math.isfinite(self.curvature):
            curvature = np.asarray(obs["curvature"], dtype=np.float64)[:, self._within]
            kappa = np.abs(curvature) / CURVATURE_SCALE
            near |= (kappa > self.curvature).any(axis=1)
        passed = self._was_near & ~near
        self._left = np.where(passed, self.hold, np.maximum(self._left - 1, 0))
        self._was_near = near
        guarded = near | (self._left > 0)
        if guarded.any():
            actions[guarded] = self.fallback.act(obs)[guarded]
        return actions


class CappedFeedrate(Policy):
    """A feedrate agent whose action is capped (``capped_feedrate``): never faster than ``cap``.

    The general feedrate agent acts ``a`` in [-1, 1] on the curvature feed limit ``L``, the
    override target ``L span^a`` (the env's ``limit_span``: 2 for the shipped agent); capped at
    0 it only ever slows below the limit. Chosen, not published: on 256 random paths of 004's
    nominal machine (seeds 1000128-1000383; docs/measurements.md, "Every candidate on 256 more
    paths") the shipped agent capped at 0 keeps 5 um on 228 at a median cycle of 6.43 s, the
    most of every candidate (the limit alone 227 at 5.84 s, the agent 212 at 5.86 s, an oracle
    of per-path constants 231 at 7.59 s); capped at 0.25, 221 at 6.07 s.

    Args:
        agent: A registered feedrate policy's name (a trained agent:
            ``ppo_004_feedrate_general``).
        cap: The largest action it passes on, in [-1, 1].

    Raises:
        ValueError: naming the value, for a ``cap`` outside [-1, 1] or an unknown agent.
    """

    name = "capped_feedrate"
    tasks = (FEEDRATE,)

    def __init__(self, agent: str = "ppo_004_feedrate_general", cap: float = 0.0) -> None:
        if not -1.0 <= finite(cap, "cap") <= 1.0:
            raise ValueError(f"cap must be in [-1, 1], got {cap!r}")
        self.cap, self.agent = float(cap), make_policy(agent)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The agent's env arguments."""
        return self.agent.env_kwargs

    def reset(self, env: Any = None) -> None:
        """Reset the agent (it checks ``env``)."""
        self.agent.reset(env)

    def act(self, obs: Observation) -> Actions:
        """The agent's actions, none above ``cap``."""
        return np.minimum(np.asarray(self.agent.act(obs), dtype=np.float64), self.cap)


register_policy(CornerGuard.name, CornerGuard)
register_policy(CappedFeedrate.name, CappedFeedrate)
