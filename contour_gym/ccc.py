"""Cross-coupled controller (Koren 1980; papers 000-003): a control law on the contour error.

The CCC output ``U`` of each contour is distributed to that contour's axes by the coupling gains
``C_i`` (the unit direction in which axis ``i`` must move to reduce the error, from the
estimator) times optional per-axis weights ``w_i`` (003's separate compensator gains K_cix,
K_ciy). Where it acts (``ccc_injection``):

* ``"control"`` (000, 001, 003): ``u_i += w_i C_i U`` is added to axis i's control signal, after
  the axis controller (``U`` in control units: A, V or N per metre of error);
* ``"reference"`` (002 section 4.3, pre-compensation: "decoupled to each axis in proportion and
  superimposed with the theoretical point R_d"): ``r_i += w_i C_i U`` shifts axis i's
  commanded position before its controller (``U`` in metres; the gains are dimensionless). It
  is also the only injection a commercial CNC's closed drives allow.

Sign convention (DESIGN.md glossary): in 2-D ``eps`` is positive when the tool is to the left of
the direction of travel and ``C = -n_left``; in 3-D ``eps = |eps_vec| >= 0`` and
``C = eps_vec / |eps_vec|``. Either way the contour error vector (tool -> foot point) is
``eps_vec = C eps``, so a positive gain always pushes the tool back onto the path. In 3-D the
unsigned ``eps`` cannot carry integral action (its integral only grows), so the law acts on
each signed component ``eps_vec_i = C_i eps`` with its own state row.

The law is a registered component (:data:`CCC_LAWS`): ``output(p, s, data, q, row, e, ts)``
returns U for parameter row ``q`` (``b * C + c``) on error ``e`` with state row ``row``;
``commit(p, s, data, q, row, e, ts, out, saturated)`` updates the state. ``pid`` (PID on eps) is
built in; register others with :func:`register_ccc_law`.

**Release at a stop.** While the reference stands at an exact stop or at the path's end waiting
for the axes to be in position, the kernel calls ``release(p, s, data, q, row, ts)`` after each
commit. The built-in laws bleed their integral off with the time constant
:data:`RELEASE_TIME` (a CNC hands the axes over to their own loops for the in-position check):
held, an integral that built up along the path keeps the axes off the point they must reach,
and the axes never come in position (measured: every CCC failed to finish 002's machine's
``part_2d`` with the nearest-point estimator; with the release each finishes). A law that
keeps the default (:func:`keep_state`) keeps its state.

**Standing aside on a leg the machine has left.** An estimator that tracks its own foot point from
tick to tick (``ground_truth``, the exact nearest point of the branch) keeps the foot on the leg the
machine is nearest to. After a reversal (a turn near 180 degrees, the new leg running almost back
along the old one) a lagging machine can stay nearer the old leg; a correction toward it then holds
the machine there, and the machine retraces the old leg while its reference runs down the new one
(on 002's machine, a 176-degree zig-zag: the PID CCC 3 mm behind its reference, peak contour error
1.47 mm against 0.14 mm without CCC; docs/measurements.md). So while the foot point the law acts on
moves *backward* on a stretch of the path that runs *against* the reference (its tangent more than
90 degrees from the reference's direction of travel), the law stands aside: no output, no commit,
its ``release`` called. The axes' own loops then bring the machine onto the reference's leg, the
foot passes to it, and the law acts again. Estimators that build their foot from the reference
(``exact``, ``two_circle``, ``tangent``, ``frenet``, ``angle``, ``window``, ``iterative``) are not
drawn back so and are never stood aside.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any

import numba
import numpy as np
from numpy.typing import ArrayLike

from contour_gym._registry import Registry
from contour_gym._schema import Param, Schema
from contour_gym._validate import as_finite_array, non_negative
from contour_gym.jit import Family
from contour_gym.servo.pid import STATE as PID_STATE
from contour_gym.servo.pid import pid_terms

INJECTIONS = ("control", "reference")


@dataclass(frozen=True)
class CCCGains:
    """PID gains of one contour's cross-coupled controller.

    Units per metre of contour error: control units (``ccc_injection="control"``) or metres
    (``"reference"``: dimensionless).

    Attributes:
        kp: Proportional gain.
        ki: Integral gain.
        kd: Derivative gain.
    """

    kp: float
    ki: float = 0.0
    kd: float = 0.0

    def __post_init__(self) -> None:
        vals = as_finite_array([self.kp, self.ki, self.kd], "CCC gains")
        if np.any(vals < 0):
            raise ValueError(f"CCC gains must be >= 0, got {self!r}")

    def as_tuple(self) -> tuple[float, float, float]:
        """Return ``(kp, ki, kd)``."""
        return (self.kp, self.ki, self.kd)

    def scaled(self, factor: float) -> CCCGains:
        """All three gains times ``factor``.

        >>> CCCGains(2.0, 10.0).scaled(0.5)
        CCCGains(kp=1.0, ki=5.0, kd=0.0)
        """
        return CCCGains(self.kp * factor, self.ki * factor, self.kd * factor)


OFF = CCCGains(0.0, 0.0, 0.0)

RELEASE_TIME = 0.05
"""Time constant, s, of the integral's release while the reference waits for the axes.

Chosen, not published: the papers do not say what their CCC does at a stop. 50 ms is about
three time constants of 002's 60 rad/s axis loop, the machine whose parts showed the problem,
and the x0.98 per 1 ms tick first tried in a scratch kernel; no other value was tried.
"""


@numba.njit(cache=True, inline="always")
def keep_state(p, s, data, q, row, ts):
    """A law's release that changes nothing (the default: the state stays as committed)."""


@numba.njit(cache=True, inline="always")
def release_integral(p, s, data, q, row, ts):
    """Bleed the integral (the PID state's, :data:`PID_STATE`) off with :data:`RELEASE_TIME`."""
    s[row, _S.integral] *= math.exp(-ts / RELEASE_TIME)


@dataclass(frozen=True)
class CCCLaw:
    """A registered CCC law.

    Attributes:
        name: Registry name.
        params: Parameter schema per contour; the first three columns are ``kp, ki, kd``
            (the base gains the CCC env's action sets).
        state: State schema per error row.
        output: Compiled output (module docstring).
        commit: Compiled state update.
        release: Compiled update while the reference waits for the axes (module docstring;
            default :func:`keep_state`).
        data: ``data()`` -> constant (n,) float table the law reads (fuzzy surfaces), or None.
        doc: One line on the law and its source.
        inline: Whether the kernel inlines the law (fast, but compiled into the kernel) or
            calls it (compiled apart: for a large law whose work per tick dwarfs a call).
        home: The preset the parameters' schema defaults were set on (None: defaults that
            hold on every machine). Needs ``units``.
        units: ``units(preset)`` -> each parameter's unit on that machine (beyond kp, ki,
            kd; finite, >= 0, and > 0 on a machine values carry from), e.g.
            ``1 / tolerance`` for an error scaling: a value set on one machine carries to
            another in proportion to it (:meth:`params_for`).
            None: the parameters are absolute and carry unchanged.
    """

    name: str
    params: Schema
    state: Schema
    output: Any = field(repr=False)
    commit: Any = field(repr=False)
    data: Callable[[], np.ndarray] | None = field(default=None, repr=False)
    doc: str = ""
    inline: bool = True
    home: str | None = None
    units: Callable[[Any], Mapping[str, float]] | None = field(default=None, repr=False)
    release: Any = field(default=keep_state, repr=False)

    def __post_init__(self) -> None:
        if (self.home is None) != (self.units is None):
            raise ValueError(f"CCC law {self.name!r}: give home and units together")
        integral = PID_STATE.col.integral
        if self.release is release_integral and self.state.names[integral:integral + 1] != (
            "integral",
        ):
            raise ValueError(f"CCC law {self.name!r}: release_integral bleeds state column "
                             f"{integral}, 'integral', but the law's state starts "
                             f"{self.state.names[:1]}")

    def params_for(
        self, machine: Any, given: Mapping[str, float], set_on: Any = None
    ) -> dict[str, float]:
        """The parameters beyond kp, ki, kd the law runs with on ``machine`` (a preset).

        The values ``given`` stand as they are, or, with ``set_on`` (the preset they were set
        on, or its name), carry to ``machine`` in proportion to :attr:`units`. A parameter not
        given takes its schema default carried from the preset :attr:`home`: the rule the
        default was made by, applied to this machine. On the machine a value was set on it
        is the value, bit for bit (the ratio of equal units is 1).

        Raises:
            ValueError: ``set_on`` for a law without units, or a unit that is not finite and
                >= 0 on ``machine`` or > 0 on ``home`` or ``set_on`` (naming the parameter and
                machine).
        """
        names = self.params.names[3:]
        out = {k: float(v) for k, v in given.items()}
        if self.units is None or self.home is None:
            if set_on is not None:
                raise ValueError(f"CCC law {self.name!r} has no machine units: its parameters "
                                 "cannot carry from the machine they were set on")
            return out
        if set_on is None and all(k in out for k in names):
            return out  # every value given for this machine: no unit needed
        here = self._units(machine, names, zero=True)
        if set_on is not None:
            there = self._units(_machine_named(set_on), names)
            out = {k: v * (here[k] / there[k]) if k in here else v for k, v in out.items()}
        base = self._units(_machine_named(self.home), names)
        defaults = self.params.defaults()
        for k in names:
            default = defaults[k]
            if k not in out and default is not None:  # None: a parameter with no default
                out[k] = default * (here[k] / base[k])
        return out

    def _units(self, machine: Any, names: Sequence[str], zero: bool = False) -> dict[str, float]:
        """The units on ``machine``: positive and finite (``zero``: or 0, a value made 0)."""
        assert self.units is not None
        units = {k: float(self.units(machine)[k]) for k in names}
        bad = {k: u for k, u in units.items() if not ((zero and u == 0.0) or 0.0 < u < math.inf)}
        if bad:
            raise ValueError(f"CCC law {self.name!r}: units {bad} on machine "
                             f"{getattr(machine, 'name', machine)!r} must be "
                             f"{'>= 0' if zero else 'positive'} and finite")
        return units

    def table(self) -> np.ndarray:
        """The law's constant data table (a one-element placeholder when it has none)."""
        if self.data is None:
            return np.zeros(1)
        return np.ascontiguousarray(self.data(), dtype=np.float64).reshape(-1)


CCC_LAWS: Registry[CCCLaw] = Registry("ccc_law")

# How a law finds the machine a name stands for (its ``home``, a ``set_on``): the machines are
# presets, a layer above, and contour_gym.presets sets its resolve_preset here when imported
# (``import contour_gym`` imports it), so that this module does not import the presets.
_MACHINE_LOOKUP: list[Callable[[Any], Any]] = []


def set_machine_lookup(lookup: Callable[[Any], Any]) -> None:
    """Set how :meth:`CCCLaw.params_for` finds a machine: ``lookup(name or preset)``."""
    _MACHINE_LOOKUP[:] = [lookup]


def _machine_named(machine: Any) -> Any:
    """The preset ``machine`` names (a preset itself is returned as it is).

    Raises:
        ValueError: for an unknown name.
    """
    if not _MACHINE_LOOKUP:
        raise RuntimeError("no machine lookup is set (import contour_gym.presets)")
    return _MACHINE_LOOKUP[0](machine)


# the kernels' slots of a CCC law (contour_gym.jit.slots)
CCC_FAMILY = Family(
    "ccc law",
    {
        "CCC_OUTPUT": attrgetter("output"),
        "CCC_COMMIT": attrgetter("commit"),
        "CCC_RELEASE": attrgetter("release"),
    },
    CCC_LAWS.components,
    attrgetter("inline"),
)


def register_ccc_law(law: CCCLaw, *, replace: bool = False) -> CCCLaw:
    """Register a CCC law (see the module docstring); returns it.

    Raises:
        ValueError: if the law's first three parameters are not ``kp, ki, kd``.
    """
    if law.params.names[:3] != ("kp", "ki", "kd"):
        raise ValueError(f"CCC law {law.name!r} must start its parameters with kp, ki, kd")
    return CCC_LAWS.register(law, replace=replace)


PID_PARAMS = Schema(
    "ccc pid",
    kp=Param(0.0, non_negative, "proportional gain per m of contour error"),
    ki=Param(0.0, non_negative, "integral gain per m s"),
    kd=Param(0.0, non_negative, "derivative gain, s per m"),
)
_C, _S = PID_PARAMS.col, PID_STATE.col


@numba.njit(cache=True, inline="always")
def pid_output(p, s, data, q, row, e, ts):
    """PID on the contour error (the classic CCC)."""
    return pid_terms(p[q, _C.kp], p[q, _C.ki], p[q, _C.kd], s, row, e, ts)


@numba.njit(cache=True, inline="always")
def pid_commit(p, s, data, q, row, e, ts, out, saturated):
    """Integrate (always: the axis controllers handle saturation) and keep e."""
    s[row, _S.integral] += e * ts
    s[row, _S.e_prev] = e
    s[row, _S.started] = 1.0


PID = register_ccc_law(
    CCCLaw("pid", PID_PARAMS, PID_STATE, pid_output, pid_commit,
           doc="PID on the contour error (Koren 1980)", release=release_integral)
)


def ccc_params(
    gains: ArrayLike | CCCGains | Sequence[float] | None,
    batch: int,
    n_contours: int,
    law: CCCLaw = PID,
    **law_params: Any,
) -> np.ndarray:
    """Parameter rows (batch, n_contours, law.params.size) of a CCC law.

    Args:
        gains: ``None`` (CCC off), a :class:`CCCGains`, a ``(kp, ki, kd)`` triple, or an
            array broadcastable to (batch, n_contours, 3).
        batch: Batch size.
        n_contours: Contours of the stage.
        law: The CCC law (default PID).
        **law_params: The law's other parameters (scalars, every member and contour).

    Returns:
        The parameter rows.

    Raises:
        ValueError: on non-finite or negative gains, a shape that does not broadcast, or an
            unknown law parameter.
    """
    if gains is None:
        gains = OFF
    if isinstance(gains, CCCGains):
        gains = gains.as_tuple()
    arr = as_finite_array(gains, "ccc_gains")
    try:
        arr = np.broadcast_to(arr, (batch, n_contours, 3))
    except ValueError as exc:
        raise ValueError(
            f"ccc_gains of shape {arr.shape} do not broadcast to (batch={batch}, "
            f"contours={n_contours}, 3)"
        ) from exc
    if np.any(arr < 0):
        raise ValueError(f"ccc_gains must be >= 0, got {arr.min()}")
    base = law.params.row(kp=0.0, ki=0.0, kd=0.0, **law_params)
    out = np.repeat(np.repeat(base[None, None], batch, 0), n_contours, 1)
    out[..., :3] = arr
    return out
