"""Environment arguments: one frozen dataclass, validated, with unknown keys rejected."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from contour_gym._validate import as_finite_array, non_negative, positive
from contour_gym.paths import Path

# Default domain randomisation (``randomize=True``): relative +- spread of mass, damping and
# force constant per axis and episode, and [low, high] scale ranges of friction and
# disturbance levels. 002 section 4.2 shows gain and time-constant mismatch between axes
# is what makes contour error; these ranges are chosen, not published.
DEFAULT_RANDOMIZATION: dict[str, Any] = {
    "mass": 0.1,
    "damping": 0.1,
    "force_constant": 0.1,
    "friction": (0.5, 1.5),
    "disturbance": (0.0, 2.0),
}


@dataclass(frozen=True)
class EnvConfig:
    """Arguments shared by the CCC and feedrate environments (see their docstrings).

    Attributes:
        plant: Preset name (``contour_gym.plant.PRESETS``).
        path: Library path name or :class:`Path` (None: the preset's paper path).
        feedrate: Nominal feedrate, m/s (None: the preset's).
        estimator: Contour error estimator feeding the CCC and the observation.
        estimator_options: Its options.
        axis_controller: Axis controller name.
        controller_options: Its options.
        decision_ticks: Servo ticks per env step (the action is held).
        tolerance: Contour error bound, m; also the observation and reward scale.
        hard_limit: |true contour error| beyond this ends the episode as a failure, m.
        failure_penalty: Reward subtracted on failure.
        randomize: False, True (default ranges) or a dict overriding some ranges.
        lookahead: Arc lengths ahead of the reference where curvature is observed, m.
        ccc_gains: Fixed CCC gains (feedrate env; None: the preset's), (kp, ki, kd).
        gain_range: CCC env: each gain spans [g0 / gain_range, g0 * gain_range] around the
            preset's gains g0 (log scale); kd spans kp0 * [1e-5, 1e-2] s.
        feedrate_range: Feedrate env: (F_min, F_max) as multiples of the nominal feedrate.
        max_feedrate_change: Feedrate env: |dF| per step as a multiple of the nominal.
    """

    plant: str = "xy_dc_servo"
    path: str | Path | None = None
    feedrate: float | None = None
    estimator: str = "ground_truth"
    estimator_options: dict[str, Any] = field(default_factory=dict)
    axis_controller: str = "pid"
    controller_options: dict[str, Any] = field(default_factory=dict)
    decision_ticks: int = 10
    tolerance: float = 1e-5
    hard_limit: float = 2e-3
    failure_penalty: float = 100.0
    randomize: bool | dict[str, Any] = False
    lookahead: tuple[float, ...] = (0.002, 0.005, 0.01)
    ccc_gains: tuple[float, float, float] | None = None
    gain_range: float = 30.0
    feedrate_range: tuple[float, float] = (0.2, 2.0)
    max_feedrate_change: float = 0.1

    def __post_init__(self) -> None:
        if not isinstance(self.decision_ticks, int) or self.decision_ticks < 1:
            raise ValueError(f"decision_ticks must be a positive int, got {self.decision_ticks!r}")
        positive(self.tolerance, "tolerance")
        if positive(self.hard_limit, "hard_limit") <= self.tolerance:
            raise ValueError(f"hard_limit must exceed tolerance, got {self.hard_limit!r}")
        non_negative(self.failure_penalty, "failure_penalty")
        if positive(self.gain_range, "gain_range") <= 1.0:
            raise ValueError(f"gain_range must be > 1, got {self.gain_range!r}")
        as_finite_array(self.lookahead, "lookahead", ndim=1)
        lo, hi = as_finite_array(self.feedrate_range, "feedrate_range", shape=(2,))
        if not 0 < lo < 1 < hi:
            raise ValueError(
                f"feedrate_range must satisfy 0 < low < 1 < high, got {self.feedrate_range!r}"
            )
        positive(self.max_feedrate_change, "max_feedrate_change")
        if self.ccc_gains is not None:
            as_finite_array(self.ccc_gains, "ccc_gains", shape=(3,))
        self.randomization()  # validates

    @classmethod
    def from_kwargs(cls, kwargs: dict[str, Any]) -> EnvConfig:
        """Build from env keyword arguments; unknown keys raise ValueError listing the accepted."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise ValueError(f"unknown argument(s) {unknown}; accepted: {', '.join(sorted(names))}")
        return cls(**kwargs)

    def randomization(self) -> dict[str, Any] | None:
        """The randomisation ranges in force, or None when off."""
        if self.randomize is False:
            return None
        if self.randomize is True:
            return dict(DEFAULT_RANDOMIZATION)
        if not isinstance(self.randomize, dict):
            raise ValueError(f"randomize must be a bool or dict, got {self.randomize!r}")
        unknown = sorted(set(self.randomize) - set(DEFAULT_RANDOMIZATION))
        if unknown:
            raise ValueError(
                f"unknown randomize key(s) {unknown}; accepted: {', '.join(DEFAULT_RANDOMIZATION)}"
            )
        out = {**DEFAULT_RANDOMIZATION, **self.randomize}
        for key in ("mass", "damping", "force_constant"):
            if not 0 <= non_negative(out[key], f"randomize[{key!r}]") < 1:
                raise ValueError(f"randomize[{key!r}] must be in [0, 1), got {out[key]!r}")
        for key in ("friction", "disturbance"):
            lo, hi = as_finite_array(out[key], f"randomize[{key!r}]", shape=(2,))
            if not 0 <= lo <= hi:
                raise ValueError(f"randomize[{key!r}] must be 0 <= low <= high, got {out[key]!r}")
        return out
