"""Machines: the five papers' presets, and yours by registration.

A :class:`Preset` is a machine (a :class:`~contour_gym.plant.Stage`) plus the servo settings and
the scenario its paper runs: axis gains, CCC gains and where the CCC acts, the test path and
feedrate, the interpolator's limits, the estimator and tolerance the paper's controller uses.
Presets sit above the plant and servo layers (they need both). Published numbers are used
where the papers give them; every other number is *chosen* and says so in the preset's notes.

Add your machine with one module and one call::

    register_preset("my_mill", lambda: Preset("my_mill", "user", stage, gains, ...))

and use it by name everywhere (``simulate(plant="my_mill")``, the envs' ``plant=``). A dict
``{"preset": name, **field_overrides}`` passed as ``plant=`` overrides fields of a registered
preset (nested dicts override nested dataclasses; axes are keyed by name or index), e.g.
``plant={"preset": "xy_dc_servo", "feedrate": 0.02, "stage": {"axes": {"x": {"mass": 40.0}}}}``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from contour_gym._registry import Registry
from contour_gym._validate import choice, positive
from contour_gym.ccc import INJECTIONS, CCCGains
from contour_gym.plant import (
    AxisParams,
    Contour,
    Disturbance,
    LuGreFriction,
    Ripple,
    Stage,
    StribeckFriction,
)
from contour_gym.servo import PIDGains


@dataclass(frozen=True)
class Preset:
    """A machine plus the servo settings and scenario it is run with.

    Attributes:
        name: Preset name.
        paper: Source paper file prefix ("000".."004"), or "user".
        stage: The machine.
        axis_gains: Default per-axis PID gains.
        ccc_gains: Default PID CCC gains (for every contour), in the units of
            ``ccc_injection``.
        path: Name of the paper's test path (``contour_gym.paths.load``).
        feedrate: The paper's feedrate on that path, m/s.
        accel: Interpolator acceleration limit, m/s^2 (inf = time-parameterised reference).
        jerk: Interpolator jerk limit, m/s^3 (inf = none).
        max_feedrate: The machine's feedrate limit, m/s (commanded feeds are capped to it).
        rapid_rate: Speed of rapid moves, m/s (None: ``max_feedrate``).
        ccc_injection: Where the paper's CCC acts: ``"control"`` or ``"reference"``.
        estimator: The contour error estimator the paper's controller uses.
        tolerance: Contour tolerance of the paper's scenario, m (the envs' default).
        notes: What is published and what is chosen.
    """

    name: str
    paper: str
    stage: Stage
    axis_gains: tuple[PIDGains, ...]
    ccc_gains: CCCGains
    path: str
    feedrate: float
    accel: float = math.inf
    jerk: float = math.inf
    max_feedrate: float = math.inf
    rapid_rate: float | None = None
    ccc_injection: str = "control"
    estimator: str = "ground_truth"
    tolerance: float = 1e-5
    notes: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        positive(self.feedrate, "feedrate")
        positive(self.tolerance, "tolerance")
        choice(self.ccc_injection, "ccc_injection", INJECTIONS)
        if len(self.axis_gains) != self.stage.n_axes:
            raise ValueError(f"need {self.stage.n_axes} axis gains, got {len(self.axis_gains)}")


def pd_pole_placement(
    axis: AxisParams, omega: float, zeta: float = 0.7, ki_ratio: float = 0.0
) -> PIDGains:
    """PID gains placing the axis' closed-loop poles at ``omega`` with damping ``zeta``.

    For ``m x'' + b x' = K u`` with ``u = kp e + kd de/dt``: ``kp = m omega^2 / K`` and
    ``kd = max(0, (2 zeta omega m - b) / K)``; ``ki = ki_ratio * kp * omega`` adds a slow
    integral (``ki_ratio`` ~ 0.1 keeps the PD poles nearly in place).

    Args:
        axis: The axis.
        omega: Closed-loop natural frequency, rad/s.
        zeta: Damping ratio.
        ki_ratio: Integral gain relative to ``kp * omega``.

    Returns:
        The gains.
    """
    positive(omega, "omega")
    positive(zeta, "zeta")
    kp = axis.mass * omega**2 / axis.force_constant
    kd = max(0.0, (2.0 * zeta * omega * axis.mass - axis.damping) / axis.force_constant)
    return PIDGains(kp=kp, ki=ki_ratio * kp * omega, kd=kd)


def _xy_dc_servo() -> Preset:
    lead = 0.04  # chosen ball-screw lead, m/rev
    axes = tuple(
        AxisParams.from_rotary(
            n, inertia=0.015, viscous=1.2, torque_constant=0.57, lead=lead, u_max=20.0,
            encoder_resolution=1e-6,
        )
        for n in ("x", "y")
    )
    # 000's position loops are P-type; velocity constant Kv = kp K / b = 30 1/s (chosen)
    # reproduces the scale of 000's uncompensated error (0.049 mm on the 10 mm circle).
    gains = tuple(PIDGains(kp=30.0 * a.damping / a.force_constant) for a in axes)
    stage = Stage(
        "xy_dc_servo", axes, (Contour((0, 1)),), ts=1e-3, in_position=1e-5,
        notes="000: C_T = 0.57 N m/A, B = 1.2 N m s, J = 0.015 kg m^2 per axis (published); "
        "lead 40 mm, u_max 20 A, Ts 1 ms, P-type loops with Kv = 30/s (chosen). Rig: 1 um "
        "grating encoder (000's platform has one; resolution not published: chosen), one-tick "
        "computation delay, no measurement noise (a digital encoder only quantises).",
    )  # fmt: skip
    kp = gains[0].kp
    return Preset(
        "xy_dc_servo", "000", stage, gains, CCCGains(kp=kp, ki=kp * 20.0, kd=0.0),
        path="circle_r10", feedrate=0.01 * math.pi, max_feedrate=0.05,
        notes="000 experiment: x = 10 cos(pi t) - 10, y = 10 sin(pi t) mm (10 pi mm/s). "
        "Machine feed limit 50 mm/s (chosen: 20 A against B = 1.2 N m s caps the axes near "
        "60 mm/s).",
    )  # fmt: skip


def _xyz_pmlsm() -> Preset:
    disturbance = Disturbance(sin_amp=2.0, sin_freq=1.0, random_std=2.0, random_bandwidth=20.0)
    axes = tuple(
        AxisParams(n, mass=m, damping=b, force_constant=30.0, u_max=10.0,
                   disturbance=disturbance, encoder_resolution=1e-6)
        for n, m, b in (("x", 4.0, 8.0), ("y", 3.0, 6.0), ("z", 2.0, 4.0))
    )
    gains = tuple(
        pd_pole_placement(a, w, 0.8, 0.1) for a, w in zip(axes, (150.0, 130.0, 110.0), strict=True)
    )
    stage = Stage(
        "xyz_pmlsm", axes, (Contour((0, 1, 2)),), ts=1e-3, in_position=5e-5,
        in_position_speed=5e-3,
        notes="001 three-axis PMLSM: table 2 lost in extraction; masses 4/3/2 kg, damping "
        "8/6/4 N s/m, K = 30 N/A, u_max 10 A, random + 1 Hz sinusoidal disturbance of 2 N "
        "(chosen). Loop bandwidths 150/130/110 rad/s (chosen mismatch). Rig: 1 um linear "
        "encoders (chosen), one-tick computation delay.",
    )  # fmt: skip
    kp = gains[0].kp
    return Preset(
        "xyz_pmlsm", "001", stage, gains, CCCGains(kp=kp, ki=kp * 10.0),
        path="helix", feedrate=0.02, accel=0.5, max_feedrate=0.2,
        notes="001 screw curve; feedrate 20 mm/s, machine limit 200 mm/s (chosen).",
    )  # fmt: skip


def _lugre_linear_motor() -> Preset:
    lugre = LuGreFriction(sigma0=560.0, sigma1=300.0, sigma2=4.0, fc=20.0, fs=30.0, vs=0.5)
    axes = tuple(
        AxisParams(n, mass=m, damping=5.0, force_constant=50.0, u_max=10.0, friction=lugre,
                   encoder_resolution=1e-7)
        for n, m in (("x", 8.0), ("z", 6.0))
    )
    gains = tuple(
        pd_pole_placement(a, w, 0.8, 0.1) for a, w in zip(axes, (80.0, 60.0), strict=True)
    )
    stage = Stage(
        "lugre_linear_motor", axes, (Contour((0, 1)),), ts=1e-3, substeps=4, in_position=5e-6,
        notes="002: LuGre F_s = 30 N, v_s = 0.5 m/s, sigma0 = 560, sigma1 = 300 (table 1, "
        "published); F_c = 20 N, sigma2 = 4 N s/m, masses 8/6 kg, K = 50 N/A, u_max 10 A, "
        "bandwidths 80/60 rad/s (chosen; the mismatch is 002 section 4.2's subject). Rig: "
        "0.1 um linear encoders (chosen for 002's um-level precision platform), one-tick "
        "computation delay.",
    )  # fmt: skip
    return Preset(
        "lugre_linear_motor", "002", stage, gains, CCCGains(kp=1.0, ki=10.0),
        path="bspline_complex", feedrate=1.4 / 60.0, accel=0.5, max_feedrate=0.2,
        ccc_injection="reference",
        notes="002 fig. 13: 742 mm B-spline path at 1400 mm/min. 002 section 4.3 superimposes "
        "the CCC's correction on the commanded position (pre-compensation); its gains are "
        "dimensionless here (kp 1, ki 10/s: the control-injection gains of the other presets, "
        "kp_axis (1, 10/s), divided by the axis kp; chosen).",
    )  # fmt: skip


def _gantry_axis(
    name: str, k_m: float, b_m: float, h_m: float, mass: float, enc: float
) -> AxisParams:
    # 003 identifies K/M, b/M and the lumped uncertainty H/M; with a chosen mass M we split H
    # into Stribeck friction (F_c = 0.5 H, F_s = 0.7 H) and six ripple harmonics (0.3 H).
    h = h_m * mass
    pitch = 0.032  # chosen magnet pole pitch, m
    ripple = Ripple(
        sin_amp=tuple(0.3 * h / (j * 2.0) for j in range(1, 7)),
        cos_amp=tuple(0.3 * h / (j * 4.0) for j in range(1, 7)),
        wavenumber=tuple(2.0 * math.pi * j / pitch for j in range(1, 7)),
    )
    return AxisParams(
        name, mass=mass, damping=b_m * mass, force_constant=k_m * mass, u_max=10.0,
        friction=StribeckFriction(fc=0.5 * h, fs=0.7 * h, vs=0.01, delta=2.0),
        ripple=ripple, encoder_resolution=enc,
    )  # fmt: skip


def _xyy_gantry() -> Preset:
    axes = (
        _gantry_axis("x", 97.01, 39.21, 1.57, 4.0, 50e-6),
        _gantry_axis("y1", 881.36, 142.324, 0.17, 2.0, 10e-6),
        _gantry_axis("y2", 1949.706, 179.56, 1.71, 2.0, 10e-6),
    )
    gains = tuple(
        pd_pole_placement(a, w, 0.8, 0.1) for a, w in zip(axes, (90.0, 120.0, 150.0), strict=True)
    )
    contours = (Contour((0, 1), (0.0, 0.07)), Contour((0, 2), (0.0, 0.21)))
    stage = Stage(
        "xyy_gantry", axes, contours, ts=5e-4, substeps=2, in_position=1e-4,
        in_position_speed=5e-3,
        notes="003: K/M, b/M, H/M per axis (published, case 1 identification), Ts = 0.5 ms "
        "(published), two contours sharing x with y offsets 70/210 mm (published). Masses "
        "4/2/2 kg, the split of H into friction and ripple, 32 mm pole pitch, u_max 10 V "
        "and bandwidths 90/120/150 rad/s are chosen. Rig: 003's published 50/10/10 um "
        "linear encoders, one-tick computation delay.",
    )  # fmt: skip
    kp = gains[0].kp
    return Preset(
        "xyy_gantry", "003", stage, gains, CCCGains(kp=kp, ki=kp * 10.0),
        path="circle_r50", feedrate=2.0 * math.pi * 0.05, max_feedrate=1.0,
        notes="003 case 1: r = 50 mm circle at f = 1 Hz (0.314 m/s).",
    )  # fmt: skip


def _xy_servo_coulomb() -> Preset:
    lead = 0.01  # chosen ball-screw lead, m/rev
    axes = (
        AxisParams.from_rotary(
            "x", inertia=0.0103, viscous=0.0336, torque_constant=1.2054, lead=lead,
            coulomb_torque=0.2, u_max=10.0, current_tau=1e-3, encoder_resolution=1e-6,
        ),
        AxisParams.from_rotary(
            "y", inertia=0.012, viscous=0.0308, torque_constant=1.2054, lead=lead,
            coulomb_torque=0.31, u_max=10.0, current_tau=1e-3, encoder_resolution=1e-6,
        ),
    )  # fmt: skip
    # 004 table 4.2's k_p ratio 5.5 : 4.95 sets the bandwidth mismatch (chosen scale 60 rad/s).
    omegas = (60.0, 60.0 * math.sqrt(4.95 / 5.5))
    gains = tuple(pd_pole_placement(a, w, 0.8, 0.1) for a, w in zip(axes, omegas, strict=True))
    stage = Stage(
        "xy_servo_coulomb", axes, (Contour((0, 1)),), ts=1e-3, substeps=2, in_position=1e-5,
        notes="004 tables 4.1/4.2: J, B, F_c, K_t per axis (published; Y's K_t blank, taken "
        "equal to X's). Lead 10 mm, a 1 ms first-order current loop in place of the PI "
        "current controller, u_max 10 A, Ts 1 ms and the 60 rad/s loop scale are chosen. Rig: "
        "1 um per count (2500-line encoder x4 on the 10 mm lead, chosen), one-tick "
        "computation delay.",
    )  # fmt: skip
    kp = gains[0].kp
    return Preset(
        "xy_servo_coulomb", "004", stage, gains, CCCGains(kp=kp, ki=kp * 10.0),
        path="circle_r20", feedrate=2.0 * math.pi * 0.02 / 2.57, accel=0.5, max_feedrate=0.1,
        notes="004 table 4.3: R = 20 mm circle in 2.57 s at constant speed.",
    )  # fmt: skip


@dataclass(frozen=True)
class PresetEntry:
    """A registered preset: its name and a builder (presets are built on demand)."""

    name: str
    build: Callable[[], Preset] = field(repr=False)


PRESETS: Registry[PresetEntry] = Registry("plant preset")


def register_preset(
    name: str, preset: Preset | Callable[[], Preset], *, replace: bool = False
) -> None:
    """Register a machine under ``name``: a :class:`Preset` or a function building one.

    Raises:
        ValueError: for a taken name (unless ``replace``) or a builder whose preset has
            another name.
    """
    build = preset if callable(preset) and not isinstance(preset, Preset) else (lambda: preset)
    PRESETS.register(PresetEntry(name, build), replace=replace)


def get_preset(name: str) -> Preset:
    """Return the preset called ``name``; unknown names raise ValueError listing them."""
    preset = PRESETS.get(name).build()
    if not isinstance(preset, Preset):
        raise ValueError(f"preset builder {name!r} returned {type(preset).__name__}, not Preset")
    return preset


def resolve_preset(plant: str | Preset | Mapping[str, Any]) -> Preset:
    """A preset from a name, a :class:`Preset`, or ``{"preset": name, **overrides}``.

    Raises:
        ValueError: for an unknown name or field, or an override its dataclass rejects.
    """
    if isinstance(plant, Preset):
        return plant
    if isinstance(plant, str):
        return get_preset(plant)
    if isinstance(plant, Mapping):
        changes = dict(plant)
        base = changes.pop("preset", None)
        if not isinstance(base, str):
            raise ValueError("a plant dict needs 'preset': the name of the preset it overrides")
        return override(get_preset(base), changes)
    raise ValueError(f"plant must be a preset name, a Preset or a dict, got {plant!r}")


def override(obj: Any, changes: Any, where: str = "plant") -> Any:
    """``obj`` with ``changes`` applied: dict -> dataclass fields, recursively (see module doc).

    Tuples of dataclasses take a dict keyed by an item's ``name`` or index.
    """
    if not isinstance(changes, Mapping):
        return changes
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        names = {f.name for f in dataclasses.fields(obj)}
        unknown = sorted(set(changes) - names)
        if unknown:
            raise ValueError(f"unknown field(s) {unknown} of {where}; accepted: {sorted(names)}")
        new = {k: override(getattr(obj, k), v, f"{where}.{k}") for k, v in changes.items()}
        return dataclasses.replace(obj, **new)
    if isinstance(obj, tuple):
        items = list(obj)
        keys = {getattr(x, "name", None): i for i, x in enumerate(items)}
        for key, value in changes.items():
            i = key if isinstance(key, int) else keys.get(key)
            if i is None or not 0 <= i < len(items):
                raise ValueError(f"{where} has no item {key!r}; items: {list(keys)}")
            items[i] = override(items[i], value, f"{where}[{key!r}]")
        return tuple(items)
    raise ValueError(f"{where} cannot take a dict of overrides")


for _name, _builder in (
    ("xy_dc_servo", _xy_dc_servo),
    ("xyz_pmlsm", _xyz_pmlsm),
    ("lugre_linear_motor", _lugre_linear_motor),
    ("xyy_gantry", _xyy_gantry),
    ("xy_servo_coulomb", _xy_servo_coulomb),
):
    register_preset(_name, _builder)
