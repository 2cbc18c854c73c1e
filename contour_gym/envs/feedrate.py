"""The feedrate environment: the agent changes the feedrate, F(k) = F(k-1) + dF(k) (004)."""

from __future__ import annotations

from contour_gym.envs.base import ContourEnv, ContourVectorEnv
from contour_gym.envs.core import FEEDRATE

_SPEC = """
    ## Description
    Paper 004's adaptive feedrate task: traverse the path as fast as possible while the
    contour error stays within ``tolerance``. The CCC is fixed (``ccc_gains``, default: the
    plant preset's PID CCC); every step the agent changes the commanded feedrate, which the
    interpolator follows within its acceleration limit, for ``decision_ticks`` ticks.

    ## Action space
    ``Box(-1, 1, (1,), float32)``: ``dF = a * max_feedrate_change * F_nom`` and
    ``F(k) = clip(F(k-1) + dF, F_min, F_max)`` (004 eq. 3.3) with
    ``(F_min, F_max) = feedrate_range * F_nom``. Out-of-range actions are clipped; NaN/inf or
    misshaped actions raise ValueError.

    ## Observation space
    ``Dict`` of float32 ``Box(-1e4, 1e4)`` (scaled values clipped; ``tol`` = ``tolerance``):

    | key | shape | meaning | unit and scale |
    |---|---|---|---|
    | contour_error | (C,) | estimated contour error, signed in 2-D | m / tol |
    | contour_error_change | (C,) | its change over the decision (004's 2nd input) | m / tol |
    | tracking_error | (A,) | reference minus encoder reading per axis | m / 1 mm |
    | reference_velocity | (A,) | reference velocity per axis | (m/s) / F_nom |
    | curvature | (1+L,) | path curvature at s_ref and ``lookahead`` distances ahead | 1/m x 1 cm |
    | progress | (1,) | s_ref / path length | - |
    | feedrate | (2,) | commanded feedrate, actual path speed | (m/s) / F_nom |

    ## Reward
    ``r = ds / (F_nom T_dec) - 10 max(0, max|eps_true| - tolerance) / tolerance``: progress
    (1 per step at the nominal feedrate) minus a penalty for the decision's worst excess over
    the tolerance; ``-failure_penalty`` on failure.

    ## Starting state
    At rest at the path start, commanded feedrate F_nom.

    ## Episode end
    Terminated when the reference reaches the path end, or on failure (``info["failure"]``).
    Truncated by the registered ``max_episode_steps``; stepping after the end without
    ``reset`` raises ``gymnasium.error.ResetNeeded``.

    ## Info
    As the CCC env: true and estimated contour error, tracking errors, ``feedrate``, ``s``,
    ``failure``, and ``metrics`` (including ``cycle_time``) at the end.

    ## Arguments
    As the CCC env, plus ``ccc_gains``, ``feedrate_range``, ``max_feedrate_change``.

    ## Version history
    v0: initial release.
"""


class FeedrateEnv(ContourEnv):  # noqa: D101 (the spec is assigned to __doc__)
    __doc__ = "Feedrate changes as actions (``contour_gym/Feedrate-v0``).\n" + _SPEC
    kind = FEEDRATE


class FeedrateVectorEnv(ContourVectorEnv):  # noqa: D101
    __doc__ = "Native vector version of :class:`FeedrateEnv`.\n" + _SPEC
    kind = FEEDRATE
