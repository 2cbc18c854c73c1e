"""The CCC-gain environment: the agent sets the cross-coupled controller's PID gains."""

from __future__ import annotations

from contour_gym.envs.base import ContourEnv, ContourVectorEnv
from contour_gym.envs.core import CCC

_SPEC = """
    ## Description
    A multi-axis servo stage follows a contour under per-axis position control; a PID
    cross-coupled controller (CCC, Koren 1980) acts on the estimated contour error of each
    contour and distributes its output to the axes through the coupling gains. Every step
    the agent chooses the CCC gains (kp, ki, kd) of each contour, held for ``decision_ticks``
    servo ticks. The feedrate is fixed.

    ## Action space
    ``Box(-1, 1, (3C,), float32)``, C = contours of the stage (1; 2 for ``xyy_gantry``).
    For contour c: ``action[3c:3c+3]`` maps log-linearly to (kp, ki, kd):
    ``g = exp(log(lo) + (a + 1)/2 (log(hi) - log(lo)))`` with, around the plant preset's CCC
    gains (kp0, ki0), ``kp in [kp0/R, kp0 R]``, ``ki in [ki0/R, ki0 R]``,
    ``kd in kp0 [1e-5, 1e-2] s`` and ``R = gain_range`` (default 30). Out-of-range actions are
    clipped to [-1, 1]; NaN/inf or misshaped actions raise ValueError. ``action_to_gains`` and
    ``gains_to_action`` convert, so reference policies can speak in gains.

    ## Observation space
    ``Dict`` of float32 ``Box(-1e4, 1e4)`` (scaled values clipped to that; ``tol`` is
    ``tolerance``):

    | key | shape | meaning | unit and scale |
    |---|---|---|---|
    | contour_error | (C,) | estimated contour error (what a controller has), signed | m / tol |
    | contour_error_change | (C,) | its change over the last decision | m / tol |
    | tracking_error | (A,) | reference minus encoder reading per axis | m / 1 mm |
    | reference_velocity | (A,) | reference velocity per axis | (m/s) / nominal feedrate |
    | curvature | (1+L,) | curvature at s_ref and ``lookahead`` ahead (signed in 2-D) | 1/m x 1 cm |
    | progress | (1,) | s_ref / path length | - |
    | gains | (3C,) | the action in force | [-1, 1] |

    ## Reward
    ``r = -mean(|eps_true|) / tolerance`` over the decision's ticks (and contours), i.e. 0 is
    a perfect contour; ``-failure_penalty`` on failure.

    ## Starting state
    All axes at rest at the path start, integrators empty, CCC gains at the preset's (the
    ``gains`` observation shows them). With ``randomize`` the plant is redrawn per episode.

    ## Episode end
    Terminated when the reference reaches the path end, or on failure (|true contour error|
    > ``hard_limit`` or a diverged state; ``info["failure"] = True``). Truncated by the
    registered ``max_episode_steps``. Stepping after the end without ``reset`` raises
    ``gymnasium.error.ResetNeeded``.

    ## Info
    Every step: ``contour_error`` (true, m, signed in 2-D), ``contour_error_estimate``,
    ``tracking_error`` (true, m), ``feedrate`` (m/s), ``s`` (m), ``failure``. At the end also
    ``metrics``: the episode's ``contour_gym.metrics`` (the keys of ``contour_gym.simulate``).

    ## Arguments
    ``plant``, ``path`` (name or Path), ``feedrate``, ``estimator``, ``estimator_options``,
    ``axis_controller``, ``controller_options``, ``decision_ticks``, ``tolerance``,
    ``hard_limit``, ``failure_penalty``, ``randomize``, ``lookahead``, ``gain_range``,
    ``render_mode`` ("rgb_array", "human"); see :class:`contour_gym.envs.config.EnvConfig`.
    Unknown arguments raise ValueError listing the accepted ones.

    ## Version history
    v0: initial release.
"""


class CCCEnv(ContourEnv):  # noqa: D101 (the spec is assigned to __doc__)
    __doc__ = "Cross-coupled controller gains as actions (``contour_gym/CCC-v0``).\n" + _SPEC
    kind = CCC


class CCCVectorEnv(ContourVectorEnv):  # noqa: D101
    __doc__ = "Native vector version of :class:`CCCEnv` (one array program).\n" + _SPEC
    kind = CCC
