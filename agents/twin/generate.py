"""Test logs: a preset's machine with hidden, perturbed parameters, run on an exciting path.

:func:`perturbed_plant` draws the hidden machine (every axis's mass, damping, force constant and
friction parameters scaled by factors in ``[low, high]``), :func:`excitation` the recording a
user would make (a circle at two feeds, then a random path, each ending at rest), and
:func:`machine_log` records it as a :class:`~contour_gym.logs.ServoLog`: the reference as the
command, the encoder's reading (quantised, with the axis's noise) as the feedback and the
control signal as the effort, every servo tick.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym.api import make_scenario
from contour_gym.logs import AxisLog, ServoLog
from contour_gym.paths import GcodePath, Path, circle, composite, helix, random_path
from contour_gym.plant.friction import law_for
from contour_gym.presets import Preset, resolve_preset

SCALED = ("mass", "damping", "force_constant")  # the axis fields a hidden machine scales
RADIUS = 0.01  # the circle test's radius, m
ACCEL = 2.0  # the largest acceleration round the circle at the faster feed (chosen), m/s^2
PITCH = 0.001  # a 3-D machine's circles advance this much per lap, m
BOX = 0.03  # a random path is drawn within +-BOX of the circle's start, m


def perturbed_plant(
    preset: str, rng: np.random.Generator, low: float = 0.6, high: float = 1.6
) -> dict[str, Any]:
    """A hidden machine: ``preset`` with each axis parameter scaled by a factor in [low, high].

    Scaled: :data:`SCALED`, every positive friction parameter but a Stribeck exponent (the
    static force keeps its excess over the Coulomb force, scaled by its own factor) and the
    force ripple's amplitudes (by one factor, drawn after every other). Axes that drive the
    same coordinate (a gantry's two motors on one beam) share their factors.

    Returns:
        The plant dict (``{"preset": preset, "stage": {"axes": {...}}}``, a machine file's).
    """
    base = resolve_preset(preset)
    drawn: dict[int, dict[str, float]] = {}
    axes: dict[str, Any] = {}
    for a, axis in enumerate(base.stage.axes):
        factors = drawn.setdefault(_coordinate(base, a), _factors(axis, rng, low, high))
        changes: dict[str, Any] = {k: getattr(axis, k) * factors[k] for k in SCALED}
        if axis.friction is not None:
            changes["friction"] = _scaled_friction(axis.friction, factors)
        axes[axis.name] = changes
    ripples: dict[int, float] = {}
    for a, axis in enumerate(base.stage.axes):
        if axis.ripple is not None:
            level = ripples.setdefault(_coordinate(base, a), float(rng.uniform(low, high)))
            axes[axis.name]["ripple"] = axis.ripple.scaled(level)
    return {"preset": preset, "name": f"{preset}_hidden", "stage": {"axes": axes}}


def _coordinate(preset: Preset, axis: int) -> int:
    # the contour coordinate an axis drives (its index in the first contour that has it)
    return next(c.axes.index(axis) for c in preset.stage.contours if axis in c.axes)


def _factors(axis: Any, rng: np.random.Generator, low: float, high: float) -> dict[str, float]:
    names = [*SCALED, *(dataclasses.asdict(axis.friction) if axis.friction else {})]
    return {name: float(rng.uniform(low, high)) for name in names}


def _scaled_friction(model: Any, factors: dict[str, float]) -> dict[str, Any]:
    fields = dataclasses.asdict(model)
    out: dict[str, Any] = {"law": law_for(model).name, **fields}
    for key, value in fields.items():
        if isinstance(value, float) and value > 0.0 and key not in ("delta", "fs"):
            out[key] = value * factors[key]
    if isinstance(fields.get("fs"), float) and isinstance(fields.get("fc"), float):
        out["fs"] = out["fc"] + (fields["fs"] - fields["fc"]) * factors["fs"]
    return out


def excitation_feeds(preset: Preset) -> tuple[float, float]:
    """The circle test's two feeds on ``preset``'s machine, m/s.

    Half its feedrate and its feedrate, or a quarter and half of its largest feedrate where
    those are faster (chosen: a machine with a strong disturbance, 001's 2 N on a 4 kg axis,
    shows its inertia only at accelerations its paper's slow feed does not reach); a machine
    without a largest feed: half its feedrate and its feedrate.
    """
    top = preset.max_feedrate if math.isfinite(preset.max_feedrate) else preset.feedrate
    return max(0.5 * preset.feedrate, 0.25 * top), max(preset.feedrate, 0.5 * top)


def excitation(preset: Preset, rng: np.random.Generator, seconds: float = 30.0) -> GcodePath:
    """The recording a user makes to identify ``preset``'s machine, about ``seconds`` long.

    A circle of :data:`RADIUS` (larger where the faster feed would pull more than
    :data:`ACCEL`, or the machine's acceleration limit, round it; smaller where the travel
    ends nearer, the feeds then lowered to that acceleration) at each of
    :func:`excitation_feeds`; a 2-D machine then runs a random path at the faster feed (a third
    of the time each); a 3-D one runs its circles in the X-Y, Y-Z and Z-X planes (helices of
    :data:`PITCH` per lap, a sixth of the time each).
    Each part ends at rest.
    """
    slow, fast = excitation_feeds(preset)
    accel = min(ACCEL, preset.accel, preset.part_accel or math.inf)
    radius = min(max(RADIUS, fast**2 / accel), 0.5 * _room(preset))
    slow, fast = (min(f, math.sqrt(accel * radius)) for f in (slow, fast))
    if preset.stage.dim == 3:
        return _program(_planes(radius, slow, fast, seconds / 6.0), "excitation")
    ring = circle(radius)
    start = ring.point(0.0)
    box = max(BOX, 0.5 * radius)
    tail = random_path(rng, within=[[-box, box], [-box, box]],
                       length=min(fast * seconds / 3.0, 4.0 * box))
    tail = tail.transformed(offset=start - tail.point(0.0))
    parts = [(ring.repeat(_laps(ring, feed, seconds / 3.0)), feed) for feed in (slow, fast)]
    return _program([*parts, (tail, fast)], "excitation")


def _room(preset: Preset) -> float:
    # the least distance from the path's origin to an end of an axis's travel, m
    limits = [min(hi - off, off - lo) for _, _, off, (lo, hi)
              in preset.stage.limited_coordinates()]
    return min(limits, default=math.inf)


def _laps(ring: Path, feed: float, seconds: float) -> int:
    return max(1, math.ceil(seconds / (ring.length / feed)))


def _planes(radius: float, slow: float, fast: float, seconds: float) -> list[tuple[Path, float]]:
    # circles (flat helices) in the X-Y, Y-Z and Z-X planes at each feed, joined end to start
    turns = (np.eye(3), np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
             np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]))
    parts: list[tuple[Path, float]] = []
    end = np.zeros(3)
    for feed in (slow, fast):
        laps = _laps(circle(radius), feed, seconds)
        for rotation in turns:
            coil = helix(radius, PITCH, float(laps))
            if parts:
                coil = coil.transformed(rotation=rotation,
                                        offset=end - rotation @ coil.point(0.0))
            parts.append((coil, feed))
            end = coil.point(coil.length)
    return parts


def _program(parts: list[tuple[Path, float]], name: str) -> GcodePath:
    # the parts joined, each at its feed and ending at rest (as separate G1 blocks would)
    joined = composite([p for p, _ in parts])
    counts = [p.table.n_segments for p, _ in parts]
    feeds = np.repeat([f for _, f in parts], counts)
    stops = np.zeros(len(feeds), dtype=bool)
    stops[np.cumsum(counts) - 1] = True
    return GcodePath(joined.table, name, feeds, np.arange(1, len(feeds) + 1),
                     np.zeros(len(feeds), dtype=bool), exact_stop=stops)


def machine_log(
    plant: Any, path: Path, seed: int = 0, ideal: bool = False
) -> ServoLog:
    """Run ``plant`` on ``path`` at its feeds and record what the machine's servo log holds.

    Args:
        plant: The machine (a plant spec: :func:`~contour_gym.presets.resolve_preset`).
        path: The recording's path (its feeds: :func:`excitation`), run as the machine's CNC
            runs a part: at its acceleration limit, or :data:`ACCEL` where the preset has
            none (a paper's time-parameterised reference; a real CNC's planner always has one).
        seed: Seed of the machine's noise and disturbances and of the feedback's noise.
        ideal: Without encoder, noise or delay (the feedback is then the true position).

    Returns:
        The log: ``cmd`` the reference, ``fb`` the encoder's reading of the position
        (quantised to the axis's ``encoder_resolution``, plus its ``noise_std``), ``effort``
        the control signal, one row per servo tick until the run ends.
    """
    scenario = make_scenario(_planned(plant), path, ideal=ideal)
    loop = scenario.loop(record=True)
    loop.reset(seed)
    loop.run()
    trace = loop.trace(0)
    rows = int(np.isfinite(trace.x[0, :, 0]).sum())
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    axes = []
    for a, axis in enumerate(scenario.preset.stage.axes):
        x = trace.x[0, :rows, a]
        fb = x.copy()
        if not ideal:
            fb = encoder_reading(x, axis.encoder_resolution)
            fb = fb + axis.noise_std * rng.standard_normal(rows) if axis.noise_std else fb
        axes.append(AxisLog(axis.name, cmd=trace.r[0, :rows, a], fb=fb,
                            effort=trace.u[0, :rows, a]))
    source = f"{scenario.preset.name} on {path.name}"
    return ServoLog(trace.t[:rows].copy(), tuple(axes), source=source)


def _planned(plant: Any) -> Any:
    # ``plant`` with a finite acceleration for its CNC's planner (a user's recording never
    # asks a bend of a random path for hundreds of m/s^2; docs/measurements.md)
    preset = resolve_preset(plant)
    if math.isfinite(preset.accel) or preset.part_accel is not None:
        return plant
    return dataclasses.replace(preset, accel=ACCEL)


def encoder_reading(x: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    """Positions ``x`` as an encoder of ``step`` reads them (the loop's own rounding; 0: exact)."""
    return step * np.floor(x / step + 0.5) if step > 0.0 else x.copy()


__all__ = ["encoder_reading", "excitation", "excitation_feeds", "machine_log", "perturbed_plant"]
