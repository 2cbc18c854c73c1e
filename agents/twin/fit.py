"""Identify a twin: the plant whose closed loop, replaying the logs' commands, measures the same.

Output error (:mod:`agents.twin.replay`): the logs' commands drive a loop of the preset the
machine is like, each member a candidate plant, and the simulated axis positions (and, when the
logs hold it, the control signals) are matched to the logged ones by
:func:`scipy.optimize.least_squares` (bounded, from several starts; with both channels, refitted
once with each weighed by its residual at that fit). The fit's replay has exact, noise-free
encoders (the loop's delay kept): with the logged encoder steps the cost is rough at every
scale, and the twin's misfit with them is what the report gives. What the steps do in the loop
biases such a fit: :func:`_bias` reads it on the twin's own logs, and the fit is corrected by it.
The unknowns are factors on the preset's values, searched in log space: per axis its mass,
viscous damping, the friction parameters :data:`FITTED_FRICTION` names for its law and, where
the preset has a force ripple, its level (every harmonic's amplitude by one factor). The
force constant is fixed at the preset's: with the axis controller's gains known, positions
and the control signal depend on mass, damping and friction only through their ratios to it;
the preset's disturbance forces are scaled into those units by a level the force balance reads
from the logged control signal (:func:`inverse_dynamics`), and replayed at it.
A Jacobian's columns are members of one run (axis ``a``'s residual depends on axis ``a``'s
factors only, so parameter ``j`` of every axis moves in the same member).
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from agents.twin.generate import encoder_reading
from agents.twin.identified import DETERMINED, VISCOUS, Identified, static_over_coulomb
from agents.twin.replay import replay_loop
from agents.twin.stats import correlation_time, deviations
from contour_gym.logs import STILL_BELOW, ServoLog, encoder_step
from contour_gym.loop import ServoLoop
from contour_gym.machines import plant_of
from contour_gym.plant.friction import law_for
from contour_gym.plant.params import AxisParams
from contour_gym.presets import Preset, resolve_preset

Array = NDArray[np.float64]
FITTED_FRICTION = {"none": (), "coulomb": ("fc",), "stribeck": ("fc", "fs", "vs"),
                   "lugre": ("sigma0", "sigma1", "fc", "fs", "vs")}
"""Per friction law, the parameters identified (those the preset gives a value > 0: a factor
cannot move a zero); the others stay the preset's."""
FIXED = ("force_constant",)
REGRESSED = ("mass", "damping", "fc")
"""The values the force balance reads (:func:`inverse_dynamics`), in its columns' order; on an
axis under a random disturbance the twin keeps these (:func:`_process_noise_axes`)."""
BOUNDS = (0.2, 5.0)  # factors on the preset's values searched within
STEP = 2e-2  # the Jacobian's step in log factor
XTOL = 1e-4  # least_squares stops when the log factors move less than this (0.01 %)
FTOL = 1e-6  # or the cost falls by less than this fraction
NEAR = 0.1  # starts within this fraction of an axis's best sum of squares fit it as well
FAILED = 1e3  # the residual of a sample a failed candidate did not reach (in following errors)


def _nominal(axis: Any) -> dict[str, Any]:
    """The preset's values of an axis's identified parameters (and its friction model's)."""
    friction = dataclasses.asdict(axis.friction) if axis.friction is not None else {}
    ripple = {"ripple": axis.ripple.amplitude} if axis.ripple is not None else {}
    return {"mass": axis.mass, "damping": axis.damping, **friction, **ripple}


def fitted_names(preset: Preset) -> list[tuple[str, ...]]:
    """Per axis, the parameters identified.

    Mass, damping, its law's :data:`FITTED_FRICTION` and ``ripple`` (the force ripple's
    largest amplitude) where the preset has a ripple.
    """
    out = []
    for axis in preset.stage.axes:
        law = law_for(axis.friction).name
        given = _nominal(axis)
        friction = [n for n in FITTED_FRICTION.get(law, ()) if (given.get(n) or 0.0) > 0.0]
        ripple = ["ripple"] if (given.get("ripple") or 0.0) > 0.0 else []
        out.append(("mass", "damping", *friction, *ripple))
    return out


class _Problem:
    """The logs replayed on candidate plants: residuals and Jacobians by runs of members.

    The residuals are, per log, channel-major blocks of samples: each axis's position, then
    (when every log holds it) each axis's control signal, each channel divided by its
    :attr:`scale` (first its RMS following error or RMS control signal; :meth:`reweight` sets
    it to the channel's residual at a fit, so that every channel counts by its own noise).
    """

    def __init__(self, logs: Sequence[ServoLog], like: Any, screen: int, ideal: bool) -> None:
        self.spec = like  # the plant the replays run (a preset name or a plant dict)
        self.ideal = ideal
        self.read: dict[str, str] = {}  # what was read from the logs, not fitted
        self.preset = resolve_preset(like)
        self.names = fitted_names(self.preset)
        self.n_params = max(len(n) for n in self.names)
        members = max(screen, 1 + self.n_params)  # the screen at once, or a Jacobian's run
        self.logs = list(logs)
        axes = [a.name for a in self.preset.stage.axes]
        cmd = [np.stack([log.axis(n).cmd for n in axes], axis=1) for log in self.logs]
        fb = [np.stack([log.axis(n).fb for n in axes], axis=1) for log in self.logs]
        moved = np.concatenate([np.ptp(c, axis=0)[None] for c in cmd]).max(axis=0)
        self.still = [a for a, span in enumerate(moved) if span < STILL_BELOW]
        if len(self.still) == len(axes):
            raise ValueError(f"no axis of {like!r} moved in the logs: nothing to identify")
        _check_span(self.preset, cmd)
        self.effort = all(log.axis(n).effort is not None for log in self.logs for n in axes)
        self.measured = fb
        err = np.concatenate([c - f for c, f in zip(cmd, fb, strict=True)])
        scale = np.sqrt(np.mean(err**2, axis=0)) + 1e-12  # each axis's RMS following error
        if self.effort:
            u = [np.stack([_effort(log, n) for n in axes], axis=1) for log in self.logs]
            self.measured = [np.concatenate(pair, axis=1) for pair in zip(fb, u, strict=True)]
            scale = np.r_[scale, np.sqrt(np.mean(np.concatenate(u) ** 2, axis=0)) + 1e-12]
        self.scale: Array = scale
        self.first_scale: Array = scale.copy()  # what the reported NRMSE divides by
        self.channel_axis = np.tile(np.arange(len(axes)), 2 if self.effort else 1)
        self.loops = [replay_loop(log, like, members=members, ideal=ideal) for log in self.logs]
        # per axis, the preset's disturbance (step, sine) is replayed this many times over
        self.disturbance: Array = np.ones(len(axes))
        self._last: tuple[bytes, Array, Array] | None = None

    def outputs(self, theta: Array) -> list[Array]:
        """(M, N, C) per log: the channels of members with log factors ``theta`` (M, A, P)."""
        m = theta.shape[0]
        theta = theta.copy()
        theta[:, self.still] = 0.0  # an axis that never moved keeps the preset's values
        factors = np.exp(theta)
        fric: dict[str, Array] = {}
        for a, names in enumerate(self.names):
            for j, name in enumerate(names[2:], start=2):
                fric.setdefault(name, np.ones((m, len(self.names))))[:, a] = factors[:, a, j]
        ripple = fric.pop("ripple", np.ones((m, len(self.names))))
        out = []
        for loop, log in zip(self.loops, self.logs, strict=True):
            _scale(loop, factors, fric, ripple, self.disturbance)
            loop.reset(0)
            loop.step(len(log.time), skip=np.arange(m, loop.batch_size))  # the rest sit out
            trace = loop.trace()
            out.append(np.concatenate([trace.x[:m], trace.u[:m]], axis=2) if self.effort
                       else trace.x[:m])
        return out

    def residuals(self, out: list[Array]) -> Array:
        """(M, R) each member's residuals: (simulated - logged) / the channel's scale."""
        rows = [(o - meas[None]) / self.scale for o, meas in zip(out, self.measured, strict=True)]
        res = np.concatenate([r.reshape(r.shape[0], -1, order="F") for r in rows], axis=1)
        # a candidate whose loop failed (diverged: NaN rows after its end) is a bad fit
        return np.nan_to_num(res, nan=FAILED, posinf=FAILED, neginf=-FAILED)

    def reweight(self, res: Array) -> None:
        """Scale each channel by its RMS residual ``res`` (R,) at a fit: equal weight per noise."""
        rms = np.array([math.sqrt(np.mean(res[r] ** 2)) for r in self.channel_rows(res.size)])
        self.scale = self.scale * np.maximum(rms, 1e-9)
        self._last = None

    def run(self, flat: Array) -> tuple[Array, Array]:
        """Residuals (R,) at ``flat`` and the Jacobian (R, A P), from one run of 1 + P members."""
        key = flat.tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1], self._last[2]
        a, p = len(self.names), self.n_params
        theta = np.repeat(flat.reshape(1, a, p), p + 1, axis=0)
        for j in range(p):
            theta[j + 1, :, j] += STEP
        res = self.residuals(self.outputs(theta))
        jac = np.zeros((res.shape[1], a * p))
        per_axis = self.axis_rows(res.shape[1])
        for j in range(p):
            for ax in range(a):
                rows = per_axis[ax]
                jac[rows, ax * p + j] = (res[j + 1, rows] - res[0, rows]) / STEP
        self._last = (key, res[0], jac)
        return res[0], jac

    def channel_rows(self, total: int) -> list[NDArray[np.intp]]:
        """The residual rows of each channel (per log, channel-major blocks)."""
        c = len(self.channel_axis)
        idx, start = [np.zeros(0, dtype=np.intp) for _ in range(c)], 0
        for meas in self.measured:
            n = meas.shape[0]
            for ch in range(c):
                idx[ch] = np.r_[idx[ch], np.arange(start + ch * n, start + (ch + 1) * n)]
            start += c * n
        assert start == total
        return idx

    def axis_rows(self, total: int) -> list[NDArray[np.intp]]:
        """The residual rows of each axis (its position's and, when logged, its control's)."""
        rows = self.channel_rows(total)
        return [np.concatenate([r for r, a in zip(rows, self.channel_axis, strict=True)
                                if a == ax]) for ax in range(len(self.names))]


def _effort(log: ServoLog, name: str) -> Array:
    effort = log.axis(name).effort
    assert effort is not None
    return effort


def _scale(loop: ServoLoop, factors: Array, fric: dict[str, Array], ripple: Array,
           disturbance: Array) -> None:
    m = factors.shape[0]
    loop.set_plant_scaling(np.arange(m), mass=factors[:, :, 0], damping=factors[:, :, 1],
                           friction_params=fric, ripple=ripple,
                           disturbance=disturbance[None, :],
                           random_disturbance=0.0)  # as replay_loop


def identify(
    logs: Sequence[ServoLog], like: Any, *, starts: int = 3, screen: int = 128, seed: int = 0,
    ideal: bool = False,
) -> Identified:
    """Fit a twin of the machine that wrote ``logs``, starting from the preset ``like``.

    Args:
        logs: Servo logs of the machine (one sample per servo tick).
        like: The preset (or machine file) whose structure, controllers and fixed values the
            twin keeps.
        starts: Least-squares runs, from the best points of the screen (on the replay with
            exact, noise-free encoders, as the whole fit).
        screen: Random points (log factors within :data:`BOUNDS`) simulated at once to pick
            the starts from (the preset's own values among them).
        seed: Seed of the screen.
        ideal: Replay without encoder, noise or delay (logs made with ``ideal=True``).

    Returns:
        The twin (:class:`Identified`).
    """
    spec: Any = _like_spec(like)
    read: dict[str, str] = {}
    if not ideal:  # the twin's encoders step as the logged feedback does
        spec, read = _with_encoders(spec, logs)
    # the fit searches a replay with exact encoders: with the steps its cost is rough at every
    # scale and a search there fits its dents (docs/measurements.md); the replay with the
    # steps, the twin as it runs, gives the reported misfit
    problem = _Problem(logs, spec, 0, ideal)
    problem.read = read
    fitted = problem if ideal else _Problem(logs, _without_encoders(spec), 0, ideal)
    a, p = len(problem.names), problem.n_params
    lo, hi = np.log(BOUNDS[0]), np.log(BOUNDS[1])
    rng = np.random.default_rng(seed)
    points = rng.uniform(lo, hi, size=(screen, a, p))
    points[0] = 0.0
    regressed = inverse_dynamics(problem)  # with effort logged
    points[1] = np.clip(regressed.theta, lo, hi)
    _use_levels(problem, regressed)
    fitted.disturbance = problem.disturbance
    fits = [_solve(fitted, x0, (lo, hi)) for x0 in _starts(fitted, points, starts)]
    best = min(fits, key=lambda f: f.cost)
    spread = _spread(fitted, fits, best)
    if fitted.effort:  # positions and control signals: each weighed by its own noise
        fitted.reweight(best.fun)
        best = _solve(fitted, best.x, (lo, hi))
    problem.scale = fitted.scale
    sd = _process_noise_axes(problem, best, regressed, spread)
    _check_bounds(problem, best.x.reshape(a, p))
    bias = _bias(problem, fitted, best.x, (lo, hi))
    for ax, j in sd:  # the force balance's values are not the fit's
        bias[ax, j] = 0.0
    best.x = np.clip(best.x - bias.ravel(), lo, hi)  # the fit lands ``bias`` off: correct it
    return _result(problem, fitted, best, spread, sd, bias)


def _starts(fitted: _Problem, points: Array, starts: int) -> list[Array]:
    """The least-squares starts from a screen of ``points`` (M, A, P), run at once.

    The axes are fitted apart (each one's residuals follow its own factors only): start k
    takes each axis's k-th best point.
    """
    screened = _Problem(fitted.logs, fitted.spec, len(points), fitted.ideal)
    screened.disturbance = fitted.disturbance
    res = screened.residuals(screened.outputs(points))
    ranked = [np.argsort((res[:, r] ** 2).sum(axis=1))
              for r in screened.axis_rows(res.shape[1])]
    return [np.stack([points[ranked[ax][k], ax] for ax in range(points.shape[1])]).ravel()
            for k in range(starts)]


def _bias(problem: _Problem, fitted: _Problem, x: Array, bounds: tuple[Array, Array]
          ) -> Array:
    """(A, P) the fit's bias at log factors ``x``: where it lands when the logs are the twin's own.

    The twin (``x`` on ``problem``'s replay, with the logged encoder steps) replays the logs'
    commands; its encoder readings (and control signals) become logs, and the fit runs on
    them from ``x`` on ``fitted``'s replay, weighed as it was; the distance it moves is the
    bias (a parametric bootstrap's, in log factor): what the fit's exact encoders miss of what
    the steps do in the loop. The twin's logs hold no noise but the steps' and no random
    disturbance, so the bias those add is not in it.
    """
    a, p = len(problem.names), problem.n_params
    out = problem.outputs(x.reshape(1, a, p))
    logs = [_twin_log(problem, log, o[0]) for log, o in zip(problem.logs, out, strict=True)]
    own = _Problem(logs, fitted.spec, 0, fitted.ideal)
    own.disturbance, own.scale = fitted.disturbance, fitted.scale
    found = _solve(own, x, bounds).x
    return (found - x).reshape(a, p)


def _twin_log(problem: _Problem, log: ServoLog, channels: Array) -> ServoLog:
    # ``log`` with the preset's axes' feedback (and effort) from a replay's ``channels``
    # (N, C): its positions read by the encoders as the logged feedback was
    if not np.all(np.isfinite(channels)):
        raise ValueError(f"{log.source}: the twin's own replay of this log failed (diverged): "
                         "its values cannot drive the logged commands")
    n_axes = len(problem.preset.stage.axes)
    made = {}
    for a, axis in enumerate(problem.preset.stage.axes):
        step = 0.0 if problem.ideal else axis.encoder_resolution
        changes: dict[str, Any] = {"fb": encoder_reading(channels[:, a], step)}
        if problem.effort:
            changes["effort"] = channels[:, n_axes + a]
        made[axis.name] = dataclasses.replace(log.axis(axis.name), **changes)
    return dataclasses.replace(log, axes=tuple(made.get(ax.name, ax) for ax in log.axes))


def _process_noise_axes(problem: _Problem, best: Any, regressed: Regressed, spread: Array
                        ) -> dict[tuple[int, int], float]:
    """On axes under a random disturbance, the force balance's values replace the fit's.

    Output error takes the residual for measurement noise; a random force acting through the
    closed loop is not, and biases it (docs/measurements.md, "IV values under a random
    disturbance"). The instrumental-variable regression
    (:func:`inverse_dynamics`) is not biased by it: with the effort logged, the
    :data:`REGRESSED` values of such an axis are its (``best.x`` changed in place, their
    ``spread`` 0). Returns their standard deviations, (axis, parameter) -> log factor's.
    """
    a, p = len(problem.names), problem.n_params
    x = best.x.reshape(a, p).copy()
    lo, hi = np.log(BOUNDS[0]), np.log(BOUNDS[1])
    out: dict[tuple[int, int], float] = {}
    noisy = random_axes(problem.preset)
    for ax, axis in enumerate(problem.preset.stage.axes):
        if not (axis.name in noisy and problem.effort) or ax in problem.still:
            continue
        taken = [j for j, name in enumerate(problem.names[ax]) if name in REGRESSED]
        for j in taken:
            x[ax, j] = np.clip(regressed.theta[ax, j], lo, hi)
            spread[ax, j] = 0.0
            out[(ax, j)] = float(regressed.std[ax, j])
        problem.read[f"{axis.name}.regressed"] = (
            f"{', '.join(problem.names[ax][j] for j in taken)} from the force balance "
            "(instrumental variables), not the replay's fit: the axis's random disturbance "
            "biases that")
    best.x = x.ravel()
    return out


def random_axes(preset: Preset) -> list[str]:
    """The axes of ``preset`` under a random disturbance (what a replay cannot draw again)."""
    return [a.name for a in preset.stage.axes
            if a.disturbance is not None and a.disturbance.is_random]


def _like_spec(like: Any) -> Any:
    """``like`` as a plant the twin's changes merge into: a preset name, or a plant dict."""
    if isinstance(like, Preset):
        return like.name
    spec, _ = plant_of(like)  # a machine file is read (its changes stay the twin's)
    return spec


def _merged(spec: Any, axes: dict[str, Any]) -> dict[str, Any]:
    """The plant dict ``spec`` with ``axes``' changes merged into its axes (deep per axis)."""
    plant: dict[str, Any] = ({"preset": spec} if isinstance(spec, str)
                             else copy.deepcopy(dict(spec)))
    stage = plant.setdefault("stage", {})
    mine = stage.setdefault("axes", {})
    for name, changes in axes.items():
        mine[name] = {**mine.get(name, {}), **changes}
    return plant


def _with_encoders(spec: Any, logs: Sequence[ServoLog]) -> tuple[Any, dict[str, str]]:
    """``spec`` with each axis's encoder step read from the logged feedback (where it steps)."""
    steps: dict[str, Any] = {}
    read = {}
    for axis in resolve_preset(spec).stage.axes:
        found = [encoder_step(log.axis(axis.name).fb) for log in logs]
        if found and all(f is not None for f in found):
            step = float(np.median([f for f in found if f is not None]))
            steps[axis.name] = {"encoder_resolution": step}
            read[f"{axis.name}.encoder_resolution"] = (
                f"{step * 1e6:.6g} um, read from the feedback's steps (not fitted)")
    return (_merged(spec, steps) if steps else spec), read


def _without_encoders(spec: Any) -> dict[str, Any]:
    """``spec`` with every axis's encoder exact and noise-free (the loop's delay kept)."""
    return _merged(spec, {axis.name: {"encoder_resolution": 0.0, "noise_std": 0.0}
                          for axis in resolve_preset(spec).stage.axes})


def _check_span(preset: Preset, cmd: list[Array]) -> None:
    """Refuse logs whose commands span more than an axis's travel: a wrong length unit."""
    span = np.concatenate(cmd).max(axis=0) - np.concatenate(cmd).min(axis=0)
    for axis, reach in zip(preset.stage.axes, span, strict=True):
        if axis.travel is not None and reach > axis.travel[1] - axis.travel[0]:
            raise ValueError(
                f"the log's {axis.name} commands span {reach * 1e3:.6g} mm, more than "
                f"{preset.name}'s {axis.name} travel ({(axis.travel[1] - axis.travel[0]) * 1e3:g}"
                " mm): is the length unit right (--length-unit m, mm or inch)?")


def _check_bounds(problem: _Problem, theta: Array) -> None:
    """Refuse a fit whose mass sits on a bound: a wrong length unit, or another machine."""
    lo, hi = np.log(BOUNDS[0]), np.log(BOUNDS[1])
    for ax, axis in enumerate(problem.preset.stage.axes):
        if ax in problem.still or not (theta[ax, 0] <= lo + 0.01 or theta[ax, 0] >= hi - 0.01):
            continue
        raise ValueError(
            f"axis {axis.name}'s fitted mass is {math.exp(theta[ax, 0]):.3g} times "
            f"{problem.preset.name}'s, at the bound of the search ({BOUNDS[0]:g} to "
            f"{BOUNDS[1]:g}): check the log's length unit (--length-unit) and effort unit, or "
            "choose a --like preset nearer your machine")


def _spread(problem: _Problem, fits: list[Any], best: Any) -> Array:
    """(A, P) each parameter's largest log-factor distance from ``best`` over the starts.

    Only starts that fit its axis about as well count (within :data:`NEAR` of the best sum of
    squares there).
    """
    a, p = len(problem.names), problem.n_params
    out = np.zeros((a, p))
    for ax, rows in enumerate(problem.axis_rows(best.fun.size)):
        costs = [float(f.fun[rows] @ f.fun[rows]) for f in fits]
        for f, cost in zip(fits, costs, strict=True):
            if cost <= (1.0 + NEAR) * min(costs):
                gap = np.abs(f.x.reshape(a, p)[ax] - best.x.reshape(a, p)[ax])
                out[ax] = np.maximum(out[ax], gap)
    return out


def _solve(problem: _Problem, start: Array, bounds: tuple[Array, Array]) -> Any:
    return least_squares(lambda f: problem.run(f)[0], start, jac=lambda f: problem.run(f)[1],
                         bounds=bounds, x_scale=1.0, max_nfev=60, xtol=XTOL, ftol=FTOL)


class Regressed(NamedTuple):
    """What :func:`inverse_dynamics` reads from the logged effort."""

    theta: Array
    """(A, P) log factors on the preset's values (0 where nothing was read)."""
    disturbance: Array
    """(A,) the preset's disturbance forces' level in the twin's units (1: not read)."""
    std: Array
    """(A, P) the standard deviations of :attr:`theta` (0 where not read; the residuals'
    correlation counted)."""


def inverse_dynamics(problem: _Problem, smooth: int = 9) -> Regressed:
    """Log factors and force levels from the logged effort (IDIM-IV), per axis.

    The axis's force balance ``K u = m a + b v + fc sgn(v) + r(x) - g d(t) - w`` holds at
    every sample (``r`` the preset's force ripple, ``d`` its disturbance's step and sine,
    ``w`` the random part): with the effort ``u`` logged and ``v``, ``a`` differenced from
    the feedback (smoothed over ``smooth`` samples, the effort read one tick earlier: the
    loop's delay), ``m/K``, ``b/K``, ``fc/K`` and ``g`` follow from one linear
    regression (the inverse dynamic model of the EMPS benchmark). In closed loop the
    disturbance moves ``a`` and ``v`` too, which biases plain least squares; the same
    quantities differenced from the logged *command*, which it does not move, are the
    instruments (IDIM-IV). Each ratio is turned into a factor on the preset's value; friction
    parameters other than ``fc`` start at the factor ``fc`` got.

    ``g`` is the disturbance's level in the twin's units: the force constant stays the
    preset's (:data:`FIXED`), so a force the machine exerts in newtons is
    ``K_preset / K_machine`` times as large in the twin. It is left 1 on an axis without a
    step or sine to read it from, where it comes out outside :data:`BOUNDS`, or without
    effort logged (then the search starts from the preset's values). The preset's ripple is
    taken off the force as it is; its level starts at the preset's and the replay's fit
    finds it: this balance has neither a gantry's coupled beam nor the Stribeck hump, which
    a ripple level read from it would absorb.
    """
    a_n, p = len(problem.names), problem.n_params
    theta, level, std = np.zeros((a_n, p)), np.ones(a_n), np.zeros((a_n, p))
    for ax, (axis, names) in enumerate(zip(problem.preset.stage.axes, problem.names,
                                           strict=True)):
        rows = [_regressors(log, axis, problem.preset.stage.ts, smooth)
                for log in problem.logs]
        if ax in problem.still or any(r is None for r in rows):
            continue
        x, z, y = (np.concatenate([r[i] for r in rows if r is not None]) for i in range(3))
        if len(y) <= x.shape[1]:  # too few moving samples to read anything from
            continue
        fit = np.linalg.lstsq(z.T @ x, z.T @ y, rcond=None)[0]
        cols = _columns(axis)
        coef = dict(zip(cols, fit, strict=True))
        sd = dict(zip(cols, _iv_std(x, z, y - x @ fit), strict=True))
        if "level" in coef and BOUNDS[0] <= coef["level"] <= BOUNDS[1]:
            level[ax] = coef["level"]
        nominal = _nominal(axis)
        fc = coef["fc"] / nominal["fc"] if "fc" in coef else 1.0
        for j, name in enumerate(names):
            ratio = {"mass": coef["mass"] / axis.mass,
                     "damping": coef["damping"] / max(axis.damping, 1e-12),
                     "ripple": 1.0}.get(name, fc)
            theta[ax, j] = math.log(ratio) if ratio > 0.0 else 0.0
            read = name in REGRESSED and name in coef and coef[name] != 0.0
            std[ax, j] = sd[name] / abs(coef[name]) if read else 0.0
    return Regressed(theta, level, std)


def _iv_std(x: Array, z: Array, e: Array) -> Array:
    """Standard deviations of an IV estimate: ``s^2 (Z'X)^-1 Z'Z (X'Z)^-1``, ``e`` its residuals.

    ``s^2`` the residuals' variance times their correlation time
    (:func:`~agents.twin.stats.correlation_time`): a disturbance that lasts many samples is
    worth fewer than their number.
    """
    zx = np.linalg.pinv(z.T @ x)
    cov = zx @ (z.T @ z) @ zx.T * (float(e @ e) / max(len(e) - x.shape[1], 1))
    return np.sqrt(np.clip(np.diag(cov), 0.0, None) * correlation_time(e))


def _columns(axis: AxisParams) -> list[str]:
    # the force balance's unknowns on ``axis``: mass and damping, the Coulomb force where its
    # friction law has one (a column the twin does not have would only blur the damping: at
    # a circle's speeds sgn v follows v closely), the disturbance's level where it has a shape
    coulomb = (_nominal(axis).get("fc") or 0.0) > 0.0
    return ["mass", "damping", *(["fc"] if coulomb else []),
            *(["level"] if _has_shape(axis) else [])]


def _regressors(log: ServoLog, axis: AxisParams, ts: float, smooth: int
                ) -> tuple[Array, Array, Array] | None:
    # :func:`_columns`' regressors ([a, v, sgn v, -d(t)]) from the feedback, the same from
    # the command (the instruments) and the force K u less the ripple, of the moving
    # samples; None without effort
    logged = log.axis(axis.name)
    if logged.effort is None:
        return None
    shape = disturbance_shape(axis, log.time - log.time[0])
    kernel = np.ones(smooth) / smooth
    columns = []
    for signal in (logged.fb, logged.cmd):
        v = np.gradient(np.convolve(signal, kernel, mode="same"), ts)
        known = {"mass": np.gradient(v, ts), "damping": v, "fc": np.sign(v), "level": -shape}
        columns.append(np.stack([known[c] for c in _columns(axis)], axis=1))
    u = np.r_[logged.effort[0], logged.effort[:-1]]  # the loop's one-tick delay
    force = axis.force_constant * u - ripple_force(axis, logged.fb)
    v = columns[1][:, 1]  # the samples kept by the command's speed, which d does not move
    keep = np.abs(v) > 1e-3 * max(np.abs(v).max(), 1e-12)
    keep[: smooth] = keep[-smooth:] = False
    return columns[0][keep], columns[1][keep], force[keep]


def _has_shape(axis: AxisParams) -> bool:
    # whether the axis's disturbance has a step or a sine (a level to read)
    d = axis.disturbance
    return d is not None and (d.step_amp != 0.0 or (d.sin_amp != 0.0 and d.sin_freq > 0.0))


def disturbance_shape(axis: AxisParams, t: Array) -> Array:
    """The preset's disturbance on ``axis`` at times ``t``: its step and sine, N.

    Not its random part (as :func:`contour_gym.loop.kernel.axis_tick` applies them).
    """
    d = axis.disturbance
    if d is None:
        return np.zeros_like(t)
    return (np.where(t >= d.step_time, d.step_amp, 0.0)
            + d.sin_amp * np.sin(2.0 * math.pi * d.sin_freq * t + d.sin_phase))


def ripple_force(axis: AxisParams, x: Array) -> Array:
    """The preset's force ripple on ``axis`` at positions ``x``, N (it opposes the motor)."""
    force = np.zeros_like(x)
    if axis.ripple is not None:
        for a, b, w in zip(axis.ripple.sin_amp, axis.ripple.cos_amp, axis.ripple.wavenumber,
                           strict=True):
            force += a * np.sin(w * x) + b * np.cos(w * x)
    return force


def _use_levels(problem: _Problem, regressed: Regressed) -> None:
    """Replay at the disturbance levels :func:`inverse_dynamics` read, and say what was read."""
    problem.disturbance = regressed.disturbance
    for axis, g in zip(problem.preset.stage.axes, regressed.disturbance, strict=True):
        if g != 1.0:
            problem.read[f"{axis.name}.disturbance"] = (
                f"{g:.4g} times the preset's (step, sine and random part), the sine's "
                "amplitude read from the logged effort (not fitted: the replay runs it)")


def _result(problem: _Problem, fitted: _Problem, fit: Any, spread: Array,
            regressed: dict[tuple[int, int], float], bias: Array) -> Identified:
    # ``fitted``: the replay fitted (its residuals and Jacobian give the deviations);
    # ``problem``: the twin as it runs (its residuals give the reported NRMSE)
    a, p = len(problem.names), problem.n_params
    res, jac = fitted.run(fit.x)
    sd = deviations(fitted, res, jac).reshape(a, p)
    for (ax, j), value in regressed.items():  # the force balance's values: its deviations
        sd[ax, j] = value
    if fitted is not problem:
        res = problem.residuals(problem.outputs(fit.x.reshape(1, a, p)))[0]
    factors = np.exp(fit.x.reshape(a, p))
    values: dict[str, dict[str, float]] = {}
    std: dict[str, dict[str, float]] = {}
    apart: dict[str, dict[str, float]] = {}
    off: dict[str, dict[str, float]] = {}
    axes: dict[str, Any] = {}
    for ax, (axis, names) in enumerate(zip(problem.preset.stage.axes, problem.names,
                                           strict=True)):
        nominal = _nominal(axis)
        values[axis.name] = {n: float(nominal[n] * factors[ax, j]) for j, n in enumerate(names)}
        std[axis.name] = {n: float(values[axis.name][n] * sd[ax, j]) for j, n in enumerate(names)}
        apart[axis.name] = {n: float(math.expm1(spread[ax, j])) for j, n in enumerate(names)}
        off[axis.name] = {n: float(math.expm1(bias[ax, j])) for j, n in enumerate(names)}
        axes[axis.name] = _axis_changes(axis, values[axis.name], problem.disturbance[ax])
    fixed = {n: "not separable from the mass by positions and control (kept the preset's)"
             for n in FIXED}
    fixed.update(problem.read)
    for axis in problem.preset.stage.axes:
        for name in VISCOUS:
            if (getattr(axis.friction, name, 0.0) or 0.0) > 0.0:
                fixed[f"{axis.name}.{name}"] = ("viscous: not separable from the damping (kept "
                                                "the preset's; the damping holds the sum)")
    for ax in problem.still:
        name = problem.preset.stage.axes[ax].name
        fixed[name] = "never moved in the logs (kept the preset's values)"
        axes.pop(name)
        values.pop(name)
        std.pop(name)
        apart.pop(name)
        off.pop(name)
    return Identified(
        plant=_merged(problem.spec, axes),
        values=values, std=std, fixed=fixed,
        nrmse=_nrmse(problem, res), cost=0.5 * float(res @ res), spread=apart, bias=off,
    )


def _axis_changes(axis: Any, values: dict[str, float], level: float) -> dict[str, Any]:
    # the machine file's changes of one axis: mass, damping, its friction model, its ripple,
    # and its disturbance's forces ``level`` times the preset's
    out: dict[str, Any] = {"mass": values["mass"], "damping": values["damping"]}
    if axis.disturbance is not None and level != 1.0:
        d = axis.disturbance
        out["disturbance"] = {"step_amp": d.step_amp * float(level),
                              "sin_amp": d.sin_amp * float(level),
                              "random_std": d.random_std * float(level)}
    if axis.ripple is not None and "ripple" in values:
        out["ripple"] = axis.ripple.scaled(values["ripple"] / axis.ripple.amplitude)
    if axis.friction is not None:
        fields = {**dataclasses.asdict(axis.friction),
                  **{k: v for k, v in values.items() if k not in ("mass", "damping", "ripple")}}
        static_over_coulomb(fields)
        out["friction"] = {"law": law_for(axis.friction).name, **fields}
    return out


def _nrmse(problem: _Problem, res: Array) -> dict[str, float]:
    # per axis that moved: RMS(twin's following error - measured) / RMS(measured), from the
    # position residuals at the solution ((position - feedback) / the channel's scale)
    rows = problem.channel_rows(res.size)
    ratio = problem.scale / problem.first_scale
    return {axis.name: float(math.sqrt(np.mean(res[rows[ax]] ** 2)) * ratio[ax])
            for ax, axis in enumerate(problem.preset.stage.axes) if ax not in problem.still}


__all__ = [
    "BOUNDS", "DETERMINED", "FITTED_FRICTION", "FIXED", "VISCOUS", "Identified", "Regressed",
    "fitted_names", "identify", "inverse_dynamics", "random_axes",
]
