"""Frozen parameter dataclasses of one axis: dynamics, force ripple, disturbances, sensing.

Every axis obeys (DESIGN.md; issue 2 item 5)::

    m x'' = K i - b x' - k x - F_friction(x', z) - F_ripple(x) + d(t)
    tau i' = u - i            (optional first-order current loop; tau = 0 means i = u)

with ``u`` the controller output (A or V, saturated at ``u_max``), ``x`` in metres. All
quantities are SI. Rotary axes (a motor on a ball screw) are converted to these linear
equivalents by :meth:`AxisParams.from_rotary`. Friction models live with their laws in
:mod:`contour_gym.plant.friction` (re-exported here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from contour_gym._validate import as_finite_array, finite, non_negative, positive
from contour_gym.plant._kernel import MAX_HARMONICS
from contour_gym.plant.friction import CoulombFriction, LuGreFriction, StribeckFriction

Friction = Any  # a registered law's model (contour_gym.plant.friction), or None


@dataclass(frozen=True)
class Ripple:
    """Position-periodic force ripple, paper 003 eqs. 5-6.

    ``F = sum_j a_j sin(w_j x) + b_j cos(w_j x)``.

    Attributes:
        sin_amp: ``a_j``, N (up to 6 harmonics in 003).
        cos_amp: ``b_j``, N.
        wavenumber: ``w_j``, rad/m.
    """

    sin_amp: tuple[float, ...]
    cos_amp: tuple[float, ...]
    wavenumber: tuple[float, ...]

    def __post_init__(self) -> None:
        n = len(self.wavenumber)
        if not 1 <= n <= MAX_HARMONICS:
            raise ValueError(f"ripple needs 1..{MAX_HARMONICS} harmonics, got {n}")
        for name in ("sin_amp", "cos_amp", "wavenumber"):
            as_finite_array(getattr(self, name), name, shape=(n,))

    @property
    def harmonic(self) -> bool:
        """Whether the wavenumbers are the harmonics ``j w_1`` (to 1e-12 relative).

        003's eqs. 5-6 name six frequencies ``w_j`` without relating them; harmonics of one
        magnet pole pitch are this library's choice for the ``xyy_gantry`` preset. For
        harmonics the kernel evaluates the series from one sine and cosine (a recurrence).
        """
        w = np.asarray(self.wavenumber, dtype=np.float64)
        j = np.arange(1, len(w) + 1)
        return bool(w[0] != 0.0 and np.all(np.abs(w - j * w[0]) <= 1e-12 * np.abs(j * w[0])))

    @property
    def amplitude(self) -> float:
        """The largest harmonic's amplitude ``max_j hypot(a_j, b_j)``, N (the ripple's level)."""
        return float(np.max(np.hypot(self.sin_amp, self.cos_amp)))

    def scaled(self, factor: float) -> dict[str, tuple[float, ...]]:
        """This ripple with every amplitude times ``factor``, as a machine file's fields."""
        return {"sin_amp": tuple(float(a * factor) for a in self.sin_amp),
                "cos_amp": tuple(float(b * factor) for b in self.cos_amp),
                "wavenumber": tuple(float(w) for w in self.wavenumber)}

    def as_array(self) -> np.ndarray:
        """Return a (MAX_HARMONICS, 3) array of (a_j, b_j, w_j), zero-padded."""
        out = np.zeros((MAX_HARMONICS, 3))
        n = len(self.wavenumber)
        out[:n, 0], out[:n, 1], out[:n, 2] = self.sin_amp, self.cos_amp, self.wavenumber
        return out


@dataclass(frozen=True)
class Disturbance:
    """External force ``d(t)`` on one axis: step + sinusoid + band-limited random, N.

    The random part is white Gaussian noise through a first-order low-pass filter with
    cut-off ``random_bandwidth`` whose stationary standard deviation is ``random_std``; it is
    drawn from the generator handed to the loop, so the same seed gives the same force.

    Attributes:
        step_time: Time of the step, s.
        step_amp: Step amplitude, N.
        sin_amp: Sinusoid amplitude, N.
        sin_freq: Sinusoid frequency, Hz.
        sin_phase: Sinusoid phase, rad.
        random_std: Stationary standard deviation of the random part, N.
        random_bandwidth: Cut-off of the random part, Hz.
    """

    step_time: float = 0.0
    step_amp: float = 0.0
    sin_amp: float = 0.0
    sin_freq: float = 0.0
    sin_phase: float = 0.0
    random_std: float = 0.0
    random_bandwidth: float = 10.0

    def __post_init__(self) -> None:
        non_negative(self.step_time, "step_time")
        finite(self.step_amp, "step_amp")
        finite(self.sin_amp, "sin_amp")
        non_negative(self.sin_freq, "sin_freq")
        finite(self.sin_phase, "sin_phase")
        non_negative(self.random_std, "random_std")
        positive(self.random_bandwidth, "random_bandwidth")

    @property
    def is_random(self) -> bool:
        """Whether this disturbance draws random numbers."""
        return self.random_std > 0.0


@dataclass(frozen=True)
class AxisParams:
    """One linear axis (linear equivalents for rotary drives), SI units.

    Attributes:
        name: Axis name ("x", "y1", ...).
        mass: Moving mass m, kg (> 0).
        damping: Viscous damping b, N s/m (>= 0).
        stiffness: Spring stiffness k, N/m (>= 0).
        force_constant: K, N per unit of control signal (N/A or N/V), > 0.
        u_max: Actuator saturation |u| <= u_max.
        current_tau: Time constant of the first-order current loop, s; 0 = ideal.
        friction: Friction model or None.
        ripple: Force ripple or None.
        disturbance: External disturbance or None.
        encoder_resolution: Position quantisation step of the encoder, m; 0 = none (the rig
            model; ``ideal=True`` drops it).
        noise_std: Measurement noise standard deviation, m (rig model; dropped by ``ideal``).
        travel: ``(low, high)`` machine positions the axis can reach, m (its soft limits); a
            path outside them is refused before a run starts. None: unlimited.
    """

    name: str
    mass: float
    damping: float
    force_constant: float
    u_max: float
    stiffness: float = 0.0
    current_tau: float = 0.0
    friction: Friction | None = None
    ripple: Ripple | None = None
    disturbance: Disturbance | None = None
    encoder_resolution: float = 0.0
    noise_std: float = 0.0
    travel: tuple[float, float] | None = None
    notes: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        positive(self.mass, f"{self.name}.mass")
        non_negative(self.damping, f"{self.name}.damping")
        non_negative(self.stiffness, f"{self.name}.stiffness")
        positive(self.force_constant, f"{self.name}.force_constant")
        positive(self.u_max, f"{self.name}.u_max")
        non_negative(self.current_tau, f"{self.name}.current_tau")
        non_negative(self.encoder_resolution, f"{self.name}.encoder_resolution")
        non_negative(self.noise_std, f"{self.name}.noise_std")
        if self.travel is not None:
            ends = as_finite_array(self.travel, f"{self.name}.travel", ndim=1)
            if ends.shape != (2,) or not ends[0] < ends[1]:
                raise ValueError(f"{self.name}.travel must be (low, high) with low < high, m; "
                                 f"got {self.travel!r}")
            object.__setattr__(self, "travel", (float(ends[0]), float(ends[1])))

    @property
    def is_random(self) -> bool:
        """Whether the axis draws random numbers (measurement noise or random disturbance)."""
        return self.noise_std > 0.0 or (self.disturbance is not None and self.disturbance.is_random)

    @classmethod
    def from_rotary(
        cls,
        name: str,
        *,
        inertia: float,
        viscous: float,
        torque_constant: float,
        lead: float,
        coulomb_torque: float = 0.0,
        **kwargs: object,
    ) -> AxisParams:
        """Build the linear equivalent of a rotary motor driving a ball screw.

        With ``n = 2 pi / lead`` (rad per metre): ``m = J n^2``, ``b = B n^2``,
        ``K = Kt n`` and a Coulomb torque ``Tc`` becomes the force ``Tc n``.

        Args:
            name: Axis name.
            inertia: Rotor plus reflected load inertia J, kg m^2.
            viscous: Viscous friction B, N m s/rad.
            torque_constant: Kt, N m/A.
            lead: Ball-screw lead, m per revolution.
            coulomb_torque: Coulomb friction torque, N m (0 = none).
            **kwargs: Remaining :class:`AxisParams` fields (u_max, current_tau, ...).

        Returns:
            The equivalent linear axis.
        """
        n = 2.0 * math.pi / positive(lead, f"{name}.lead")
        friction = CoulombFriction(coulomb_torque * n) if coulomb_torque > 0 else None
        kwargs.setdefault("friction", friction)
        return cls(
            name=name,
            mass=positive(inertia, f"{name}.inertia") * n * n,
            damping=non_negative(viscous, f"{name}.viscous") * n * n,
            force_constant=positive(torque_constant, f"{name}.torque_constant") * n,
            **kwargs,  # type: ignore[arg-type]
        )


__all__ = [
    "MAX_HARMONICS",
    "AxisParams",
    "CoulombFriction",
    "Disturbance",
    "Friction",
    "LuGreFriction",
    "Ripple",
    "StribeckFriction",
]
