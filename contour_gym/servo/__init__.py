"""Per-axis servo controllers, batched and selected by name.

=================  ===========================================================================
``pid``            PID with velocity feed-forward (the presets' baseline).
``two_dof_pid``    paper 003's 2-DOF PID (eqs. 26-35): main PID plus a feed-forward PD on the
                   command with set-point weights ``alpha``, ``beta``.
``smc_dob``        paper 001's sliding-mode control with boundary layer and disturbance
                   observer (small switching gain).
``smc``            the same law without observer and with the large switching gain 001 needs.
``pd_robust``      paper 001's comparison controller: PD plus nominal-model feed-forward.
=================  ===========================================================================

Every controller takes ``friction="feedforward"`` (paper 002 section 3: a LuGre model on the
command velocity), ``"feedback"`` (the traditional compensation: the same model on the
measured velocity) or ``"feedback_static"`` (002 eq. 3 on the measured velocity), with
``friction_model=`` the identified parameters (:func:`agents.identify.identify_friction`).

Select a controller with ``ServoLoop(..., axis_controller=name, controller_options={...})``
(also ``make_scenario(...).loop(...)`` and ``simulate(...)``). An optimiser tuning 003's
five numbers per axis (Kp, TI, TD, alpha, beta) maps its population ``x`` of shape
``(B, 5 n_axes)`` to rows with :func:`two_dof_pid_params`::

    loop = scenario.loop(axis_controller="two_dof_pid", batch_size=B)
    loop.set_controller_params(two_dof_pid_params(x.reshape(B, -1, 5), base=loop.ctrl_p))

:class:`AxisControllers` runs the same compiled controllers outside the loop. Defaults and
how they are derived: :mod:`contour_gym.servo.builders`; the laws and what was reconstructed
from the papers: :mod:`contour_gym.servo._kernel`.
"""

from __future__ import annotations

from contour_gym.servo.bank import AxisControllers
from contour_gym.servo.builders import (
    CONTROLLERS,
    TWO_DOF_NAMES,
    build_controller,
    controller_options,
    disturbance_bound,
    loop_bandwidth,
    pid_params,
    smc_defaults,
    two_dof_pid_params,
    two_dof_pid_values,
)
from contour_gym.servo.gains import PIDGains

__all__ = [
    "CONTROLLERS",
    "TWO_DOF_NAMES",
    "AxisControllers",
    "PIDGains",
    "build_controller",
    "controller_options",
    "disturbance_bound",
    "loop_bandwidth",
    "pid_params",
    "smc_defaults",
    "two_dof_pid_params",
    "two_dof_pid_values",
]
