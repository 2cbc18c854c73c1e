"""Convenience API: run one scenario of a machine and get its contouring metrics."""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from contour_gym._validate import positive
from contour_gym.ccc import CCC_LAWS, CCCGains
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
        laps: Times ``path`` traces the closed contour it was built from (already repeated).
    """

    preset: Preset
    path: Path
    feedrate: float
    options: dict[str, Any] = field(default_factory=dict)
    feed_override: float = 1.0
    laps: int = 1

    def interpolator(self, feedrate: float | None = None) -> Interpolator:
        """The interpolator at ``feedrate`` (default: the scenario's) with the machine's limits."""
        p = self.preset
        return Interpolator(
            self.feedrate if feedrate is None else feedrate, p.accel, p.jerk, p.max_feedrate,
            p.rapid_rate, p.time_constant, self.feed_override,
        )

    def loop(
        self, *, batch_size: int = 1, ccc_gains: Any = None, record: bool = False,
        ccc_weights: Any = None, threads: int | None = 1, **kwargs: Any,
    ) -> ServoLoop:
        """A :class:`ServoLoop` of this scenario; ``kwargs`` are loop options overriding ours.

        ``ccc_weights`` None: the preset's; ``threads``: :class:`ServoLoop`'s. The CCC law's
        parameters are those it runs with on this machine (:func:`machine_law_params`).
        """
        options = _merged_controller(
            self.options["axis_controller"], self.options.get("controller_options") or {},
            {**self.options, **kwargs}, kwargs,
        )
        options["ccc_law_params"] = machine_law_params(
            self.preset, options.get("ccc_law", "pid"), options.get("ccc_law_params"))
        loop = ServoLoop(
            self.preset.stage, self.path, self.preset.axis_gains, self.interpolator(),
            batch_size=batch_size, ccc_gains=ccc_gains, record=record,
            ccc_weights=self.preset.ccc_weights if ccc_weights is None else ccc_weights,
            threads=threads, **options,
        )
        if self.feed_override != 1.0:
            loop.set_feed_override(self.feed_override)
        return loop


def machine_law_params(
    preset: Preset, law: str, given: Mapping[str, Any] | None
) -> dict[str, float]:
    """A CCC law's parameters beyond kp, ki, kd on ``preset``'s machine.

    ``given`` are the loop option ``ccc_law_params``: values in the law's units, used as they
    are, unless it holds ``"machine"``: a preset (or its name) they were set on, from which
    they carry to this machine in proportion to the law's units (a tuned factor set of paper
    000's law on another machine). What is not given takes the law's default for this
    machine (:meth:`~contour_gym.ccc.CCCLaw.params_for`).

    Raises:
        ValueError: for an unknown law, or ``"machine"`` for a law without machine units.
    """
    values = dict(given or {})
    set_on = values.pop("machine", None)
    return CCC_LAWS.get(law).params_for(preset, values, set_on)


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
                                  else 10.0 * preset.feedrate)
    return for_machine(dim, rapid_rate=rapid)


def make_scenario(
    plant: PlantSpec = "xy_dc_servo",
    path: str | Path | None = None,
    feedrate: float | None = None,
    *,
    feedrate_override: float | None = None,
    laps: int | None = None,
    **options: Any,
) -> Scenario:
    """Resolve a machine, a path and a feedrate into a :class:`Scenario`.

    The preset's paper settings are the defaults: its estimator, axis controller (with its
    options) and CCC injection, unless ``options`` name others.

    Args:
        plant: Preset name, :class:`Preset`, or ``{"preset": name, **overrides}``.
        path: Library path name, a :class:`Path` (G-code parts are mapped onto the machine's
            axes; a Path runs at the preset's ``part_accel`` where it has one), or None for
            the preset's paper path.
        feedrate: m/s; None for a G-code part's own F words (the highest cutting one is the
            nominal), else the preset's feedrate. Given for a G-code part, it replaces its
            F words; given for a path with a time law, it scales the law's time so that its
            mean speed is ``feedrate``.
        feedrate_override: Fraction of the programmed feeds to run at (a CNC panel's override;
            on a time-law path, the rate at which the law's time runs).
        laps: Times to trace a closed path (None: the preset's ``laps`` on its own path, else 1).
        **options: Loop options (:class:`~contour_gym.loop.LoopOptions`), e.g. ``ideal=True``.

    Returns:
        The scenario.

    Raises:
        ValueError: for unknown names or options, a path whose dimension does not match the
            machine, a non-positive feedrate, or laps of an open path.
    """
    preset = _for_path(resolve_preset(plant), path)
    resolved, laps = _scenario_path(preset, path, laps)
    override = 1.0
    if feedrate_override is not None:
        override = positive(feedrate_override, "feedrate_override")
    given = None if feedrate is None else positive(feedrate, "feedrate")
    if given is not None and resolved.time_law is None:
        options.setdefault("use_program_feeds", False)  # the given feed replaces the F words
    rate, override = _nominal_feedrate(preset, resolved, given, override)
    _check_loop_options(options)
    return Scenario(preset, resolved, rate, _with_paper_options(preset, options), override, laps)


def _for_path(preset: Preset, path: str | Path | None) -> Preset:
    """``preset`` as it runs ``path``: a user's :class:`Path` at its ``part_accel``."""
    if isinstance(path, Path) and preset.part_accel is not None and math.isinf(preset.accel):
        return replace(preset, accel=preset.part_accel)
    return preset


def _scenario_path(preset: Preset, path: str | Path | None, laps: int | None) -> tuple[Path, int]:
    """The path on the machine's axes, repeated ``laps`` times, and the laps.

    None: the preset's paper path, with its laps; laps default to 1 on any other path.
    """
    resolved = load(preset.path if path is None else path) if not isinstance(path, Path) else path
    own = path is None or path == preset.path
    if laps is None:
        laps = preset.laps if own else 1
    return _on_machine(resolved, preset).repeat(laps), laps


def _nominal_feedrate(
    preset: Preset, path: Path, given: float | None, override: float
) -> tuple[float, float]:
    """The scenario's nominal feedrate and feed override (see :func:`make_scenario`).

    On a time-law path the nominal is the law's mean speed and ``given`` scales the override;
    else ``given``, the part's highest cutting F word or the preset's feedrate. Warns when the
    commanded feedrate exceeds the machine's limit.
    """
    if path.time_law is not None:
        rate = path.time_law.mean_speed()
        return rate, override * (1.0 if given is None else given / rate)
    rate = given or _programmed_feedrate(path) or preset.feedrate
    if rate * override > preset.max_feedrate * (1.0 + 1e-9):  # not for a rounding's ulp
        warnings.warn(
            f"feedrate {rate * override:.4g} m/s exceeds {preset.name}'s machine limit "
            f"{preset.max_feedrate:.4g} m/s; the interpolator caps it, as a CNC does",
            stacklevel=3,
        )
    return rate, override


def _check_loop_options(options: Mapping[str, Any]) -> None:
    """Raise ValueError naming the keys of ``options`` that are no :class:`LoopOptions` field."""
    unknown = sorted(set(options) - set(LoopOptions.__dataclass_fields__))
    if unknown:
        raise ValueError(f"unknown option(s) {unknown}; accepted: "
                         f"{', '.join(sorted(LoopOptions.__dataclass_fields__))}")


def _with_paper_options(preset: Preset, options: Mapping[str, Any]) -> dict[str, Any]:
    """``options`` with the preset's paper settings filling what they leave open."""
    out = {"ccc_injection": preset.ccc_injection, "estimator": preset.estimator, **options}
    return _merged_controller(preset.axis_controller, preset.controller_options, out, options)


def _merged_controller(
    name: str, base: Mapping[str, Any], out: dict[str, Any], given: Mapping[str, Any]
) -> dict[str, Any]:
    """Put the axis controller and its options into ``out``.

    Controller ``name`` with options ``base`` unless ``given`` names another controller;
    ``given``'s own controller options update ``base`` for the same controller.
    """
    mine = given.get("controller_options") or {}
    if given.get("axis_controller", name) == name:
        out["axis_controller"], out["controller_options"] = name, {**base, **mine}
    else:
        out["controller_options"] = dict(mine)
    return out


def _scenario(
    plant: PlantSpec, path: str | Path | None, feedrate: float | None, options: dict[str, Any]
) -> Scenario:
    scenario_keys = set(LoopOptions.__dataclass_fields__) | {"feedrate_override", "laps"}
    picked = {k: options.pop(k) for k in list(options) if k in scenario_keys}
    return make_scenario(plant, path, feedrate, **picked)


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
        ``chattering``, ``failed`` (1.0 if the loop diverged, never got in position or ran out
        of time; the error metrics are inf when it diverged), ``failure_reason`` (its code:
        :attr:`ServoLoop.failure_reason`) and ``finished`` (1.0 when in position at the end).

    >>> m = simulate("xy_dc_servo", ideal=True)  # 000's servo on its 10 mm circle, no CCC
    >>> round(m["max_contour_error"] * 1e6, 1), m["finished"]  # 000 reports 49 um
    (50.6, 1.0)
    """
    loop = run_scenario(_scenario(plant, path, feedrate, options), ccc_gains, seed, **options)
    return {**member_metrics(loop.metrics(), 0), **_outcome(loop)}


def _outcome(loop: ServoLoop) -> dict[str, float]:
    # failed, its reason's code (ServoLoop.failure_reason) and finished, of member 0
    return {"failed": float(loop.failed[0]), "failure_reason": float(loop.failure_reason[0]),
            "finished": float(loop.done[0])}


def run_trace(
    scenario: Scenario, ccc_gains: object, seed: int = 0, **options: Any
) -> tuple[dict[str, float], Trace]:
    """Run a scenario recording every tick; returns (metrics, trace)."""
    loop = run_scenario(scenario, ccc_gains, seed, record=True, **options)
    return {**member_metrics(loop.metrics(), 0), **_outcome(loop)}, loop.trace()


def run_scenario(
    scenario: Scenario, ccc_gains: object = None, seed: int = 0, *, record: bool = False,
    max_time: float | None = None, **options: Any,
) -> ServoLoop:
    """Run one member of ``scenario`` from ``seed`` to its end; returns the finished loop.

    ``options`` override the scenario's loop options; ``loop.metrics()`` holds the run's
    metrics (per-contour arrays included) and, with ``record``, ``loop.trace()`` every tick.
    ``max_time`` caps the simulated time (:meth:`ServoLoop.run`; a member still running then
    has failed, reason 4).
    """
    if max_time is not None:
        positive(max_time, "max_time")
    loop = scenario.loop(ccc_gains=ccc_gains, record=record, **options)
    loop.reset(seed)
    loop.run(max_time=max_time)
    return loop


__all__ = [
    "Scenario", "machine_law_params", "make_scenario", "run_scenario", "run_trace", "simulate",
]
