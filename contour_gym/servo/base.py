"""Axis controllers by registration: parameter and state schemas, compiled law, default builder.

A controller is two compiled functions on row tables (one row ``i = b * A + a`` per member and
axis; ``p`` its parameters, ``s`` its state, both laid out by its schemas)::

    control(p, s, i, r, r_dot, r_ddot, y, ts) -> u
        the control of this tick before the CCC, compensation and saturation; reads s only
    commit(p, s, i, r, r_dot, r_ddot, y, ts, u_total, u_applied, u_comp, u_max)
        updates s once the tick's total control is known: ``u_total`` (unsaturated),
        ``u_applied`` (what drives the plant this tick: saturated, delayed on the rig),
        ``u_comp`` (the friction compensation's share, which observers must not count twice)

plus ``build(stage, gains, batch, **options) -> (batch, A, P)`` deriving default parameters
from the stage and the preset's PID gains. Register with :func:`register_controller`; the
servo loop then compiles and inlines exactly that controller.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._registry import Registry
from contour_gym._schema import Schema
from contour_gym._validate import as_finite_array
from contour_gym.jit import Family

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage
    from contour_gym.servo.gains import PIDGains

Array = NDArray[np.float64]
Builder = Callable[..., Array]


@dataclass(frozen=True)
class AxisController:
    """A registered axis controller.

    Attributes:
        name: Registry name.
        params: Parameter schema (the columns of ``p``).
        state: State schema (the columns of ``s``; zero at reset).
        control: Compiled control law (module docstring).
        commit: Compiled state update (module docstring).
        build: ``build(stage, gains, batch, **options) -> (batch, A, params.size)``.
        doc: One line on the law and its source.
    """

    name: str
    params: Schema
    state: Schema
    control: Any = field(repr=False)
    commit: Any = field(repr=False)
    build: Builder = field(repr=False)
    doc: str = ""

    def options(self) -> tuple[str, ...]:
        """The keyword options of :attr:`build` (without the friction compensation's)."""
        sig = inspect.signature(self.build).parameters
        return tuple(p for p, x in sig.items() if x.kind is inspect.Parameter.KEYWORD_ONLY)


CONTROLLERS: Registry[AxisController] = Registry("axis_controller")
# the kernels' slots of an axis controller (contour_gym.jit.slots)
CONTROLLER_FAMILY = Family(
    "axis controller",
    {"CTRL_CONTROL": attrgetter("control"), "CTRL_COMMIT": attrgetter("commit")},
    CONTROLLERS.components,
)


def register_controller(ctrl: AxisController, *, replace: bool = False) -> AxisController:
    """Register an axis controller (see the module docstring); returns it."""
    return CONTROLLERS.register(ctrl, replace=replace)


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


def option(
    value: ArrayLike | None, default: ArrayLike, n_axes: int, name: str, *,
    allow_zero: bool = False,
) -> Array:
    """An option given per axis (or one for all), else its default."""
    return per_axis(default if value is None else value, n_axes, name, allow_zero=allow_zero)


def rows(schema: Schema, batch: int, n_axes: int, **columns: ArrayLike) -> Array:
    """(batch, n_axes, schema.size) rows with the named columns set (per axis or scalar)."""
    row = np.zeros((n_axes, schema.size))
    schema.check_names(columns)
    for name, vals in columns.items():
        row[:, schema.names.index(name)] = np.broadcast_to(np.asarray(vals, float), (n_axes,))
    return np.repeat(row[None], batch, axis=0)


def loop_bandwidth(stage: Stage, gains: Sequence[PIDGains]) -> Array:
    """Natural frequency ``sqrt(kp K / m)`` of each axis' PID loop, rad/s."""
    kp = np.array([g.kp for g in gains])
    k = np.array([a.force_constant for a in stage.axes])
    m = np.array([a.mass for a in stage.axes])
    return np.sqrt(kp * k / m)


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


def measured_velocity_at(n, y_prev, y, ts):
    """Backward difference of the measured position (0 on the first tick: it starts at rest)."""
    return (y - y_prev) / ts if n > 0.0 else 0.0


measured_velocity = numba.njit(cache=True, inline="always")(measured_velocity_at)
