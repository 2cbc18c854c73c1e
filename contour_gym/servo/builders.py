"""Parameter rows of the axis controllers, with defaults derived from the stage and its PID.

Every builder returns ``(batch, n_axes, N_CP)`` rows for :mod:`contour_gym.servo._kernel`.
Options are scalars (every axis) or one value per axis. Model-based laws read the nominal model
``a = damping / mass``, ``b = force_constant / mass`` from ``stage.axes`` (the ``mass``,
``damping`` and ``force_constant`` options override it, e.g. to study model mismatch). Every
controller also takes ``friction`` (``"feedforward"``, ``"feedback"``, ``"feedback_static"``)
and ``friction_model`` (:func:`friction_columns`).

How the defaults are derived (``omega`` is the bandwidth of the preset's PID,
``omega = sqrt(kp K / m)``, the natural frequency :func:`contour_gym.plant.pd_pole_placement`
placed; ``D_max`` is :func:`disturbance_bound`):

===============  ============================================================================
``pid``          the preset's gains.
``two_dof_pid``  the preset's PID: ``Kp = kp``, ``TI = kp / ki`` (inf without ki),
                 ``TD = kd / kp``, ``alpha = beta = 0`` (003's law then is that PID with the
                 derivative on ``r' - y'``).
``smc_dob``      ``c = lambda = omega`` (surface and reaching poles at the PID's bandwidth);
                 ``eta = 0.1 D_max`` (the switching term only has to cover the observer's
                 residual); ``phi = eta / omega`` (inside the layer the switching term is a
                 linear gain ``eta / phi = omega``, so the loop poles stay at the PID's scale);
                 observer gain ``l = min(8 omega, 0.8 / ts)`` (faster than the loop; Euler
                 step ``l ts`` at most 0.8). Measured on ``xyz_pmlsm``: ``l ts = 0.5`` left
                 the max tracking error ~20 % above ``smc``'s, 0.8 puts it below.
``smc``          the same law without observer: ``eta = D_max`` (001: without the observer the
                 switching gain must exceed the whole disturbance) and the same ``c``,
                 ``lambda``, ``phi`` as ``smc_dob``; inside the layer its gain on ``S`` is
                 ``lambda + eta / phi = 11 omega``, and where ``11 omega ts > 1`` (``xyz_pmlsm``:
                 1.2-1.65) the sampled layer overshoots every tick: 001's chattering.
``pd_robust``    ``kp = c (lambda + eta / phi) = 2 omega^2``, ``kd = c + lambda + eta / phi =
                 3 omega``: the linear part of ``smc_dob`` inside its boundary layer, so the
                 comparison isolates the observer and the switching term.
===============  ============================================================================
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Sequence
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array, choice
from contour_gym.servo import _kernel as K  # noqa: N812
from contour_gym.servo.gains import PIDGains

if TYPE_CHECKING:
    from contour_gym.plant.params import AxisParams, LuGreFriction
    from contour_gym.plant.stage import Stage

Array = NDArray[np.float64]

ETA_DOB_RATIO = 0.1  # smc_dob switching gain as a fraction of D_max
DOB_SPEEDUP = 8.0  # observer bandwidth / loop bandwidth
DOB_MAX_STEP = 0.8  # largest Euler step l ts of the observer
D_FLOOR = 0.01  # least disturbance bound, fraction of the axis' peak acceleration K u_max / m
FRICTION_MODES = {
    "none": K.FR_NONE,
    "feedforward": K.FR_FEEDFORWARD,
    "feedback": K.FR_FEEDBACK,
    "feedback_static": K.FR_FEEDBACK_STATIC,
}
TWO_DOF_NAMES = ("kp", "ti", "td", "alpha", "beta")


def per_axis(value: ArrayLike, n_axes: int, name: str, *, allow_zero: bool = False) -> Array:
    """``value`` as one positive (or non-negative) finite float per axis.

    Args:
        value: A scalar (every axis) or a sequence of ``n_axes`` values.
        n_axes: Number of axes.
        name: Option name, quoted in errors.
        allow_zero: Accept 0.

    Returns:
        (n_axes,) array.

    Raises:
        ValueError: for a wrong length, a non-finite value or one out of range.
    """
    arr = as_finite_array(value, name)
    if arr.ndim > 1 or (arr.ndim == 1 and arr.size != n_axes):
        raise ValueError(f"{name} must be a scalar or {n_axes} values, got shape {arr.shape}")
    arr = np.broadcast_to(arr, (n_axes,)).copy()
    bad = arr < 0 if allow_zero else arr <= 0
    if bad.any():
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {arr.tolist()}")
    return arr


def loop_bandwidth(stage: Stage, gains: Sequence[PIDGains]) -> Array:
    """Natural frequency ``sqrt(kp K / m)`` of each axis' PID loop, rad/s."""
    kp = np.array([g.kp for g in gains])
    k = np.array([a.force_constant for a in stage.axes])
    m = np.array([a.mass for a in stage.axes])
    return np.sqrt(kp * k / m)


def disturbance_bound(axis: AxisParams) -> float:
    """Bound ``D_max`` of the lumped disturbance acceleration of an axis, m/s^2.

    ``(|step| + |sinusoid| + 3 sigma_random + F_friction + F_ripple) / m``, with the friction's
    break-away force and the ripple's summed amplitudes, and at least ``D_FLOOR`` of the peak
    acceleration ``K u_max / m`` (for unmodelled dynamics when the axis has no disturbance).
    """
    from contour_gym.plant.params import CoulombFriction

    force = 0.0
    d = axis.disturbance
    if d is not None:
        force += abs(d.step_amp) + abs(d.sin_amp) + 3.0 * d.random_std
    fr = axis.friction
    if isinstance(fr, CoulombFriction):
        force += fr.static
    elif fr is not None:
        force += fr.fs
    if axis.ripple is not None:
        force += float(np.sum(np.hypot(axis.ripple.sin_amp, axis.ripple.cos_amp)))
    floor = D_FLOOR * axis.force_constant * axis.u_max
    return max(force, floor) / axis.mass


def nominal_model(
    stage: Stage,
    mass: ArrayLike | None = None,
    damping: ArrayLike | None = None,
    force_constant: ArrayLike | None = None,
) -> tuple[Array, Array]:
    """Nominal ``a = damping / mass`` (1/s) and ``b = force_constant / mass`` per axis.

    Args:
        stage: The machine (its axes give the defaults).
        mass: Override of the masses, kg (> 0).
        damping: Override of the viscous damping, N s/m (>= 0).
        force_constant: Override of the force constants (> 0).

    Returns:
        ``(a, b)``, each (n_axes,).
    """
    n = stage.n_axes
    m = per_axis([x.mass for x in stage.axes] if mass is None else mass, n, "mass")
    c = [x.damping for x in stage.axes] if damping is None else damping
    b = per_axis(c, n, "damping", allow_zero=True)
    kf = [x.force_constant for x in stage.axes] if force_constant is None else force_constant
    k = per_axis(kf, n, "force_constant")
    return b / m, k / m


def friction_columns(
    stage: Stage,
    rows: Array,
    friction: str | None,
    friction_model: LuGreFriction | Sequence[LuGreFriction | None] | None,
) -> None:
    """Fill the friction-compensation columns of ``rows`` (batch, n_axes, N_CP) in place.

    Args:
        stage: The machine (force constants; default models).
        rows: Parameter rows to complete.
        friction: ``None``/``"none"``, ``"feedforward"`` (LuGre model on the command
            velocity, 002 section 3) or ``"feedback"`` (002 eq. 3 on the measured velocity,
            the traditional compensation).
        friction_model: The (identified) LuGre parameters: one for every axis, one per axis
            (``None`` = no compensation on that axis), or ``None`` for each axis' own LuGre
            friction.

    Raises:
        ValueError: for an unknown mode, or no model for an axis without LuGre friction.
    """
    from contour_gym.plant.params import LuGreFriction

    mode = FRICTION_MODES[
        choice("none" if friction is None else friction, "friction", FRICTION_MODES)
    ]
    if mode == K.FR_NONE:
        return
    n = stage.n_axes
    if friction_model is None:
        models: list[object] = [a.friction for a in stage.axes]
        for a, fm in zip(stage.axes, models, strict=True):
            if not isinstance(fm, LuGreFriction):
                raise ValueError(f"axis {a.name!r} has no LuGre friction; pass friction_model")
    elif isinstance(friction_model, LuGreFriction):
        models = [friction_model] * n
    else:
        models = list(friction_model)
        if len(models) != n:
            raise ValueError(f"friction_model needs {n} entries, got {len(models)}")
    for i, fm in enumerate(models):
        if fm is None:
            continue
        if not isinstance(fm, LuGreFriction):
            raise ValueError(f"friction_model entries must be LuGreFriction or None, got {fm!r}")
        rows[:, i, K.CP_FR_MODE] = mode
        rows[:, i, K.CP_FR_INVK] = 1.0 / stage.axes[i].force_constant
        cols = (K.CP_FR_S0, K.CP_FR_S1, K.CP_FR_S2, K.CP_FR_FC, K.CP_FR_FS, K.CP_FR_VS)
        rows[:, i, cols] = fm.sigma0, fm.sigma1, fm.sigma2, fm.fc, fm.fs, fm.vs


def _rows(batch: int, per_axis_cols: dict[int, Array]) -> Array:
    n = len(next(iter(per_axis_cols.values())))
    row = np.zeros((n, K.N_CP))
    for col, vals in per_axis_cols.items():
        row[:, col] = vals
    return np.repeat(row[None], batch, axis=0)


def pid_params(gains: tuple[PIDGains, ...], batch: int) -> Array:
    """Kernel parameter rows (batch, n_axes, N_CP) for the given per-axis gains."""
    return _rows(
        batch,
        {
            K.CP_KP: np.array([g.kp for g in gains]),
            K.CP_KI: np.array([g.ki for g in gains]),
            K.CP_KD: np.array([g.kd for g in gains]),
            K.CP_KFF: np.array([g.kff for g in gains]),
        },
    )


def two_dof_pid_values(gains: Sequence[PIDGains]) -> Array:
    """The five tunable 2-DOF PID numbers (Kp, TI, TD, alpha, beta) per axis of a PID, (A, 5).

    ``TI = kp / ki`` (``inf`` when ``ki = 0``), ``TD = kd / kp``, ``alpha = beta = 0``.
    """
    return np.array(
        [[g.kp, g.kp / g.ki if g.ki > 0 else math.inf, g.kd / g.kp, 0.0, 0.0] for g in gains]
    )


def two_dof_pid_params(values: ArrayLike, base: ArrayLike | None = None) -> Array:
    """Kernel rows of 003's 2-DOF PID from its five tunable numbers per axis.

    This is what an optimiser tuning 003's 15 axis parameters (eqs. 34-35) maps its points
    through before :meth:`contour_gym.loop.ServoLoop.set_controller_params`.

    Args:
        values: ``(..., n_axes, 5)`` of ``(Kp, TI, TD, alpha, beta)``: ``Kp > 0``,
            ``TI > 0`` (``inf`` = no integral), ``TD >= 0``, ``alpha`` and ``beta`` finite
            (003 eqs. 28-29; ``alpha = beta = 0`` is a plain PID). E.g. an optimiser's
            ``(B, 15)`` population reshaped to ``(B, 3, 5)``.
        base: Rows to start from (keeps their other columns, e.g. friction compensation),
            broadcastable to ``(..., n_axes, N_CP)``; default zeros.

    Returns:
        ``(..., n_axes, N_CP)`` rows (a new array).

    Raises:
        ValueError: for a wrong shape or an out-of-range value, naming it.
    """
    v = np.asarray(values, dtype=np.float64)
    if v.ndim < 2 or v.shape[-1] != 5:
        raise ValueError(f"two_dof_pid values must have shape (..., n_axes, 5), got {v.shape}")
    kp, ti, td, alpha, beta = np.moveaxis(v, -1, 0)
    as_finite_array(np.stack([kp, td, alpha, beta]), "two_dof_pid Kp, TD, alpha, beta")
    if np.any(np.isnan(ti)) or np.any(ti <= 0) or np.any(kp <= 0) or np.any(td < 0):
        raise ValueError("two_dof_pid needs Kp > 0, TI > 0 (inf allowed) and TD >= 0")
    shape = v.shape[:-1] + (K.N_CP,)
    out = np.zeros(shape) if base is None else np.array(np.broadcast_to(base, shape), dtype=float)
    out[..., K.CP_KP], out[..., K.CP_KI], out[..., K.CP_KD] = kp, kp / ti, kp * td
    out[..., K.CP_KFF] = 0.0
    out[..., K.CP_ALPHA], out[..., K.CP_BETA] = alpha, beta
    return out


def _option(
    value: ArrayLike | None, default: Array, n_axes: int, name: str, *, allow_zero: bool = False
) -> Array:
    return per_axis(default if value is None else value, n_axes, name, allow_zero=allow_zero)


def _build_pid(stage: Stage, gains: Sequence[PIDGains], batch: int) -> Array:
    return pid_params(tuple(gains), batch)


def _build_two_dof_pid(
    stage: Stage,
    gains: Sequence[PIDGains],
    batch: int,
    *,
    kp: ArrayLike | None = None,
    ti: ArrayLike | None = None,
    td: ArrayLike | None = None,
    alpha: ArrayLike | None = None,
    beta: ArrayLike | None = None,
) -> Array:
    values = two_dof_pid_values(gains)
    for j, (name, given) in enumerate(zip(TWO_DOF_NAMES, (kp, ti, td, alpha, beta), strict=True)):
        if given is not None:
            arr = np.asarray(given, dtype=float)
            if arr.ndim > 1 or arr.size not in (1, stage.n_axes):
                raise ValueError(
                    f"{name} must be a scalar or {stage.n_axes} values, got {arr.shape}"
                )
            values[:, j] = np.broadcast_to(arr, (stage.n_axes,))
    return two_dof_pid_params(np.repeat(values[None], batch, axis=0))


def smc_defaults(stage: Stage, gains: Sequence[PIDGains], observer: bool) -> dict[str, Array]:
    """Default ``c``, ``reaching``, ``eta``, ``phi``, ``observer_gain`` per axis (module doc)."""
    omega = loop_bandwidth(stage, gains)
    d_max = np.array([disturbance_bound(a) for a in stage.axes])
    eta_dob = ETA_DOB_RATIO * d_max
    gain = np.minimum(DOB_SPEEDUP * omega, DOB_MAX_STEP / stage.ts)
    return {
        "c": omega,
        "reaching": omega,
        "eta": eta_dob if observer else d_max,
        "phi": eta_dob / omega,
        "observer_gain": gain if observer else np.zeros_like(omega),
    }


def _build_smc(
    stage: Stage,
    gains: Sequence[PIDGains],
    batch: int,
    *,
    observer: bool,
    c: ArrayLike | None = None,
    reaching: ArrayLike | None = None,
    eta: ArrayLike | None = None,
    phi: ArrayLike | None = None,
    observer_gain: ArrayLike | None = None,
    mass: ArrayLike | None = None,
    damping: ArrayLike | None = None,
    force_constant: ArrayLike | None = None,
) -> Array:
    n, d = stage.n_axes, smc_defaults(stage, gains, observer)
    if not observer and observer_gain is not None:
        raise ValueError("smc has no observer; use smc_dob to set observer_gain")
    cols = {
        K.CP_C: _option(c, d["c"], n, "c"),
        K.CP_LAMBDA: _option(reaching, d["reaching"], n, "reaching", allow_zero=True),
        K.CP_ETA: _option(eta, d["eta"], n, "eta"),
        K.CP_PHI: _option(phi, d["phi"], n, "phi"),
        K.CP_L: _option(observer_gain, d["observer_gain"], n, "observer_gain") if observer
        else np.zeros(n),
    }  # fmt: skip
    if np.any(cols[K.CP_L] * stage.ts > 1.0):
        raise ValueError(
            f"observer_gain * ts must be <= 1, got {(cols[K.CP_L] * stage.ts).tolist()}"
        )
    cols[K.CP_A], cols[K.CP_B] = nominal_model(stage, mass, damping, force_constant)
    return _rows(batch, cols)


def _build_pd_robust(
    stage: Stage,
    gains: Sequence[PIDGains],
    batch: int,
    *,
    kp: ArrayLike | None = None,
    kd: ArrayLike | None = None,
    mass: ArrayLike | None = None,
    damping: ArrayLike | None = None,
    force_constant: ArrayLike | None = None,
) -> Array:
    n, d = stage.n_axes, smc_defaults(stage, gains, observer=True)
    layer = d["reaching"] + d["eta"] / d["phi"]  # smc_dob's gain on S inside its layer
    cols = {
        K.CP_PD_KP: _option(kp, d["c"] * layer, n, "kp"),
        K.CP_PD_KD: _option(kd, d["c"] + layer, n, "kd"),
    }
    cols[K.CP_A], cols[K.CP_B] = nominal_model(stage, mass, damping, force_constant)
    return _rows(batch, cols)


Builder = Callable[..., Array]

# name -> (kernel kind, builder(stage, default PID gains, batch, **options) -> (B, A, N_CP))
CONTROLLERS: dict[str, tuple[int, Builder]] = {
    "pid": (K.CTRL_PID, _build_pid),
    "two_dof_pid": (K.CTRL_TWO_DOF_PID, _build_two_dof_pid),
    "smc_dob": (K.CTRL_SMC, partial(_build_smc, observer=True)),
    "smc": (K.CTRL_SMC, partial(_build_smc, observer=False)),
    "pd_robust": (K.CTRL_PD_ROBUST, _build_pd_robust),
}


FRICTION_OPTIONS = ("friction", "friction_model")


def controller_options(name: str) -> tuple[str, ...]:
    """The options controller ``name`` accepts (its own, then the friction compensation's)."""
    builder = CONTROLLERS[choice(name, "axis_controller", CONTROLLERS)][1]
    params = inspect.signature(builder).parameters
    own = (
        p for p, x in params.items() if x.kind is inspect.Parameter.KEYWORD_ONLY and p != "observer"
    )
    return (*own, *FRICTION_OPTIONS)


def build_controller(
    name: str, stage: Stage, gains: Sequence[PIDGains], batch: int, **options: object
) -> tuple[int, np.ndarray]:
    """Kernel kind and parameter rows (batch, n_axes, N_CP) of the axis controller ``name``.

    Args:
        name: A key of :data:`CONTROLLERS`.
        stage: The machine (model-based controllers read its nominal axis parameters).
        gains: The preset's per-axis PID gains (the baseline other designs start from).
        batch: Batch size.
        **options: Controller-specific settings (:func:`controller_options`).

    Returns:
        ``(kind, params)``.

    Raises:
        ValueError: for an unknown name or option, or a bad option value.
    """
    kind, builder = CONTROLLERS[choice(name, "axis_controller", CONTROLLERS)]
    accepted = controller_options(name)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(
            f"unknown option(s) {', '.join(unknown)} for {name!r}; accepted: {', '.join(accepted)}"
        )
    if len(gains) != stage.n_axes:
        raise ValueError(f"need {stage.n_axes} axis gains, got {len(gains)}")
    friction = options.pop("friction", None)
    friction_model = options.pop("friction_model", None)
    params = builder(stage, gains, batch, **options)
    friction_columns(stage, params, friction, friction_model)  # type: ignore[arg-type]
    if params.shape != (batch, stage.n_axes, K.N_CP) or not np.all(np.isfinite(params)):
        raise ValueError(f"controller {name!r} built invalid parameters of shape {params.shape}")
    return kind, params
