"""Convenience API: run one scenario of a machine and get its contouring metrics."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from contour_gym._validate import positive
from contour_gym.ccc import CCCGains
from contour_gym.loop import LoopOptions, ServoLoop, Trace
from contour_gym.metrics import member_metrics
from contour_gym.motion import Interpolator
from contour_gym.paths import Path, load
from contour_gym.presets import Preset, resolve_preset

PlantSpec = str | Preset | Mapping[str, Any]


@dataclass(frozen=True)
class Scenario:
    """A machine on a path at a feedrate, with its loop options: what simulate and envs run.

    Attributes:
        preset: The machine and its servo settings.
        path: The contour (a G-code part already mapped onto the machine's axes).
        feedrate: Nominal (programmed cutting) feedrate, m/s.
        options: Loop options (:class:`~contour_gym.loop.LoopOptions` fields) every loop of
            this scenario gets unless a call overrides them.
        feed_override: Fraction of the programmed feeds the loops start at.
    """

    preset: Preset
    path: Path
    feedrate: float
    options: dict[str, Any] = field(default_factory=dict)
    feed_override: float = 1.0

    def interpolator(self, feedrate: float | None = None) -> Interpolator:
        """The interpolator at ``feedrate`` (default: the scenario's) with the machine's limits."""
        p = self.preset
        return Interpolator(
            self.feedrate if feedrate is None else feedrate, p.accel, p.jerk, p.max_feedrate,
            p.rapid_rate,
        )  # fmt: skip

    def loop(
        self, *, batch_size: int = 1, ccc_gains: object = None, record: bool = False, **kwargs: Any
    ) -> ServoLoop:
        """A :class:`ServoLoop` of this scenario; ``kwargs`` are loop options overriding ours."""
        options = {**self.options, **kwargs}
        loop = ServoLoop(
            self.preset.stage, self.path, self.preset.axis_gains, self.interpolator(),
            batch_size=batch_size, ccc_gains=ccc_gains, record=record, **options,  # type: ignore[arg-type]
        )  # fmt: skip
        if self.feed_override != 1.0:
            loop.set_feed_override(self.feed_override)
        return loop


def _programmed_feedrate(path: Path) -> float | None:
    feeds = getattr(path, "segment_feedrates", None)
    cutting = getattr(path, "cutting", None)
    if feeds is None:
        return None
    chosen = feeds[cutting] if cutting is not None and cutting.any() else feeds
    chosen = chosen[~(chosen != chosen)]  # drop NaN
    return float(chosen.max()) if chosen.size else None


def _on_machine(path: Path, preset: Preset) -> Path:
    dim = preset.stage.dim
    if path.dim == dim:
        return path
    for_machine = getattr(path, "for_machine", None)
    if for_machine is None:
        raise ValueError(
            f"path {path.name!r} is {path.dim}-D but plant {preset.name!r} draws {dim}-D contours"
        )
    rapid = preset.rapid_rate or (preset.max_feedrate if math.isfinite(preset.max_feedrate)
                                  else 10.0 * preset.feedrate)  # fmt: skip
    return for_machine(dim, rapid_rate=rapid)


def make_scenario(
    plant: PlantSpec = "xy_dc_servo",
    path: str | Path | None = None,
    feedrate: float | None = None,
    *,
    feedrate_override: float | None = None,
    **options: Any,
) -> Scenario:
    """Resolve a machine, a path and a feedrate into a :class:`Scenario`.

    Args:
        plant: Preset name, :class:`Preset`, or ``{"preset": name, **overrides}``.
        path: Library path name, a :class:`Path` (G-code parts are mapped onto the machine's
            axes), or None for the preset's paper path.
        feedrate: m/s; None for a G-code part's own F words (the highest cutting one is the
            nominal), else the preset's feedrate. Given for a G-code part, it replaces its
            F words.
        feedrate_override: Fraction of the programmed feeds to run at (a CNC panel's override).
        **options: Loop options (:class:`~contour_gym.loop.LoopOptions`), e.g. ``ideal=True``;
            ``ccc_injection`` defaults to the preset's.

    Returns:
        The scenario.

    Raises:
        ValueError: for unknown names or options, a path whose dimension does not match the
            machine, or a non-positive feedrate.
    """
    preset = resolve_preset(plant)
    resolved = load(preset.path if path is None else path) if not isinstance(path, Path) else path
    resolved = _on_machine(resolved, preset)
    programmed = _programmed_feedrate(resolved) if feedrate is None else None
    given = None if feedrate is None else positive(feedrate, "feedrate")
    rate = given or programmed or preset.feedrate
    if feedrate is not None:
        options.setdefault("use_program_feeds", False)
    override = 1.0
    if feedrate_override is not None:
        override = positive(feedrate_override, "feedrate_override")
    if rate * override > preset.max_feedrate:
        warnings.warn(
            f"feedrate {rate * override:.4g} m/s exceeds {preset.name}'s machine limit "
            f"{preset.max_feedrate:.4g} m/s; the interpolator caps it, as a CNC does",
            stacklevel=2,
        )
    unknown = sorted(set(options) - set(LoopOptions.__dataclass_fields__))
    if unknown:
        raise ValueError(f"unknown option(s) {unknown}; accepted: "
                         f"{', '.join(sorted(LoopOptions.__dataclass_fields__))}")
    options.setdefault("ccc_injection", preset.ccc_injection)
    return Scenario(preset, resolved, rate, options, override)


def simulate(
    plant: PlantSpec = "xy_dc_servo",
    path: str | Path | None = None,
    ccc_gains: CCCGains | Sequence[float] | None = None,
    feedrate: float | None = None,
    seed: int = 0,
    **options: Any,
) -> dict[str, float]:
    """Run one contour on one machine and return its metrics (SI units).

    Args:
        plant: Preset name, :class:`Preset`, or ``{"preset": name, **overrides}``.
        path: Library name, :class:`Path`, or None for the preset's paper path.
        ccc_gains: None for no CCC, or CCC gains ``(kp, ki, kd)``.
        feedrate: m/s; None for the preset's (or a G-code part's own F words).
        seed: Seed of the random disturbances and measurement noise.
        **options: ``feedrate_override`` and loop options (:class:`~contour_gym.loop.LoopOptions`:
            ``ideal``, ``axis_controller``, ``estimator``, their options, ``ccc_injection``,
            ``path_control``, ...); ``ccc_weights``.

    Returns:
        ``max_contour_error``, ``mean_contour_error``, ``rms_contour_error`` (m),
        ``cycle_time`` (s, until in position at the end), ``cea``, ``p_e``, ``p_eps`` (m),
        ``chattering``, ``failed`` (1.0 if the loop diverged or never got in position, when
        the error metrics are inf) and ``finished`` (1.0 when in position at the end).

    >>> m = simulate("xy_dc_servo", ideal=True)  # 000's servo on its 10 mm circle, no CCC
    >>> round(m["max_contour_error"] * 1e6, 2), m["finished"]
    (17.88, 1.0)
    """
    loop = _run(_scenario(plant, path, feedrate, options), ccc_gains, seed, False, options)
    return {**member_metrics(loop.metrics(), 0), "failed": float(loop.failed[0]),
            "finished": float(loop.done[0])}  # fmt: skip


def run_trace(
    scenario: Scenario, ccc_gains: object, seed: int = 0, **options: Any
) -> tuple[dict[str, float], Trace]:
    """Run a scenario recording every tick; returns (metrics, trace)."""
    loop = _run(scenario, ccc_gains, seed, True, options)
    return member_metrics(loop.metrics(), 0), loop.trace()


def _scenario(
    plant: PlantSpec, path: str | Path | None, feedrate: float | None, options: dict[str, Any]
) -> Scenario:
    scenario_keys = set(LoopOptions.__dataclass_fields__) | {"feedrate_override"}
    picked = {k: options.pop(k) for k in list(options) if k in scenario_keys}
    return make_scenario(plant, path, feedrate, **picked)


def _run(
    scenario: Scenario, ccc_gains: object, seed: int, record: bool, options: dict[str, Any]
) -> ServoLoop:
    loop = scenario.loop(ccc_gains=ccc_gains, record=record, **options)
    loop.reset(seed)
    loop.run()
    return loop


__all__ = ["Scenario", "make_scenario", "run_trace", "simulate"]
