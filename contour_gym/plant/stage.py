"""A stage: a set of axes plus the contours it draws, packed into arrays for the loop kernel."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.linalg import expm

from contour_gym._validate import as_finite_array, positive
from contour_gym.plant import _kernel as K
from contour_gym.plant.friction import law_for
from contour_gym.plant.params import AxisParams


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
        delay_ticks: Computation delay of the digital drive, ticks (0 or 1): the command
            computed from sample k acts from tick k + delay_ticks (rig model; ``ideal=True``
            drops it).
        in_position: In-position band of every axis, m: a contour has ended when the axes are
            within it of the path's end point (a CNC's in-position check; a reading exactly
            on it, a whole number of encoder counts away, is within).
        in_position_speed: ... and every axis is slower than this, m/s (its reading's change
            over as many ticks as its encoder needs to tell this speed from rest:
            :func:`contour_gym.loop.build.in_position_ticks`).
        notes: Where the numbers come from (published or chosen).
    """

    name: str
    axes: tuple[AxisParams, ...]
    contours: tuple[Contour, ...]
    ts: float
    substeps: int = 1
    delay_ticks: int = 1
    in_position: float = 5e-6
    in_position_speed: float = 1e-3
    notes: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        positive(self.ts, "ts")
        if not isinstance(self.substeps, int) or self.substeps < 1:
            raise ValueError(f"substeps must be a positive int, got {self.substeps!r}")
        if self.delay_ticks not in (0, 1):
            raise ValueError(f"delay_ticks must be 0 or 1, got {self.delay_ticks!r}")
        positive(self.in_position, "in_position")
        positive(self.in_position_speed, "in_position_speed")
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

    def check_travel(self, path: Any) -> None:
        """Refuse a path that takes an axis outside its travel (:attr:`AxisParams.travel`).

        Segments whose bounding sphere lies within the travel pass at once (no evaluation,
        nothing to compile); the others are checked at 9 points each, ends included, with each
        contour's offset.

        Raises:
            ValueError: naming the axis, the position reached, the travel, and the G-code
                line of the move (for a G-code path) or the arc length.
        """
        if not any(a.travel is not None for a in self.axes) or self._spheres_inside(path):
            return
        s0 = np.asarray(path.table.s0, dtype=float)
        s = (s0[:-1, None] + np.diff(s0)[:, None] * np.linspace(0.0, 1.0, 9)).ravel()
        points = np.asarray(path.point(s)).reshape(len(s), -1)
        for j, a, offset, travel in self.limited_coordinates():
            reach = points[:, j] + offset
            out = np.flatnonzero((reach < travel[0]) | (reach > travel[1]))
            if out.size:
                self._beyond(path, a, float(reach[out[0]]), float(s[out[0]]))

    def limited_coordinates(self) -> Iterator[tuple[int, int, float, tuple[float, float]]]:
        """Every contour coordinate whose axis has a travel.

        Yields:
            ``(j, a, offset, travel)``: the contour's coordinate ``j``, its axis ``a``, the
            contour's offset along ``j`` (m) and the axis' ``(low, high)`` travel (m).
        """
        for c in self.contours:
            offset = c.offset or (0.0,) * c.dim
            for j, a in enumerate(c.axes):
                travel = self.axes[a].travel
                if travel is not None:
                    yield j, a, float(offset[j]), travel

    def _spheres_inside(self, path: Any) -> bool:
        # every segment's bounding sphere within every limited axis' travel
        bound = np.asarray(path.table.spheres, dtype=float)
        for j, _, offset, travel in self.limited_coordinates():
            low = bound[:, j] + offset - bound[:, 3]
            high = bound[:, j] + offset + bound[:, 3]
            if np.any(low < travel[0]) or np.any(high > travel[1]):
                return False
        return True

    def _beyond(self, path: Any, a: int, reach: float, s: float) -> None:
        axis = self.axes[a]
        low, high = axis.travel or (0.0, 0.0)
        what = (f"the path reaches {axis.name} = {reach * 1e3:.6g} mm, outside the machine's "
                f"{axis.name} travel [{low * 1e3:.6g}, {high * 1e3:.6g}] mm "
                f"({self.name})")
        lines = getattr(path, "segment_lines", None)
        if lines is not None:
            seg = min(int(np.searchsorted(path.table.s0, s, side="right")) - 1, len(lines) - 1)
            raise ValueError(f"G-code line {int(lines[max(seg, 0)])}: {what}")
        name = getattr(path, "name", "the path")
        raise ValueError(f"{what}, at s = {s * 1e3:.6g} mm of {name!r}")


def friction_laws(stage: Stage) -> tuple[str, ...]:
    """The distinct friction laws of a stage's axes, in slot order (sorted names).

    Raises:
        ValueError: for more than ``MAX_LAWS`` distinct laws or an unregistered model.
    """
    names = tuple(sorted({law_for(a.friction).name for a in stage.axes}))
    if len(names) > K.MAX_LAWS:
        raise ValueError(f"a stage may use at most {K.MAX_LAWS} friction laws, got {names}")
    return names


def axis_row(axis: AxisParams, law: int = 0, *, ideal: bool = False) -> np.ndarray:
    """Pack one axis into the kernel's :data:`~contour_gym.plant._kernel.AXIS` row.

    Args:
        axis: The axis.
        law: Slot of its friction law among the stage's (:func:`friction_laws`).
        ideal: Drop the rig's encoder quantisation and measurement noise.
    """
    return K.AXIS.row(
        m=axis.mass, b=axis.damping, ks=axis.stiffness, k=axis.force_constant, u_max=axis.u_max,
        tau=axis.current_tau, enc=0.0 if ideal else axis.encoder_resolution,
        noise=0.0 if ideal else axis.noise_std,
        nrip=0 if axis.ripple is None else len(axis.ripple.wavenumber),
        harm=float(axis.ripple is not None and axis.ripple.harmonic), law=law,
    )


def friction_row(axis: AxisParams) -> np.ndarray:
    """The axis' friction-law parameter row (N_FR,)."""
    return law_for(axis.friction).row(axis.friction)


def ripple_rows(axis: AxisParams) -> np.ndarray:
    """The axis' (MAX_HARMONICS, 3) ripple table (zeros without ripple)."""
    return np.zeros((K.MAX_HARMONICS, 3)) if axis.ripple is None else axis.ripple.as_array()


def disturbance_row(axis: AxisParams | None, ts: float) -> np.ndarray:
    """Pack an axis' disturbance (None: no disturbance) into the kernel row for tick ``ts``."""
    d = None if axis is None else axis.disturbance
    if d is None:
        return K.DISTURBANCE.row()
    return K.DISTURBANCE.row(
        step_t=d.step_time, step_a=d.step_amp, sin_a=d.sin_amp,
        sin_w=2.0 * math.pi * d.sin_freq, sin_ph=d.sin_phase, rnd_std=d.random_std,
        rnd_alpha=math.exp(-2.0 * math.pi * d.random_bandwidth * ts),
    )


def zoh_matrices(ax_p: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation of every axis' linear part over a substep ``h``.

    Continuous model with state (x, v, i) and inputs (u, f_ext)::

        x' = v
        v' = (K i - b v - k x + f_ext) / m
        i' = (u - i) / tau          (tau > 0; with tau = 0 the drive is u itself)

    Args:
        ax_p: Axis parameter rows, shape (..., AXIS.size).
        h: Substep, s.

    Returns:
        ``(ad, bd)`` with shapes (..., 3, 3) and (..., 3, 2).
    """
    lead = ax_p.shape[:-1]
    p = ax_p.reshape(-1, K.AXIS.size)
    n = p.shape[0]
    ax = K.AX
    m, b, k, kf, tau = (p[:, i] for i in (ax.m, ax.b, ax.ks, ax.k, ax.tau))
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
