"""Convenience API: run one scenario of a preset and get its contouring metrics."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from contour_gym._validate import positive
from contour_gym.ccc import CCCGains
from contour_gym.loop import ServoLoop, Trace
from contour_gym.metrics import member_metrics
from contour_gym.motion import Interpolator
from contour_gym.paths import Path, load
from contour_gym.plant import Preset, get_preset


@dataclass(frozen=True)
class Scenario:
    """A preset on a path at a feedrate: what :func:`simulate` and the envs run.

    Attributes:
        preset: The machine and its servo settings.
        path: The contour.
        feedrate: Commanded feedrate, m/s.
    """

    preset: Preset
    path: Path
    feedrate: float

    def interpolator(self, feedrate: float | None = None) -> Interpolator:
        """The interpolator at ``feedrate`` (default: the scenario's)."""
        return Interpolator(self.feedrate if feedrate is None else feedrate, self.preset.accel)

    def loop(
        self, *, batch_size: int = 1, ccc_gains: object = None, record: bool = False, **kwargs: Any
    ) -> ServoLoop:
        """A :class:`ServoLoop` of this scenario; ``kwargs`` go to :class:`ServoLoop`."""
        return ServoLoop(
            self.preset.stage,
            self.path,
            self.preset.axis_gains,
            self.interpolator(),
            batch_size=batch_size,
            ccc_gains=ccc_gains,  # type: ignore[arg-type]
            record=record,
            **kwargs,
        )


def make_scenario(
    plant: str | Preset = "xy_dc_servo",
    path: str | Path | None = None,
    feedrate: float | None = None,
) -> Scenario:
    """Resolve a plant preset, a path and a feedrate into a :class:`Scenario`.

    Args:
        plant: Preset name or :class:`Preset`.
        path: Library path name, a :class:`Path`, or None for the preset's paper path.
        feedrate: m/s; None for the preset's feedrate.

    Returns:
        The scenario.

    Raises:
        ValueError: for unknown names, a path whose dimension does not match the stage, or
            a non-positive feedrate.
    """
    preset = get_preset(plant) if isinstance(plant, str) else plant
    if not isinstance(preset, Preset):
        raise ValueError(f"plant must be a preset name or Preset, got {plant!r}")
    resolved = load(preset.path if path is None else path) if not isinstance(path, Path) else path
    if resolved.dim != preset.stage.dim:
        raise ValueError(
            f"path {resolved.name!r} is {resolved.dim}-D but plant {preset.name!r} draws "
            f"{preset.stage.dim}-D contours"
        )
    rate = preset.feedrate if feedrate is None else positive(feedrate, "feedrate")
    return Scenario(preset, resolved, rate)


def simulate(
    plant: str | Preset = "xy_dc_servo",
    path: str | Path | None = None,
    ccc_gains: CCCGains | Sequence[float] | None = None,
    feedrate: float | None = None,
    seed: int = 0,
    **loop_options: Any,
) -> dict[str, float]:
    """Run one contour on one machine and return its metrics (SI units).

    Args:
        plant: Preset name (``contour_gym.plant.PRESETS``) or :class:`Preset`.
        path: Library name, :class:`Path`, or None for the preset's paper path.
        ccc_gains: None for no CCC, or PID CCC gains ``(kp, ki, kd)``.
        feedrate: m/s; None for the preset's.
        seed: Seed of the random disturbances and measurement noise.
        **loop_options: Passed to :class:`ServoLoop` (``axis_controller``, ``estimator``,
            their options, ``ccc_weights``).

    Returns:
        ``max_contour_error``, ``mean_contour_error``, ``rms_contour_error`` (m),
        ``cycle_time`` (s), ``cea``, ``p_e``, ``p_eps`` (m), ``chattering``, and ``failed``
        (1.0 if the loop diverged, when the error metrics are inf).
    """
    loop = _run(make_scenario(plant, path, feedrate), ccc_gains, seed, record=False, **loop_options)
    return {**member_metrics(loop.metrics(), 0), "failed": float(loop.failed[0])}


def run_trace(
    scenario: Scenario, ccc_gains: object, seed: int = 0, **loop_options: Any
) -> tuple[dict[str, float], Trace]:
    """Run a scenario recording every tick; returns (metrics, trace)."""
    loop = _run(scenario, ccc_gains, seed, record=True, **loop_options)
    return member_metrics(loop.metrics(), 0), loop.trace()


def _run(
    scenario: Scenario, ccc_gains: object, seed: int, *, record: bool, **kwargs: Any
) -> ServoLoop:
    loop = scenario.loop(ccc_gains=ccc_gains, record=record, **kwargs)
    loop.reset(seed)
    loop.run()
    return loop


__all__ = ["Scenario", "make_scenario", "run_trace", "simulate"]
