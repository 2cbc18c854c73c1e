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

from contour_gym.api import make_scenario
from contour_gym.logs import AxisLog, ServoLog
from contour_gym.paths import GcodePath, Path, circle, composite, load, random_path
from contour_gym.plant.friction import law_for
from contour_gym.presets import Preset, resolve_preset

SCALED = ("mass", "damping", "force_constant")  # the axis fields a hidden machine scales
RADIUS = 0.01  # the circle test's radius, m
BOX = 0.03  # a random path is drawn within +-BOX of the circle's start, m


def perturbed_plant(
    preset: str, rng: np.random.Generator, low: float = 0.6, high: float = 1.6
) -> dict[str, Any]:
    """A hidden machine: ``preset`` with each axis parameter scaled by a factor in [low, high].

    Scaled: :data:`SCALED` and every positive friction parameter but a Stribeck exponent (the
    static force keeps its excess over the Coulomb force, scaled by its own factor). Axes that
    drive the same coordinate (a gantry's two motors on one beam) share their factors.

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


def excitation(preset: Preset, rng: np.random.Generator, seconds: float = 30.0) -> GcodePath:
    """The recording a user makes to identify ``preset``'s machine, about ``seconds`` long.

    A 2-D machine: a circle of :data:`RADIUS` at half its feedrate, then at its feedrate (laps
    enough for two thirds of the time), then a random path from the circle's start at its
    feedrate; a 3-D one: its paper path at the two feeds, the second from where the first
    ends. Each part ends at rest.
    """
    feed = preset.feedrate
    if preset.stage.dim == 3:
        first = load(preset.path)
        second = first.transformed(offset=first.point(first.length) - first.point(0.0))
        return _program([(first, 0.5 * feed), (second, feed)], "excitation")
    ring = circle(RADIUS)
    start = ring.point(0.0)
    laps = max(1, math.ceil(seconds / 3.0 / (ring.length / feed)))  # each feed a third
    tail = random_path(rng, within=[[-BOX, BOX], [-BOX, BOX]],
                       length=min(feed * seconds / 3.0, 4.0 * BOX))
    tail = tail.transformed(offset=start - tail.point(0.0))
    return _program([(ring.repeat(laps), 0.5 * feed), (ring.repeat(laps), feed), (tail, feed)],
                    "excitation")


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
        path: The recording's path (its feeds: :func:`excitation`).
        seed: Seed of the machine's noise and disturbances and of the feedback's noise.
        ideal: Without encoder, noise or delay (the feedback is then the true position).

    Returns:
        The log: ``cmd`` the reference, ``fb`` the encoder's reading of the position
        (quantised to the axis's ``encoder_resolution``, plus its ``noise_std``), ``effort``
        the control signal, one row per servo tick until the run ends.
    """
    scenario = make_scenario(plant, path, ideal=ideal)
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
            q = axis.encoder_resolution
            fb = q * np.round(x / q) if q > 0.0 else fb
            fb = fb + axis.noise_std * rng.standard_normal(rows) if axis.noise_std else fb
        axes.append(AxisLog(axis.name, cmd=trace.r[0, :rows, a], fb=fb,
                            effort=trace.u[0, :rows, a]))
    source = f"{scenario.preset.name} on {path.name}"
    return ServoLog(trace.t[:rows].copy(), tuple(axes), source=source)


__all__ = ["excitation", "machine_log", "perturbed_plant"]
