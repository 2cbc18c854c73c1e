"""Per-axis servo controllers (PID now; the papers' SMC-DOB, 2-DOF PID and robust PD later)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from contour_gym._validate import as_finite_array, choice
from contour_gym.servo import _kernel as K

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage

__all__ = ["CONTROLLERS", "PIDGains", "build_controller", "pid_params"]


@dataclass(frozen=True)
class PIDGains:
    """Gains of one axis' position PID, in control units per metre.

    Attributes:
        kp: Proportional gain (u per m).
        ki: Integral gain (u per m s).
        kd: Derivative gain (u s per m).
        kff: Velocity feed-forward gain (u s per m); 0 in the papers' loops.
    """

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    kff: float = 0.0

    def __post_init__(self) -> None:
        vals = as_finite_array([self.kp, self.ki, self.kd, self.kff], "PID gains")
        if vals[0] <= 0 or np.any(vals[1:3] < 0):
            raise ValueError(f"PID gains need kp > 0 and ki, kd >= 0, got {self!r}")


def pid_params(gains: tuple[PIDGains, ...], batch: int) -> np.ndarray:
    """Kernel parameter rows (batch, n_axes, N_CP) for the given per-axis gains."""
    row = np.zeros((len(gains), K.N_CP))
    for a, g in enumerate(gains):
        row[a, [K.CP_KP, K.CP_KI, K.CP_KD, K.CP_KFF]] = g.kp, g.ki, g.kd, g.kff
    return np.repeat(row[None], batch, axis=0)


def _build_pid(stage: Stage, gains: Sequence[PIDGains], batch: int, **options: object) -> np.ndarray:
    if options:
        raise ValueError(f"pid takes no options, got {sorted(options)}")
    return pid_params(tuple(gains), batch)


# name -> (kernel kind, builder(stage, default PID gains, batch, **options) -> (B, A, N_CP))
CONTROLLERS: dict[str, tuple[int, Callable[..., np.ndarray]]] = {
    "pid": (K.CTRL_PID, _build_pid),
}


def build_controller(
    name: str, stage: Stage, gains: Sequence[PIDGains], batch: int, **options: object
) -> tuple[int, np.ndarray]:
    """Kernel kind and parameter rows (batch, n_axes, N_CP) of the axis controller ``name``.

    Args:
        name: A key of :data:`CONTROLLERS`.
        stage: The machine (model-based controllers read its nominal axis parameters).
        gains: The preset's per-axis PID gains (the baseline other designs start from).
        batch: Batch size.
        **options: Controller-specific settings.

    Returns:
        ``(kind, params)``.

    Raises:
        ValueError: for an unknown name or bad options.
    """
    kind, builder = CONTROLLERS[choice(name, "axis_controller", CONTROLLERS)]
    params = builder(stage, gains, batch, **options)
    if params.shape != (batch, stage.n_axes, K.N_CP) or not np.all(np.isfinite(params)):
        raise ValueError(f"controller {name!r} built invalid parameters of shape {params.shape}")
    return kind, params
