"""Build a registered axis controller: its parameter rows and its friction-compensation rows."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from contour_gym.servo.base import CONTROLLERS, AxisController
from contour_gym.servo.compensation import OPTIONS as FRICTION_OPTIONS
from contour_gym.servo.compensation import compensation_rows
from contour_gym.servo.gains import PIDGains

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
