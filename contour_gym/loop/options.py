"""The servo loop's settings beyond the stage, path, gains and interpolator."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

DEFAULT_SETTLE = 1.0  # s the machine may take to get in position after the reference ends


@dataclass(frozen=True)
class LoopOptions:
    """The loop's settings beyond the stage, path, gains and interpolator (see ServoLoop).

    Attributes:
        axis_controller: Name in :data:`contour_gym.servo.CONTROLLERS`.
        controller_options: Its options.
        estimator: Name in :data:`contour_gym.contour.ESTIMATORS`.
        estimator_options: Its options.
        ccc_law: Name in :data:`contour_gym.ccc.CCC_LAWS`.
        ccc_law_params: The law's parameters beyond kp, ki, kd; those not given take the
            law's schema defaults here (:meth:`contour_gym.api.Scenario.loop` gives its
            machine's: :func:`contour_gym.api.machine_law_params`).
        ccc_injection: ``"control"`` or ``"reference"`` (:mod:`contour_gym.ccc`).
        ideal: Drop the rig's encoder, noise and computation delay.
        path_control: ``"none"``, ``"G61"``, ``"G61.1"``, ``"G64"`` or None (the path's own).
        path_tolerance: G64 tolerance, m (None: the path's own or the default).
        use_program_feeds: Run a G-code part at its own F words.
        settle_time: Time allowed to get in position after the reference ends, s.
        sample_period: Sampling of P_e and P_eps, s (None: every tick).
    """

    axis_controller: str = "pid"
    controller_options: dict[str, Any] | None = None
    estimator: str = "ground_truth"
    estimator_options: dict[str, Any] | None = None
    ccc_law: str = "pid"
    ccc_law_params: dict[str, Any] | None = None
    ccc_injection: str = "control"
    ideal: bool = False
    path_control: str | None = None
    path_tolerance: float | None = None
    use_program_feeds: bool = True
    settle_time: float = DEFAULT_SETTLE
    sample_period: float | None = None
