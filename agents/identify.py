"""LuGre friction identification from a friction-velocity sweep (paper 002 section 2.2).

The experiment (:func:`friction_sweep`): one axis of a preset is driven by a velocity loop
along :func:`sweep_profile`: two slow small oscillations (pre-sliding: the bristles deflect, so
friction acts like the spring ``sigma0`` and damper ``sigma1 + sigma2``), then constant-velocity
plateaus at five speeds around ``v_s``, first all forwards, then all backwards (steady sliding:
friction is the Stribeck curve ``g(v) + sigma2 v`` of 002 eq. 3, which fixes ``v_s`` and
``F_s``). Going up a staircase of speeds in one direction, rather than reversing between
plateaus, keeps the large ``sigma1 dz/dt`` transients of a reversal from swamping the
Stribeck curve in eq. 4 (the documentation's "Measurements and design notes" says by how
much). The
plant is advanced by the LuGre law's own substep (:func:`contour_gym.plant.friction.lugre.substep`)
at the servo tick with one substep (the LuGre rates stay below 40 1/s, well resolved) and the
friction of each step is
recovered exactly from the mechanics, ``F = K u - b dx/h - m dv/h`` (the ZOH step holds the
friction over the step). Measured: the velocity at the start of each step and that friction;
``noise`` adds Gaussian noise of ``noise`` times each signal's RMS to both.

The model (:func:`lugre_response`): the LuGre model of 002 eq. 1 simulated over the measured
velocity, with the Coulomb force ``F_c`` and viscous ``sigma2`` known (002 identifies only
``sigma0, sigma1, v_s, F_s``, table 1). The fitness is 002 eq. 4, the integrated squared
difference between measured and modelled friction, sampled and divided by the integrated
squared measured friction (so it is dimensionless and 0 at a perfect fit).

Methods (:data:`METHODS`): the improved fruit-fly optimiser of 002 (eqs. 5-11), the standard
FOA, differential evolution and CMA-ES, all through :func:`agents.optim.minimize`, and
``scipy.optimize.least_squares`` (trust-region reflective, from the box centre) on the residual
vector.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from agents.optim import minimize
from contour_gym.params import as_finite_array, choice, non_negative, positive
from contour_gym.plant import AX, ST, STATE
from contour_gym.plant.friction import lugre
from contour_gym.plant.friction.lugre import LuGreFriction
from contour_gym.plant.stage import axis_row, friction_row, zoh_matrices
from contour_gym.presets import get_preset

if TYPE_CHECKING:
    from contour_gym.plant.params import AxisParams

Array = NDArray[np.float64]

N_STATE = STATE.size  # numba reads a module constant, not the schema object
PARAM_NAMES = ("sigma0", "sigma1", "vs", "fs")
# search box: about a factor 3 either side of 002's design values (fs above the known F_c)
DEFAULT_BOUNDS = ((150.0, 1500.0), (100.0, 900.0), (0.15, 1.5), (20.0, 90.0))
METHODS = ("improved_foa", "foa", "least_squares", "de", "cma")
# the sweep: pre-sliding oscillations (displacement amplitude m, frequency Hz, periods), then
# plateaus at these speeds (m/s), each PLATEAU_DISTANCE long, ramps at SWEEP_ACCEL
PRESLIDING = ((0.01, 0.5, 1), (0.003, 2.0, 2))
PLATEAUS = (0.15, 0.3, 0.5, 0.75, 1.0)
PLATEAU_DISTANCE = 0.15
SWEEP_ACCEL = 5.0


@dataclass(frozen=True)
class FrictionData:
    """A measured friction-velocity record.

    Attributes:
        velocity: (T,) measured velocity at the start of each step, m/s.
        force: (T,) measured friction over each step, N.
        h: Step, s.
        truth: The friction the axis really has (for reporting errors), or None.
        noise: Relative measurement noise the record was made with.
    """

    velocity: Array
    force: Array
    h: float
    truth: LuGreFriction | None = None
    noise: float = 0.0

    def __post_init__(self) -> None:
        v = as_finite_array(self.velocity, "velocity", ndim=1)
        f = as_finite_array(self.force, "force", ndim=1)
        if v.shape != f.shape or v.size < 2:
            raise ValueError(
                f"velocity and force need the same length >= 2, got {v.shape}, {f.shape}"
            )
        object.__setattr__(self, "velocity", np.ascontiguousarray(v))
        object.__setattr__(self, "force", np.ascontiguousarray(f))
        object.__setattr__(self, "h", positive(self.h, "h"))


def sweep_profile(h: float) -> tuple[Array, Array]:
    """Reference velocity and acceleration of the identification sweep, step ``h``.

    :data:`PRESLIDING` oscillations, then the :data:`PLATEAUS` forwards and backwards (module
    docstring), ramps at :data:`SWEEP_ACCEL`; about 8 s.
    """
    parts = []
    for amp, freq, periods in PRESLIDING:
        w = 2.0 * math.pi * freq
        parts.append(amp * w * np.sin(w * h * np.arange(int(round(periods / freq / h)))))
    current = 0.0
    for target in (*PLATEAUS, *(-s for s in PLATEAUS), 0.0):
        ramp = int(round(abs(target - current) / SWEEP_ACCEL / h))
        parts.append(np.linspace(current, target, ramp, endpoint=False))
        if target != 0.0:
            parts.append(np.full(int(round(PLATEAU_DISTANCE / abs(target) / h)), target))
        current = target
    vel = np.concatenate(parts)
    return vel, np.gradient(vel, h)


@numba.njit(cache=True)
def _drive(p, fr, ad, bd, v_ref, a_ref, h, kv, ki, x, v, u):
    # velocity PI with inverse-model feed-forward; friction is what the loop fights. One-row
    # tables (the plant kernel's layout); the plant is the LuGre law's own substep.
    st = np.zeros((1, N_STATE))
    m, b, kf, u_max = p[0, AX.m], p[0, AX.b], p[0, AX.k], p[0, AX.u_max]
    integ = 0.0
    for k in range(v_ref.shape[0]):
        x[k], v[k] = st[0, ST.x], st[0, ST.v]
        err = v_ref[k] - st[0, ST.v]
        integ += err * h
        uk = (m * a_ref[k] + b * v_ref[k]) / kf + kv * err + ki * integ
        u[k] = min(max(uk, -u_max), u_max)
        lugre.substep(p, fr, ad, bd, st, 0, u[k], 0.0, h)
        if p[0, AX.tau] == 0.0:
            st[0, ST.i] = u[k]
    x[-1], v[-1] = st[0, ST.x], st[0, ST.v]


def friction_sweep(
    preset: str = "lugre_linear_motor",
    axis: int = 0,
    *,
    noise: float = 0.0,
    seed: int | np.random.Generator | None = None,
    bandwidth: float = 200.0,
) -> FrictionData:
    """Simulate the friction-velocity sweep of one axis and record what a test bench measures.

    Args:
        preset: Preset name; the axis must have LuGre friction.
        axis: Axis index.
        noise: Measurement noise as a fraction of each signal's RMS (0.01 = 1 %).
        seed: Int or Generator for the noise (required when ``noise > 0``).
        bandwidth: Velocity-loop bandwidth, rad/s (PI gains ``m w / K`` and ``m w^2 / (4 K)``).

    Returns:
        The record, with the axis' true friction as ``truth``.

    Raises:
        ValueError: for an axis without LuGre friction, a negative noise or a missing seed.
    """
    stage = get_preset(preset).stage
    if not 0 <= axis < stage.n_axes:
        raise ValueError(f"axis must be in [0, {stage.n_axes}), got {axis!r}")
    ax: AxisParams = replace(stage.axes[axis], disturbance=None, ripple=None)
    if not isinstance(ax.friction, LuGreFriction):
        raise ValueError(f"axis {ax.name!r} of {preset!r} has no LuGre friction")
    if non_negative(noise, "noise") > 0 and seed is None:
        raise ValueError("a noisy sweep needs a seed")
    h = stage.ts
    p = axis_row(ax, ideal=True)
    ad, bd = zoh_matrices(p[None], h)
    v_ref, a_ref = sweep_profile(h)
    n = v_ref.size
    x, v, u = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n)
    w = positive(bandwidth, "bandwidth")
    kv, ki = ax.mass * w / ax.force_constant, ax.mass * w * w / (4.0 * ax.force_constant)
    _drive(p[None], friction_row(ax)[None], ad, bd, v_ref, a_ref, h, kv, ki, x, v, u)
    force = ax.force_constant * u - ax.damping * np.diff(x) / h - ax.mass * np.diff(v) / h
    vel = v[:-1]
    if noise > 0:
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        vel = vel + noise * np.sqrt(np.mean(vel**2)) * rng.standard_normal(n)
        force = force + noise * np.sqrt(np.mean(force**2)) * rng.standard_normal(n)
    return FrictionData(vel, force, h, ax.friction, float(noise))


def with_params(known: LuGreFriction, theta: ArrayLike) -> LuGreFriction:
    """``known`` with ``(sigma0, sigma1, vs, fs)`` replaced by ``theta``."""
    s0, s1, vs, fs = (float(x) for x in as_finite_array(theta, "theta", shape=(4,)))
    return replace(known, sigma0=s0, sigma1=s1, vs=vs, fs=fs)


def _thetas(known: LuGreFriction, points: Array) -> Array:
    # identified (sigma0, sigma1, vs, fs) rows -> full LuGre rows with the known sigma2, fc
    c = lugre.C
    out = np.empty((points.shape[0], lugre.PARAMS.size))
    out[:, c.sigma0], out[:, c.sigma1] = points[:, 0], points[:, 1]
    out[:, c.vs], out[:, c.fs] = points[:, 2], points[:, 3]
    out[:, c.sigma2], out[:, c.fc] = known.sigma2, known.fc
    return out


def lugre_response(params: LuGreFriction, velocity: ArrayLike, h: float) -> Array:
    """Friction of the LuGre model ``params`` over a velocity record (bristles start at rest).

    Args:
        params: Model parameters.
        velocity: (T,) velocity held over each step, m/s.
        h: Step, s.

    Returns:
        (T,) friction, N.
    """
    v = as_finite_array(velocity, "velocity", ndim=1)
    out = np.empty_like(v)
    lugre.lugre_response(params.as_array(), v, positive(h, "h"), out)
    return out


class FrictionFitness:
    """002 eq. 4 as a batch objective over ``(sigma0, sigma1, vs, fs)`` rows.

    Args:
        data: The measured record.
        known: Supplies the known ``F_c`` and ``sigma2``.
    """

    def __init__(self, data: FrictionData, known: LuGreFriction) -> None:
        self.data, self.known = data, known
        self.scale = float(np.sum(data.force**2))

    def __call__(self, points: Array) -> Array:
        """Normalised squared error of each row (``inf`` where ``fs < F_c``: no LuGre model)."""
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        sse = lugre.lugre_sse(
            _thetas(self.known, pts), self.data.velocity, self.data.force, self.data.h
        )
        return np.where(pts[:, 3] >= self.known.fc, sse / self.scale, np.inf)

    def residuals(self, point: Array) -> Array:
        """Residual vector (measured - model) / sqrt(scale) of one point, for least squares."""
        model = lugre_response(with_params(self.known, point), self.data.velocity, self.data.h)
        return (self.data.force - model) / math.sqrt(self.scale)


@dataclass(frozen=True)
class Identification:
    """One method's identification.

    Attributes:
        method: Name (a key of :data:`METHODS`).
        friction: Identified model (known ``F_c``, ``sigma2``).
        theta: ``(sigma0, sigma1, vs, fs)``.
        fitness: Normalised 002 eq. 4 at ``theta``.
        nfev: Fitness evaluations.
        seconds: Wall time.
    """

    method: str
    friction: LuGreFriction
    theta: Array
    fitness: float
    nfev: int
    seconds: float

    def percent_error(self, truth: LuGreFriction) -> Array:
        """Signed error of each identified parameter relative to ``truth``, %."""
        want = np.array([getattr(truth, n) for n in PARAM_NAMES])
        return 100.0 * (self.theta - want) / want


def identify_friction(
    data: FrictionData,
    method: str = "improved_foa",
    *,
    known: LuGreFriction | None = None,
    bounds: ArrayLike = DEFAULT_BOUNDS,
    population: int = 40,
    iterations: int = 150,
    seed: int | np.random.Generator = 0,
) -> Identification:
    """Identify ``(sigma0, sigma1, v_s, F_s)`` of a LuGre model from a friction record.

    Args:
        data: The record.
        method: One of :data:`METHODS`.
        known: Model supplying the known ``F_c`` and ``sigma2`` (default ``data.truth``).
        bounds: (4, 2) search box in ``PARAM_NAMES`` order; ``F_s`` must stay above ``F_c``.
        population: Evaluations per generation (population methods).
        iterations: Generations; ``least_squares`` gets the same evaluation budget.
        seed: Int or Generator (population methods).

    Returns:
        The :class:`Identification`.

    Raises:
        ValueError: for an unknown method, missing ``known`` or bad bounds.
    """
    choice(method, "identification method", METHODS)
    known = known if known is not None else data.truth
    if known is None:
        raise ValueError("identify_friction needs known= (F_c and sigma2) for data without truth")
    box = as_finite_array(bounds, "bounds", shape=(4, 2))
    if box[3, 0] < known.fc:
        raise ValueError(f"the F_s bounds must lie above F_c = {known.fc}, got {box[3].tolist()}")
    fitness = FrictionFitness(data, known)
    start = time.perf_counter()
    if method == "least_squares":
        budget = population * (iterations + 1)
        x0 = box.mean(axis=1)
        res = least_squares(
            fitness.residuals, x0, bounds=(box[:, 0], box[:, 1]), x_scale=box[:, 1] - box[:, 0],
            max_nfev=budget,
        )
        # the 2-point Jacobian costs 4 evaluations each time
        theta, nfev = np.asarray(res.x, dtype=float), int(res.nfev + 4 * (res.njev or 0))
    else:
        out = minimize(
            method, fitness, box, population=population, iterations=iterations, seed=seed
        )
        theta, nfev = np.asarray(out.x, dtype=float), out.nfev
    seconds = time.perf_counter() - start
    return Identification(
        method, with_params(known, theta), theta, float(fitness(theta)[0]), nfev, seconds
    )


__all__ = [
    "DEFAULT_BOUNDS",
    "METHODS",
    "PARAM_NAMES",
    "FrictionData",
    "FrictionFitness",
    "Identification",
    "friction_sweep",
    "identify_friction",
    "lugre_response",
    "sweep_profile",
    "with_params",
]
