"""The CCC-gain environment: the agent sets the cross-coupled controller's PID gains."""

from __future__ import annotations

from contour_gym.envs.base import (
    OBSERVATION_V1,
    OBSERVATION_V1_NOTES,
    ContourEnv,
    ContourVectorEnv,
)
from contour_gym.envs.core import CCC

_SPEC = (
    """
    ## Description
    A multi-axis servo stage follows a contour under per-axis position control; a
    cross-coupled controller (CCC, Koren 1980; a PID on the contour error by default,
    ``ccc_law``) acts on the *estimated* contour error of each contour (the paper's estimator
    by default, fed by the encoder readings) and distributes its output to the axes through
    the coupling gains, into the control signal or the commanded position
    (``ccc_injection``, the paper's by default). Every step the agent chooses the CCC gains
    (kp, ki, kd) of each contour, held for ``decision_ticks`` servo ticks. The feedrate is
    fixed. The machine is a rig (encoder quantisation, one-tick computation delay) unless
    ``ideal=True``: high gains amplify quantisation noise into the motor command and, past a
    point, destabilise the loop, so the best gains are interior.

    ## Action space
    ``Box(-1, 1, (3C,), float32)``, C = contours of the stage (1; 2 for ``xyy_gantry``).
    For contour c, ``action[3c:3c+3]`` maps to (kp, ki, kd) by
    ``g = g_max (R^((a+1)/2) - 1) / (R - 1)`` with ``R = gain_range^2``: ``a = -1`` is exactly
    0 (no CCC), ``a = 1`` is ``g_max``, and the scale is logarithmic in between (``a = 0`` is
    about ``g_max / gain_range``, the preset's gain). ``g_max`` is ``gain_range`` (default 30)
    times the preset's kp and ki, and ``kd_scale`` (default 0.01 s) times its kp for kd.
    ``action_to_gains`` and ``gains_to_action`` convert exactly (``gains_to_action`` of the
    preset's gains, kd = 0 included, round-trips), so reference policies speak in gains.
    Out-of-range actions are clipped to [-1, 1]; NaN/inf or misshaped actions raise
    ValueError.

    ## Observation space
    ``Dict`` of float32 ``Box(-1e4, 1e4)`` (scaled values clipped to that; ``tol`` is
    ``tolerance``):

"""
    + OBSERVATION_V1
    + """    | gains | (3C,) | the action in force | [-1, 1] |

"""
    + OBSERVATION_V1_NOTES
    + """
    ``-v0`` ids (``observation="v0"``; the shipped agents were trained on it):

    | key | shape | meaning | unit and scale |
    |---|---|---|---|
    | contour_error | (C,) | estimated contour error (what a controller has), signed | m / tol |
    | contour_error_change | (C,) | its change over the last decision | m / tol |
    | tracking_error | (A,) | reference minus encoder reading per axis | m / 1 mm |
    | reference_velocity | (A,) | reference velocity per axis | (m/s) / nominal feedrate |
    | curvature | (1+L,) | curvature at s_ref and ``lookahead`` ahead (signed in 2-D) | 1/m x 1 cm |
    | progress | (1,) | the machine's foot point along the path / path length | - |
    | gains | (3C,) | the action in force | [-1, 1] |

    ## Reward
    A compiled reward of the step's components (``contour_gym.rewards``; ``reward`` and
    ``reward_weights`` swap it), by default
    ``r = -(contour + 10 chatter)``: ``contour`` the mean |true contour error| over the
    decision's ticks in tolerances, ``chatter`` the mean |u_k - u_(k-1)| / u_max over ticks
    and axes (the price of gains that amplify encoder noise into the motor). Each step's
    reward is clipped to the reward's range ``[r_lo, r_hi]`` over the components' bounds;
    ``info["reward_components"]`` holds the components.

    **Failure never pays.** On failure the step's reward makes the episode's return exactly
    ``N r_lo - failure_penalty`` (N the env's step limit): below any completed or truncated
    episode, which earns at least ``r_lo`` on each of at most N steps.

    ## Starting state
    All axes at rest at the path start, integrators empty, CCC gains at the preset's (the
    ``gains`` observation shows them). With ``randomize`` the plant is redrawn per episode.

    ## Episode end
    Terminated when the machine is in position at the path end (the reference has ended, the
    machine's foot point has reached the end, and every axis is within the stage's
    in-position band and nearly at rest), or on failure: |true contour error| >
    ``hard_limit`` (default 100 tolerances), a diverged state, or not in position
    ``settle_time`` after the reference ended (``info["failure"] = True``). Truncated at the
    env's own step limit N (``step_limit``; default twice the planned decisions of its
    path at its feedrate, plus 10; on random paths, of each episode's path). Stepping after
    the end without ``reset`` raises ``gymnasium.error.ResetNeeded``.

    ## Info
    Every step: ``contour_error`` (true, m, signed in 2-D), ``contour_error_estimate``,
    ``tracking_error`` (true, m), ``feedrate`` (m/s), ``s`` (m), ``failure``,
    ``reward_components``. At every episode end (terminated or truncated) also ``metrics``: the
    episode's ``contour_gym.metrics`` (the keys of ``contour_gym.simulate``, ``failure_reason``
    5 for the hard limit: ``contour_gym.loop.REASON_NAMES``) and ``finished``
    (whether the machine got in position at the end). The vector env batches each key with a
    ``_key`` mask.

    ## Arguments
    ``plant`` (name or ``{"preset": name, **overrides}``), ``path`` (name, Path or
    ``"random"``: each episode its own path, ``path_options``, run under ``"G64"`` look-ahead
    unless ``path_control`` says otherwise, and at the preset's ``part_accel``),
    ``feedrate``, ``feedrate_override``, ``laps``, ``ideal``, ``estimator``,
    ``estimator_options``, ``axis_controller``, ``controller_options``, ``ccc_law``,
    ``ccc_law_params``, ``ccc_injection``, ``path_control``, ``path_tolerance``, ``decision_ticks``,
    ``tolerance``, ``hard_limit``, ``failure_penalty``, ``reward``, ``reward_weights``,
    ``randomize``, ``lookahead``, ``ccc_weights``, ``gain_range``, ``kd_scale``, ``settle_time``,
    ``step_limit``, ``render_mode`` ("rgb_array", "human"); see
    :class:`contour_gym.envs.config.EnvConfig`. Unknown arguments raise ValueError listing the
    accepted ones.

    ## Version history
    v1: the observation fit to generalise over paths (tracking errors in tolerances, speed
    relative to the programmed feed and the machine's limit, the geometry ahead by arc length;
    no ``progress``). v0: initial release.
"""
)


class CCCEnv(ContourEnv):  # noqa: D101 (the spec is assigned to __doc__)
    __doc__ = "Cross-coupled controller gains as actions (``contour_gym/CCC-v0``).\n" + _SPEC
    kind = CCC


class CCCVectorEnv(ContourVectorEnv):  # noqa: D101
    __doc__ = "Native vector version of :class:`CCCEnv` (one array program).\n" + _SPEC
    kind = CCC
