"""A CCC agent guarded through sharp corners and near-cusps: the PID CCC's gains there.

On 000's machine (G64 blending, 000's ``two_circle`` estimator) the general CCC agent's
largest losses to no CCC at all were at sharp line corners: the estimate the CCC acts on is
poor through the turn, the agent raises its gains on it and the error overshoots after the
corner, where the PID CCC's held gains do not (random path 7010 of the generalization suite:
119 um against no CCC's 65 and the PID CCC's 54). :class:`CornerGuard` hands the gains to the
PID CCC (:class:`~agents.ccc_policies.PIDCCC`, the env's own gains) from ``near`` before a
corner turning more than ``angle`` until ``hold`` decisions after it, and leaves the agent
acting everywhere else. It reads the v1 observation's ``corner`` (distance and turn of the
next corner within the preview horizon).

Chosen, not published: the defaults (2 mm, 85 degrees, 20 decisions: 0.2 s at 000's 1 kHz servo
rate). The first setting (2 mm, 30 degrees, 20 decisions) was tried on a validation set of 32
random paths of 000's randomised machine (seeds 1000000-1000031: no training, tuning or test
path; the training runs' evaluation draws other paths from seeds 1000000-1000015, on the
nominal machine), where the agent lost to no CCC on 5 paths and the guarded agent on 3, at the
same median (29.82 um); without the hold after the corner it lost on 5 (4 -> 2 and 4 before the
interpolator braked for every junction in reach). On 002's and 004's validation sets (the same
seeds, their machines; their CNCs stop at sharp corners) it moved 6 and 5 of the 32 peaks by up
to 4.5 %, but neither median nor the paths lost to no CCC (1 and 6).

The angle became 85 degrees on 2026-12-02, after the suite's per-path results had been seen:
there the agent (retrained under the CCC's release at stops) beat the PID CCC after corners
turning 35-73 degrees (random paths 7003, 7004, 7007, 7008: 26-36 um against 47-59) and lost
to it after 90-102 degree ones (three G-code parts' 90-degree corners, path 7010), so a 30-degree
guard gave away the agent's best corners. On 000's 64 validation paths (nominal machine)
30, 60 and 85 degrees lose the same 2 paths at the same median (16.30 um); on 128 fresh paths
(seeds 2000000-2000127, used by nothing else; rule set before the run: 85 degrees if it loses
no more and its median is no higher) both lose 8, the median is 23.61 um for both and the mean
33.35 um against 36.03, 85 degrees lower on 25 of the 27 paths where they differ.

It guards near-cusps too since 2026-12-02: where the path within ``near`` curves tighter than
``curvature`` (5000 1/m: a radius under 0.2 mm), as past a rose's tip, the agent's gains swung
the error from +31 to -160 um within 30 ms while its estimate was good (validation path
1000055). By a rule set before measuring (of 2000 and 5000 1/m, the fewest paths lost on the 64
validation paths, then the lower median; adopted only if losing fewer than the corner guard's 2
at a median at most 2 % higher, and then fewer than its 8 on the 128 fresh paths at most 2 %
higher): 5000 loses none at 16.30 um (2000: none at 16.74), and on the fresh paths 5 at 23.82
um (the corner guard alone 8 at 23.61), the same 5 the PID CCC loses.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from agents.ccc_policies import PIDCCC
from agents.policies import Actions, Observation, Policy, batch_size, make_policy, register_policy
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
                 curvature: float = 5000.0) -> None:  # fmt: skip
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
                             f"got {env!r}")  # fmt: skip
        self._horizon = float(max(config.preview))
        self._within = np.array([True, *(d <= self.near for d in config.preview)])
        self.agent.reset(env)
        self.fallback.reset(env)
        self._left = self._was_near = None

    def act(self, obs: Observation) -> Actions:
        """The agent's actions; the PID CCC's near a sharp corner or near-cusp, or just past one."""
        if math.isnan(self._horizon):
            raise ValueError("corner_guard reads the env's preview horizon at reset(env): "
                             "call it first")  # fmt: skip
        if "corner" not in obs:
            raise ValueError(f"corner_guard acts on the v1 Dict observation (its 'corner' key), "
                             f"got keys {sorted(obs)}")  # fmt: skip
        actions = np.array(self.agent.act(obs), dtype=np.float64)
        n = batch_size(obs)
        if self._left is None or self._was_near is None or self._left.shape[0] != n:
            self._left, self._was_near = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool)
        corner = np.asarray(obs["corner"], dtype=np.float64)
        near = (corner[:, 0] * self._horizon < self.near) & (
            np.abs(corner[:, 1]) * math.pi > self.angle)  # fmt: skip
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
    0 it only ever slows below the limit. Chosen,
    not published, before its suite rows were seen: on 256 random paths of 004's nominal
    machine (seeds 1000128-1000383, docs/training.md "Every candidate on 256 more paths")
    the shipped agent capped at 0 kept 5 um on 228 at a median cycle of 6.43 s, the most of
    every candidate (the limit alone 227 at 5.84 s, the agent 212 at 5.86 s, an oracle of
    per-path constants 231 at 7.59 s); capped at 0.25, 221 at 6.07 s.

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
