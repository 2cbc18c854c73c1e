"""A stage: a set of axes plus the contours it draws, packed into arrays for the loop kernel."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import expm

from contour_gym._validate import as_finite_array, positive
from contour_gym.plant import _kernel as K
from contour_gym.plant.params import (
    AxisParams,
    CoulombFriction,
    LuGreFriction,
    StribeckFriction,
)


@dataclass(frozen=True)
class Contour:
    """One contour drawn by a stage: which axis moves along each path coordinate.

    Attributes:
        axes: Axis index for each path coordinate (x, y[, z]).
        offset: Offset added to the path point in each coordinate, m (003's y1/y2 offsets).
    """

    axes: tuple[int, ...]
    offset: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        if len(self.axes) not in (2, 3) or len(set(self.axes)) != len(self.axes):
            raise ValueError(f"contour axes must be 2 or 3 distinct indices, got {self.axes!r}")
        if self.offset:
            as_finite_array(self.offset, "contour offset", shape=(len(self.axes),))

    @property
    def dim(self) -> int:
        """Number of path coordinates the contour uses."""
        return len(self.axes)


@dataclass(frozen=True)
class Stage:
    """A machine: its axes, the contours they draw, and the servo sampling.

    Attributes:
        name: Stage name.
        axes: The axes.
        contours: The contours (one for X-Y or X-Y-Z; two for 003's X-Y-Y gantry).
        ts: Servo sampling time, s.
        substeps: Plant integration substeps per tick (for stiff friction).
        notes: Where the numbers come from (published or chosen).
    """

    name: str
    axes: tuple[AxisParams, ...]
    contours: tuple[Contour, ...]
    ts: float
    substeps: int = 1
    notes: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        positive(self.ts, "ts")
        if not isinstance(self.substeps, int) or self.substeps < 1:
            raise ValueError(f"substeps must be a positive int, got {self.substeps!r}")
        if not self.axes or not self.contours:
            raise ValueError("a stage needs at least one axis and one contour")
        n = len(self.axes)
        for c in self.contours:
            if max(c.axes) >= n or min(c.axes) < 0:
                raise ValueError(f"contour axes {c.axes!r} out of range for {n} axes")

    @property
    def n_axes(self) -> int:
        """Number of axes."""
        return len(self.axes)

    @property
    def dim(self) -> int:
        """Path dimension every contour of this stage draws."""
        return self.contours[0].dim

    @property
    def is_random(self) -> bool:
        """Whether any axis draws random numbers."""
        return any(a.is_random for a in self.axes)


def axis_row(axis: AxisParams) -> np.ndarray:
    """Pack one axis into the kernel's (N_AX,) parameter row."""
    p = np.zeros(K.N_AX)
    p[K.AX_M], p[K.AX_B], p[K.AX_KS] = axis.mass, axis.damping, axis.stiffness
    p[K.AX_K], p[K.AX_UMAX], p[K.AX_TAU] = axis.force_constant, axis.u_max, axis.current_tau
    p[K.AX_ENC], p[K.AX_NOISE] = axis.encoder_resolution, axis.noise_std
    p[K.AX_DELTA], p[K.AX_VS] = 2.0, 1.0
    fr = axis.friction
    if isinstance(fr, CoulombFriction):
        p[K.AX_FKIND], p[K.AX_FC], p[K.AX_FS] = K.FRIC_COULOMB, fr.fc, fr.static
    elif isinstance(fr, StribeckFriction):
        p[K.AX_FKIND] = K.FRIC_STRIBECK
        p[K.AX_FC], p[K.AX_FS], p[K.AX_VS] = fr.fc, fr.fs, fr.vs
        p[K.AX_DELTA], p[K.AX_FV] = fr.delta, fr.fv
    elif isinstance(fr, LuGreFriction):
        p[K.AX_FKIND] = K.FRIC_LUGRE
        p[K.AX_FC], p[K.AX_FS], p[K.AX_VS] = fr.fc, fr.fs, fr.vs
        p[K.AX_S0], p[K.AX_S1], p[K.AX_S2] = fr.sigma0, fr.sigma1, fr.sigma2
    p[K.AX_NRIP] = 0 if axis.ripple is None else len(axis.ripple.wavenumber)
    return p


def disturbance_row(axis: AxisParams, ts: float) -> np.ndarray:
    """Pack one axis' disturbance into the kernel's (N_DS,) row for sampling time ``ts``."""
    out = np.zeros(K.N_DS)
    d = axis.disturbance
    out[K.DS_STEP_T] = math.inf
    if d is None:
        return out
    out[K.DS_STEP_T], out[K.DS_STEP_A] = d.step_time, d.step_amp
    out[K.DS_SIN_A], out[K.DS_SIN_W], out[K.DS_SIN_PH] = (
        d.sin_amp,
        2.0 * math.pi * d.sin_freq,
        d.sin_phase,
    )
    out[K.DS_RND_STD] = d.random_std
    out[K.DS_RND_ALPHA] = math.exp(-2.0 * math.pi * d.random_bandwidth * ts)
    return out


def zoh_matrices(ax_p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of every axis' linear part over a substep ``h``.

    Continuous model with state (x, v, i) and inputs (u, f_ext)::

        x' = v
        v' = (K i - b v - k x + f_ext) / m
        i' = (u - i) / tau          (tau > 0; with tau = 0 the drive is u itself)

    Args:
        ax_p: Axis parameter rows, shape (..., N_AX).
        h: Substep, s.

    Returns:
        ``(ad, bd)`` with shapes (..., 3, 3) and (..., 3, 2).
    """
    lead = ax_p.shape[:-1]
    p = ax_p.reshape(-1, K.N_AX)
    n = p.shape[0]
    m, b, k, kf, tau = (p[:, i] for i in (K.AX_M, K.AX_B, K.AX_KS, K.AX_K, K.AX_TAU))
    big = np.zeros((n, 5, 5))
    big[:, 0, 1] = 1.0
    big[:, 1, 0], big[:, 1, 1] = -k / m, -b / m
    big[:, 1, 4] = 1.0 / m
    lag = tau > 0
    big[lag, 1, 2] = kf[lag] / m[lag]
    big[lag, 2, 2] = -1.0 / tau[lag]
    big[lag, 2, 3] = 1.0 / tau[lag]
    big[~lag, 1, 3] = kf[~lag] / m[~lag]
    disc = expm(big * h)
    ad = disc[:, :3, :3].reshape(*lead, 3, 3)
    bd = disc[:, :3, 3:].reshape(*lead, 3, 2)
    return np.ascontiguousarray(ad), np.ascontiguousarray(bd)
