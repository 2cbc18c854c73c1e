"""Per-axis servo controllers, batched and selected by name (:data:`CONTROLLERS`).

| name | controller |
|---|---|
| ``pid`` | PID with velocity feed-forward (the presets' baseline). |
| ``two_dof_pid`` | 003's 2-DOF PID (eqs. 26-35): PID plus a feed-forward PD on the command. |
| ``smc_dob`` | 001's sliding-mode control, boundary layer, disturbance observer. |
| ``smc`` | the same law without observer and with the large switching gain 001 needs. |
| ``pd_robust`` | paper 001's comparison controller: PD plus nominal-model feed-forward. |

``two_dof_pid`` weighs the command by the set-point weights ``alpha``, ``beta``; ``smc_dob``'s
observer lets its switching gain be small.

Each is one module (:mod:`.pid`, :mod:`.two_dof_pid`, :mod:`.smc`, :mod:`.pd_robust`) with
its parameter and state schemas, its compiled law and one :func:`register_controller` call;
add yours the same way (:mod:`contour_gym.servo.base`). Every controller takes
``friction="feedforward"`` / ``"feedback"`` / ``"feedback_static"`` with ``friction_model=``
(paper 002's compensation, :mod:`.compensation`).

Select a controller with ``ServoLoop(..., axis_controller=name, controller_options={...})``
(also ``make_scenario(...).loop(...)`` and ``simulate(...)``). An optimiser tuning 003's
five numbers per axis maps its population ``x`` of shape ``(B, 5 n_axes)`` to rows with
:func:`two_dof_pid_params`::

    loop = scenario.loop(axis_controller="two_dof_pid", batch_size=B)
    loop.set_controller_params(two_dof_pid_params(x.reshape(B, -1, 5)))

:class:`AxisControllers` runs the same compiled controllers outside the loop.
"""

from __future__ import annotations

from contour_gym.servo import pd_robust, pid, smc, two_dof_pid  # noqa: F401 (registration)
from contour_gym.servo.bank import AxisControllers
from contour_gym.servo.base import (
    CONTROLLERS,
    AxisController,
    loop_bandwidth,
    register_controller,
)
from contour_gym.servo.build import FRICTION_OPTIONS, build_controller, controller_options
from contour_gym.servo.gains import PIDGains
from contour_gym.servo.pid import pid_params
from contour_gym.servo.smc import disturbance_bound, smc_defaults
from contour_gym.servo.two_dof_pid import NAMES as TWO_DOF_NAMES
from contour_gym.servo.two_dof_pid import params_of as two_dof_pid_params
from contour_gym.servo.two_dof_pid import values_of as two_dof_pid_values

__all__ = [
    "CONTROLLERS",
    "FRICTION_OPTIONS",
    "TWO_DOF_NAMES",
    "AxisController",
    "AxisControllers",
    "PIDGains",
    "build_controller",
    "controller_options",
    "disturbance_bound",
    "loop_bandwidth",
    "pid_params",
    "register_controller",
    "smc_defaults",
    "two_dof_pid_params",
    "two_dof_pid_values",
]
