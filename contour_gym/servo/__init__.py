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

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from contour_gym.servo import pd_robust, pid, smc, two_dof_pid  # noqa: F401 (registration)
from contour_gym.servo.base import (
    CONTROLLERS,
    AxisController,
    loop_bandwidth,
    register_controller,
)
from contour_gym.servo.compensation import OPTIONS as FRICTION_OPTIONS
from contour_gym.servo.compensation import compensation_rows
from contour_gym.servo.gains import PIDGains
from contour_gym.servo.pid import pid_params
from contour_gym.servo.smc import disturbance_bound, smc_defaults
from contour_gym.servo.two_dof_pid import NAMES as TWO_DOF_NAMES
from contour_gym.servo.two_dof_pid import params_of as two_dof_pid_params
from contour_gym.servo.two_dof_pid import values_of as two_dof_pid_values

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage


def controller_options(name: str) -> tuple[str, ...]:
    """The options controller ``name`` accepts (its own, then the friction compensation's)."""
    return (*CONTROLLERS.get(name).options(), *FRICTION_OPTIONS)


def build_controller(
    name: str, stage: Stage, gains: Sequence[PIDGains], batch: int, **options: object
) -> tuple[AxisController, np.ndarray, np.ndarray]:
    """The controller ``name`` with its parameter rows and its compensation rows.

    Args:
        name: A key of :data:`CONTROLLERS`.
        stage: The machine (model-based controllers read its nominal axis parameters).
        gains: The preset's per-axis PID gains (the baseline other designs start from).
        batch: Batch size.
        **options: Controller-specific settings (:func:`controller_options`).

    Returns:
        ``(controller, params (batch, A, P), compensation (batch, A, N_COMP))``.

    Raises:
        ValueError: for an unknown name or option, or a bad option value.
    """
    ctrl = CONTROLLERS.get(name)
    accepted = controller_options(name)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(
            f"unknown option(s) {', '.join(unknown)} for {name!r}; accepted: {', '.join(accepted)}"
        )
    if len(gains) != stage.n_axes:
        raise ValueError(f"need {stage.n_axes} axis gains, got {len(gains)}")
    own = {k: v for k, v in options.items() if k not in FRICTION_OPTIONS}
    params = np.asarray(ctrl.build(stage, tuple(gains), batch, **own), dtype=np.float64)
    want = (batch, stage.n_axes, ctrl.params.size)
    if params.shape != want or not np.all(np.isfinite(params)):
        raise ValueError(f"controller {name!r} built invalid parameters of shape {params.shape}")
    comp = compensation_rows(
        stage, batch, options.get("friction"), options.get("friction_model")  # type: ignore[arg-type]
    )
    return ctrl, params, comp


from contour_gym.servo.bank import AxisControllers  # noqa: E402 (uses build_controller)

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
