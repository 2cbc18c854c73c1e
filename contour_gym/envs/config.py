"""Environment arguments: one frozen dataclass, validated, with unknown keys rejected."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from contour_gym._envstate import OBSERVATIONS
from contour_gym._validate import as_finite_array, choice, finite, non_negative, positive
from contour_gym.api import Scenario, make_scenario
from contour_gym.ccc import INJECTIONS
from contour_gym.envs._paths import (
    RANDOM,
    check_path_options,
    draw_path,
    path_options,
    reset_draws,
)
from contour_gym.motion import PATH_CONTROLS
from contour_gym.paths import Path
from contour_gym.presets import Preset, resolve_preset

if TYPE_CHECKING:
    from contour_gym.tasks.base import Task

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
HARD_LIMIT_TOLERANCES = 100.0  # default hard limit, in tolerances


def draw_plant_scaling(ranges: dict[str, Any], n_axes: int, rng: np.random.Generator
                       ) -> dict[str, NDArray[np.float64]]:
    """One machine drawn from randomisation ``ranges``: ``set_plant_scaling``'s factors.

    Mass, damping and force constant are each scaled by ``1 + U(-r, r)`` per axis, friction
    and disturbance by ``U(low, high)`` (:data:`DEFAULT_RANDOMIZATION`'s keys), drawn from
    ``rng`` in that order.
    """
    shape = (n_axes,)
    factors = {k: 1.0 + rng.uniform(-ranges[k], ranges[k], shape)
               for k in ("mass", "damping", "force_constant")}
    for k in ("friction", "disturbance"):
        factors[k] = rng.uniform(ranges[k][0], ranges[k][1], shape)
    return factors


@dataclass(frozen=True)
class EnvConfig:
    """Arguments shared by the CCC and feedrate environments (see their docstrings).

    Attributes:
        plant: Preset name, or ``{"preset": name, **overrides}`` (``contour_gym.presets``).
        path: Library path name or :class:`Path` (None: the preset's paper path), or
            ``"random"``: each member draws a path of its own at each reset
            (:func:`contour_gym.paths.random_path`, from the member's generator after its
            other draws), within the machine's travel (:mod:`contour_gym.envs._paths`).
        path_options: With ``path="random"``: arguments of :func:`contour_gym.paths.random_path`
            (``family``, ``within``, ``length``, ``feed_range``, ``margin``); the defaults are
            the machine's travel box less 5 % at each end, and for the feedrate task
            ``feed_range`` 0.3 to 1 times the preset's ``max_feedrate`` (its ``feedrate``
            where the machine has no limit).
        feedrate: Nominal feedrate, m/s (None: the preset's, or a G-code part's F words).
        feedrate_override: Fraction of the programmed feeds (a CNC panel's override).
        laps: Times to trace a closed path (None: the preset's on its own path, else 1).
        ideal: Drop the rig's encoder, noise and computation delay (the papers' simulations).
        estimator: Contour error estimator feeding the CCC and the observation (None: the
            preset's, i.e. its paper's).
        estimator_options: Its options.
        axis_controller: Axis controller name (None: the preset's, i.e. its paper's).
        controller_options: Its options (update the preset's for the preset's controller).
        ccc_law: CCC law name (``contour_gym.ccc.CCC_LAWS``).
        ccc_law_params: The law's parameters beyond kp, ki, kd.
        ccc_injection: ``"control"`` or ``"reference"`` (None: the preset's).
        path_control: ``"none"``, ``"G61"``, ``"G61.1"``, ``"G64"`` (None: the path's own; on
            random paths the task's: ``"G64"`` for the CCC task, ``"G61.1"`` for feedrate).
        path_tolerance: Tolerance of ``"G64"``, m.
        decision_ticks: Servo ticks per env step (the action is held).
        tolerance: Contour error bound, m; also the observation and reward scale (None: the
            preset's).
        hard_limit: |true contour error| beyond this ends the episode as a failure, m (None:
            100 tolerances).
        failure_penalty: Extra penalty of a failed episode beyond the failure rule's floor.
        reward: Reward: a registered compiled reward's name, a Python callable, or None for
            the env kind's default (``"ccc"`` or ``"feedrate"``; ``contour_gym.rewards``).
        reward_weights: Weights of a compiled reward, by name.
        randomize: False, True (default ranges) or a dict overriding some ranges.
        lookahead: v0 observation: arc lengths ahead of the reference where curvature is
            observed, m.
        observation: ``"v1"`` (the ``-v1`` ids: what a controller can know on any path) or
            ``"v0"`` (the ``-v0`` ids: v0's keys, ``progress`` and the reference velocity per
            axis among them); see the env docstrings.
        preview: v1 observation: arc lengths ahead of the reference where curvature and the
            turning angle are observed, m; the largest is the horizon of the next corner.
        observe_progress: v1 observation: add ``progress`` (the fraction of the path done),
            which lets an agent learn a path's schedule instead of a control law.
        curvature_windows: v1 observation: edges of arc-length windows ahead of the reference,
            m, increasing from >= 0 (e.g. ``(0, 0.001, 0.002, 0.005, 0.01)``: four windows);
            adds ``curvature_peak``, the largest curvature in each window (sampled every
            0.125 mm), so that a short tight curve ahead shows
            all the while it is in a window, not only as it passes a ``preview`` point.
            Empty (default): no such key.
        ccc_weights: Per-contour, per-coordinate weights of the CCC output, broadcastable to
            (C, 3) (None: the preset's ``ccc_weights``; e.g. 003's compensator gains).
        ccc_gains: CCC env: the gains the action map is centred on (None: the preset's).
            Feedrate env: fixed CCC gains (None: no CCC, as in 004), (kp, ki, kd).
        gain_range: CCC env: each gain's largest value is the preset's times this; the action
            map spans [0, that] on a log-like scale (see the CCC env).
        kd_scale: CCC env: largest kd as a multiple of the preset's kp, s.
        feedrate_range: Feedrate env: (F_min, F_max) as multiples of the programmed feedrate.
            The default (0.2, 2.0) is chosen (004 publishes no range). On some tight curves
            of 004's machine 5 um needs less than 0.2 (docs/training.md): lower the floor.
        max_feedrate_change: Feedrate env: |dF| per step as a multiple of the programmed one.
        feedrate_target: Feedrate env: None (default: the action is the override's change),
            or ``(low, mid, high)`` overrides within ``feedrate_range``: the action is then a
            target override on a log scale (-1 ``low``, 0 ``mid``, 1 ``high``; ``mid (high /
            mid)^a`` above 0, ``mid (low / mid)^-a`` below), which the override moves toward
            by at most ``max_feedrate_change`` a step. A zero action holds ``mid``, so an agent
            learns its departures from a safe override rather than a speed to keep.
        feedrate_limit: Feedrate env, with ``feedrate_target``: None (default), or ``(a_c,
            reach)``: the zero action's target (``mid`` above) then follows a centripetal
            acceleration limit, the override at which the block's programmed feed F meets
            ``v^2 kappa = a_c`` (m/s^2) on the tightest curve within ``reach`` (m) ahead,
            ``sqrt(a_c / kappa) / F`` within [``low``, ``mid``]; the action departs from it
            on the same log scale. An agent learns corrections to a curvature feed limit, as
            a CNC's own has it (residual learning), rather than the limit itself. ``(a_c,
            reach, v_end, end_reach)`` also keeps the speed to ``v_end`` (m/s, the override
            ``v_end / F``) within ``end_reach`` (m) of the path's end, where the axes stop.
        limit_span: Feedrate env, with ``feedrate_limit``: None (default: the action departs
            from the limit L toward ``low`` and ``high``, ``L (high / L)^a`` above 0 and ``L
            (low / L)^-a`` below), or a factor > 1: the target is then ``L span^a`` within
            [``low``, ``high``], the same factor up and down wherever L lies (with L at
            ``mid`` = 0.6 and low 0.05, the default map's a = -0.1 slows by 22 % where a =
            0.1 speeds up by 7 %).
        settle_time: Time allowed to get in position after the reference ends, s.
        step_limit: The env's own step limit (None: computed from its path, feedrate and
            decision time, see the env docstrings). ``gym.make(id, max_episode_steps=N)`` adds
            Gymnasium's ``TimeLimit`` wrapper instead, whose truncation the env cannot see (its
            info then has no ``metrics``); ``step_limit=N`` ends the episode in the env itself.
    """

    plant: str | Mapping[str, Any] = "xy_dc_servo"
    path: str | Path | None = None
    path_options: dict[str, Any] = field(default_factory=dict)
    feedrate: float | None = None
    feedrate_override: float | None = None
    laps: int | None = None
    ideal: bool = False
    estimator: str | None = None
    estimator_options: dict[str, Any] = field(default_factory=dict)
    axis_controller: str | None = None
    controller_options: dict[str, Any] = field(default_factory=dict)
    ccc_law: str = "pid"
    ccc_law_params: dict[str, Any] = field(default_factory=dict)
    ccc_injection: str | None = None
    path_control: str | None = None
    path_tolerance: float | None = None
    decision_ticks: int = 10
    tolerance: float | None = None
    hard_limit: float | None = None
    failure_penalty: float = 100.0
    reward: Any = None
    reward_weights: dict[str, float] = field(default_factory=dict)
    randomize: bool | dict[str, Any] = False
    lookahead: tuple[float, ...] = (0.002, 0.005, 0.01)
    observation: str = "v1"
    preview: tuple[float, ...] = (0.001, 0.002, 0.005, 0.01, 0.02)
    observe_progress: bool = False
    curvature_windows: tuple[float, ...] = ()
    ccc_weights: Any = None
    ccc_gains: tuple[float, float, float] | None = None
    gain_range: float = 30.0
    kd_scale: float = 1e-2
    feedrate_range: tuple[float, float] = (0.2, 2.0)
    max_feedrate_change: float = 0.1
    feedrate_target: tuple[float, float, float] | None = None
    feedrate_limit: tuple[float, ...] | None = None
    limit_span: float | None = None
    settle_time: float = 1.0
    step_limit: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.decision_ticks, int) or self.decision_ticks < 1:
            raise ValueError(f"decision_ticks must be a positive int, got {self.decision_ticks!r}")
        if self.tolerance is not None:
            positive(self.tolerance, "tolerance")
        if self.hard_limit is not None:
            positive(self.hard_limit, "hard_limit")
        non_negative(self.failure_penalty, "failure_penalty")
        if positive(self.gain_range, "gain_range") <= 1.0:
            raise ValueError(f"gain_range must be > 1, got {self.gain_range!r}")
        positive(self.kd_scale, "kd_scale")
        as_finite_array(self.lookahead, "lookahead", ndim=1)
        self._check_observation()
        lo, hi = as_finite_array(self.feedrate_range, "feedrate_range", shape=(2,))
        if not 0 < lo < 1 < hi:
            raise ValueError(
                f"feedrate_range must satisfy 0 < low < 1 < high, got {self.feedrate_range!r}"
            )
        positive(self.max_feedrate_change, "max_feedrate_change")
        self._check_target(lo, hi)
        positive(self.settle_time, "settle_time")
        if self.ccc_gains is not None:
            as_finite_array(self.ccc_gains, "ccc_gains", shape=(3,))
        if self.ccc_weights is not None:
            weights = as_finite_array(self.ccc_weights, "ccc_weights")
            if weights.ndim > 2 or (weights.ndim and weights.shape[-1] not in (1, 3)):
                raise ValueError(f"ccc_weights must broadcast to (C, 3), got {weights.shape}")
        if self.ccc_injection is not None and self.ccc_injection not in INJECTIONS:
            raise ValueError(
                f"unknown ccc_injection {self.ccc_injection!r}; accepted: {INJECTIONS}"
            )
        if self.path_control is not None and self.path_control not in PATH_CONTROLS:
            raise ValueError(
                f"unknown path_control {self.path_control!r}; accepted: {PATH_CONTROLS}"
            )
        if self.step_limit is not None and (
            not isinstance(self.step_limit, int) or self.step_limit < 1
        ):
            raise ValueError(f"step_limit must be a positive int, got {self.step_limit!r}")
        check_path_options(self.path, self.path_options)
        if self.path == RANDOM and self.laps is not None:
            raise ValueError("laps do not apply to path='random' (each draw is one path)")
        self.randomization()  # validates

    def _check_target(self, lo: float, hi: float) -> None:
        if self.feedrate_target is not None:
            t_lo, t_mid, t_hi = as_finite_array(self.feedrate_target, "feedrate_target",
                                                shape=(3,))
            if not lo <= t_lo < t_mid < t_hi <= hi:
                raise ValueError(f"feedrate_target must be (low, mid, high) increasing within "
                                 f"feedrate_range {tuple(self.feedrate_range)!r}, got "
                                 f"{self.feedrate_target!r}")
        self._check_span()
        if self.feedrate_limit is None:
            return
        limit = as_finite_array(self.feedrate_limit, "feedrate_limit")
        if limit.shape not in ((2,), (4,)) or np.any(limit <= 0):
            raise ValueError(f"feedrate_limit must be (a_c, reach) or (a_c, reach, v_end, "
                             f"end_reach) > 0, m/s^2, m, m/s and m, got "
                             f"{self.feedrate_limit!r}")
        if self.feedrate_target is None:
            raise ValueError("feedrate_limit sets the zero action of feedrate_target: give "
                             "feedrate_target=(low, mid, high) too")

    def _check_span(self) -> None:
        if self.limit_span is None:
            return
        if isinstance(self.limit_span, (bool, str)) or finite(self.limit_span, "limit_span") <= 1:
            raise ValueError(f"limit_span must be a finite number > 1, got {self.limit_span!r}")
        if self.feedrate_limit is None:
            raise ValueError("limit_span scales the action around feedrate_limit: give "
                             "feedrate_limit too")

    def _check_observation(self) -> None:
        choice(self.observation, "observation", OBSERVATIONS)
        preview = as_finite_array(self.preview, "preview", ndim=1)
        if preview.size == 0 or np.any(preview <= 0):
            raise ValueError(f"preview must be positive arc lengths, m, got {self.preview!r}")
        if not isinstance(self.observe_progress, bool):
            raise ValueError(f"observe_progress must be a bool, got {self.observe_progress!r}")
        edges = as_finite_array(self.curvature_windows, "curvature_windows", ndim=1)
        if edges.size == 0:
            return
        if edges.size < 2 or edges[0] < 0 or np.any(np.diff(edges) <= 0):
            raise ValueError("curvature_windows must be >= 2 increasing arc lengths from >= 0, "
                             f"m, got {self.curvature_windows!r}")
        if self.observation != "v1":
            raise ValueError(f"curvature_windows is a v1 observation option, got observation="
                             f"{self.observation!r}")

    @classmethod
    def from_kwargs(cls, kwargs: dict[str, Any]) -> EnvConfig:
        """Build from env keyword arguments; unknown keys raise ValueError listing the accepted."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise ValueError(f"unknown argument(s) {unknown}; accepted: {', '.join(sorted(names))}")
        return cls(**kwargs)

    def tolerance_for(self, preset: Preset) -> float:
        """The contour tolerance the env scores against: ``tolerance``, else the preset's."""
        return self.tolerance if self.tolerance is not None else preset.tolerance

    def hard_limit_for(self, preset: Preset) -> float:
        """The contour error that fails an episode: ``hard_limit``, else 100 tolerances."""
        return self.hard_limit or HARD_LIMIT_TOLERANCES * self.tolerance_for(preset)

    @property
    def random_paths(self) -> bool:
        """Whether each member draws its own path at each reset (``path="random"``)."""
        return isinstance(self.path, str) and self.path == RANDOM

    def path_options_for(self, preset: Preset, defaults: Mapping[str, Any]) -> dict[str, Any]:
        """The arguments of each random path draw on ``preset``, with the task's ``defaults``."""
        return path_options(preset.stage, defaults, self.path_options)

    def random_scenario(
        self, rng: np.random.Generator, task: Task, *, as_reset: bool = False
    ) -> Scenario:
        """The scenario of one random path drawn from ``rng``, as the env runs it for ``task``.

        The task's path defaults (:meth:`Task.path_defaults`) under the env's
        ``path_options``, and its path control (:meth:`Task.random_path_control`) where the
        env names none. For tuning on random paths (:mod:`agents.tune`) as the env trains.

        Args:
            rng: The generator the path is drawn from.
            task: The env's task.
            as_reset: Draw as an env's reset does (:func:`~contour_gym.envs._paths.reset_draws`):
                from a generator seeded ``s``, the path ``env.reset(seed=s)`` runs.

        Raises:
            ValueError: for ``as_reset`` with a randomised machine (its draws come first).
        """
        preset = resolve_preset(self.plant)
        options = self.path_options_for(preset, task.path_defaults(preset))
        if as_reset and self.randomization() is not None:
            raise ValueError("as_reset draws the path of an env without randomize; "
                             f"got randomize={self.randomize!r}")
        path = reset_draws(rng, preset.stage, options)[1] if as_reset else draw_path(
            rng, preset.stage, options)
        return self.scenario(path=path, **task.random_path_control(self.tolerance_for(preset)))

    def scenario(self, path: Path | None = None, **defaults: Any) -> Scenario:
        """The scenario (machine, path, loop options) these arguments describe.

        Args:
            path: The path to run instead of ``self.path`` (an env on random paths gives its
                first draw; else, with ``path="random"``, a draw from ``default_rng(0)``).
            **defaults: ``path_control`` and ``path_tolerance`` where these arguments leave
                them None (the task's on random paths).
        """
        if path is None and self.random_paths:
            preset = resolve_preset(self.plant)
            rng = np.random.default_rng(0)
            path = draw_path(rng, preset.stage, self.path_options_for(preset, {}))
        options: dict[str, Any] = {
            "ideal": self.ideal, "ccc_law": self.ccc_law, "ccc_law_params": self.ccc_law_params,
            "path_control": self.path_control or defaults.get("path_control"),
            "path_tolerance": self.path_tolerance or defaults.get("path_tolerance"),
            "settle_time": self.settle_time,
            "estimator_options": self.estimator_options,
            "controller_options": self.controller_options,
        }
        for key in ("ccc_injection", "estimator", "axis_controller"):  # None: the preset's
            if getattr(self, key) is not None:
                options[key] = getattr(self, key)
        return make_scenario(
            self.plant, self.path if path is None else path, self.feedrate,
            feedrate_override=self.feedrate_override,
            laps=self.laps, **options,
        )

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
