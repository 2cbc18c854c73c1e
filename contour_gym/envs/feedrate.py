"""The feedrate environment: the agent changes the feedrate, F(k) = F(k-1) + dF(k) (004)."""

from __future__ import annotations

from contour_gym.envs.base import (
    OBSERVATION_V1,
    OBSERVATION_V1_NOTES,
    ContourEnv,
    ContourVectorEnv,
)
from contour_gym.envs.core import FEEDRATE

_SPEC = (
    """
    ## Description
    Paper 004's adaptive feedrate task: traverse the path as fast as possible while the
    contour error stays within ``tolerance``. No CCC runs (004 has none) unless
    ``ccc_gains`` fixes its gains. Every step the agent changes the feedrate, which the
    interpolator follows within the machine's acceleration limit, for ``decision_ticks`` ticks. The
    interpolator only stops where it must (the path end, exact stops and dwells of a G-code
    part): slowing for corners and curves is the agent's job, unless ``path_control`` turns
    on the CNC's own look-ahead planning (the ``cnc_lookahead`` reference policy does). On
    random paths (``path="random"``) the CNC stops at real corners (``"G61.1"``, unless
    ``path_control`` says otherwise): the override's floor cannot stop the axes there.

    ## Action space
    ``Box(-1, 1, (1,), float32)``: ``dF = a * max_feedrate_change * F_nom`` and
    ``F(k) = clip(F(k-1) + dF, F_min, F_max)`` (004 eq. 3.3) with
    ``(F_min, F_max) = feedrate_range * F_nom``, where ``F_nom`` is the programmed feedrate of
    the current block (one value on a plain path; a G-code part's own F words), i.e. the action
    moves the feed override ``F / F_nom`` by ``a * max_feedrate_change``. Rapid moves run at the
    machine's rapid rate whatever the override. Out-of-range actions are clipped; NaN/inf or
    misshaped actions raise ValueError. With ``feedrate_target=(low, mid, high)`` the action is
    instead a target override, ``mid (high / mid)^a`` for ``a >= 0`` and ``mid (low / mid)^-a``
    below, and ``dF`` the step toward it, at most ``max_feedrate_change * F_nom``; on an
    episode's first decision, the axes still at rest, the override takes the target at once.
    With ``feedrate_limit=(a_c, reach)`` too, the zero action's target is not ``mid`` but a
    centripetal acceleration limit, ``sqrt(a_c / kappa) / F`` within [``low``, ``mid``]
    (``kappa`` the tightest curvature within ``reach`` ahead, ``F`` the block's programmed
    feed), and the action departs from it on the same scale; ``feedrate_limit=(a_c, reach,
    v_end, end_reach)`` also keeps the speed to ``v_end`` within ``end_reach`` of the path's
    end, where the axes stop. With ``limit_span`` too, the target is the limit times
    ``limit_span^a``, within [``low``, ``high``]: the same factor up and down.

    ## Observation space
    ``Dict`` of float32 ``Box(-1e4, 1e4)`` (scaled values clipped; ``tol`` = ``tolerance``):

"""
    + OBSERVATION_V1
    + """    | feedrate | (2,) | the override F / F_nom, actual path speed / F_nom | - |

"""
    + OBSERVATION_V1_NOTES
    + """
    ``-v0`` ids (``observation="v0"``; the shipped agents were trained on it):

    | key | shape | meaning | unit and scale |
    |---|---|---|---|
    | contour_error | (C,) | estimated contour error, signed in 2-D | m / tol |
    | contour_error_change | (C,) | its change over the decision (004's 2nd input) | m / tol |
    | tracking_error | (A,) | reference minus encoder reading per axis | m / 1 mm |
    | reference_velocity | (A,) | reference velocity per axis | (m/s) / nominal feedrate |
    | curvature | (1+L,) | path curvature at s_ref and ``lookahead`` distances ahead | 1/m x 1 cm |
    | progress | (1,) | the machine's foot point along the path / path length | - |
    | feedrate | (2,) | the override F / F_nom, actual path speed / F_nom | - |

    ## Reward
    By default ``r = progress - 1 - 30 excess`` (``contour_gym.rewards``): ``progress`` the
    arc length advanced in the decision over ``F_nom x decision time`` (1 per step at the
    nominal feedrate), 1 the price of a step, ``excess = max(0, peak - 1)`` with ``peak`` the
    decision's max |true contour error| in tolerances. Summed, the progress is the path's
    length in nominal steps whatever the speed, so the return is the time saved over the
    nominal feedrate (in decisions) less 30 per tolerance of excess: faster within the
    tolerance scores higher. ``reward_weights={"margin": m}`` charges the peak above ``m``
    tolerances instead of 1 (``max(0, peak - m)``). Clipped to the reward's range ``[r_lo, r_hi]``;
    ``info["reward_components"]`` holds the components.

    **Failure never pays.** On failure the step's reward makes the episode's return exactly
    ``N min(r_lo, 0) - failure_penalty`` (N the env's step limit), below any completed or
    truncated episode.

    ## Starting state
    At rest at the path start, override 1 (``feedrate_override`` if given).

    ## Episode end
    Terminated when the machine is in position at the path end, or on failure (|true
    contour error| > ``hard_limit``, a diverged state, or not in position ``settle_time`` after
    the reference ended; ``info["failure"]``). Truncated at the env's own step limit N (twice
    the planned decisions at the slowest feedrate, plus 10); stepping after the end without
    ``reset`` raises ``gymnasium.error.ResetNeeded``.

    ## Info
    As the CCC env: true and estimated contour error, tracking errors, ``feedrate`` (m/s),
    ``s``, ``failure``, ``reward_components``, and ``metrics`` (including ``cycle_time``, the
    time until in position at the end, and ``finished``) at every episode end.

    ## Arguments
    As the CCC env, plus ``ccc_gains``, ``feedrate_range``, ``max_feedrate_change``,
    ``feedrate_target``, ``feedrate_limit``, ``limit_span``. On
    ``path="random"`` each part is programmed at feeds drawn from 0.3 to 1 times the machine's
    ``max_feedrate`` (``path_options={"feed_range": ...}`` to change it), and its highest
    feed is the episode's nominal feedrate.

    ## Version history
    v1: the observation fit to generalise over paths (tracking errors in tolerances, speed
    relative to the programmed feed and the machine's limit, the geometry ahead by arc length;
    no ``progress``). v0: initial release.
"""
)


class FeedrateEnv(ContourEnv):  # noqa: D101 (the spec is assigned to __doc__)
    __doc__ = "Feedrate changes as actions (``contour_gym/Feedrate-v0``).\n" + _SPEC
    kind = FEEDRATE


class FeedrateVectorEnv(ContourVectorEnv):  # noqa: D101
    __doc__ = "Native vector version of :class:`FeedrateEnv`.\n" + _SPEC
    kind = FEEDRATE
