"""Tuning protocols: a controller's parameters searched by any optimiser on a paper's scenarios.

A :class:`Protocol` names the parameters it searches and their box, the registered env ids it
runs (its scenarios), its fitness, and its default optimiser and budget; :data:`PROTOCOLS`
holds them by name. :func:`tune` runs one with any optimiser of :mod:`agents.optim` and, given
a folder, writes the run there (``contour-gym tune PROTOCOL`` on the command line)::

    result = tune("000", seed=0, out="runs/tune/000")   # paper 000, improved PSO, 50 x 100
    result.params                                         # {"k_e": ..., "k_de": ..., ...}

**One batch per generation.** The objective (:class:`PopulationObjective`) evaluates a whole
population at once: one batched :class:`~contour_gym.loop.ServoLoop` per scenario, each
candidate one batch member with its own CCC law parameters
(:meth:`~contour_gym.loop.ServoLoop.set_ccc_params`), every member reset from the same
episode seed, so a candidate's fitness depends on its parameters only, never on the other
members or the batch size (the test checks it bit for bit). The scenario of an env id is the
env's own (its machine, path, estimator, tolerance; ``ideal`` as asked), with the protocol's
CCC law and the env's PID CCC gains as the law's base gains ``kp, ki, kd``, as the reference
policy :class:`~agents.ccc_policies.FuzzyPIDCCC` builds it.

**Failures.** A candidate fails on a scenario when its member does not get in position at the
path end (the loop's divergence test, or not in position ``settle_time`` after the reference
ended), when its largest true contour error exceeds the env's hard limit (``hard_limit``, by
default 100 tolerances: the envs' failure rule), or when its fitness is not finite (NaN never
continues). A candidate that fails on any scenario gets the finite penalty
``PENALTY_HARD_LIMITS * H = 2 H``, ``H`` the largest hard limit of the protocol's scenarios
(1.52 mm on 000's machine): every fitness of :data:`FITNESSES` is at most the largest contour
error, which a candidate that did not fail keeps below ``H``, so a failure never wins and
never crashes the run.

**Search scale.** Parameters marked ``log`` are searched in ``log10`` (the optimiser's box is
``log10`` of theirs; :meth:`Protocol.to_params` maps back), the others linearly. Results are
always reported in the parameters' own (SI) units.

**Run folder** (``out``): ``result.json`` (best parameters by name, best fitness, the
settings, seed, optimiser, wall time and the best-so-far fitness after every generation),
written atomically after every generation (``"status": "running"``, the history so far),
once more at the end (``"complete"``; ``"interrupted"`` on Ctrl-C and ``"failed"`` on an
error, then re-raised); ``convergence.png``; and for the PSO family ``schedules.png``, the
``(w, c1, c2)`` of every generation as :func:`agents.optim.pso.schedules` computes them.

Protocol ``"000"`` (paper 000, section "Adaptive fuzzy PID cross-coupled control based on
improved PSO algorithm"): see :func:`fuzzy_pid_000_params` for the box and :data:`FITNESSES`
for eq. 15. 000 tunes each path on its own; ``"000"`` tunes one set of factors on all three
of its paths (the mean of the three eq.-15 values), and ``"000_circle"``, ``"000_infinity"``,
``"000_trident"`` tune one path each, as 000 does.

Measured on this project's 2-core machine (seed 0, 50 x 101 candidates, rig):
``000_circle`` (5050 episodes of the 2 s circle at 1 kHz, fuzzy PID every tick) searches in
4.0 s on two threads (``benchmarks/paper_tables.py``, quiet machine; the issue's target is
15 s); before the tuner ran on threads, 6.2-8.7 s on a machine shared with other jobs, and
``000`` (all three paths, 15150 episodes) 98-151 s.
``000`` reaches 1.283 um (circle 0.919, "infinity" 1.083, trident 1.848 um; the law's
defaults give 1.92, 2.42, 6.74 um), with ``k_pf`` at the top of its box. Standard PSO against
improved PSO on ``000_circle``, seeds 0-9: median best 0.388 against 0.390 um (ranges
0.372-0.402 and 0.378-0.405 um); on ``000``, seeds 0-2: median 1.286 against 1.283 um
(1.285-1.290 and 1.281-1.289 um, 84-102 s a run): even, not the clear gain 000's figures 10
and 13 show.
What the factors do to the peak errors, and 000's claims: :mod:`agents.ccc_policies`.

Protocol ``"003"`` (paper 003, sections 4-6: ACC2PID on the linear-motor X-Y-Y gantry,
preset ``xyy_gantry``): improved ABC over the 19 parameters of :data:`ACC2PID_NAMES` (three
2PIDs ``Kp, TI, TD, alpha, beta`` and the P compensators ``K_c1x, K_c1y, K_c2x, K_c2y``), box
:func:`acc2pid_003_params`, fitness eq. 38 (:data:`FITNESSES` ``"eq38"``), averaged over the
dual circle and the dual three-leaf (``"003_circle"``, ``"003_three_leaf"``: one each).
Each candidate is one batch member with its own 2PID rows and CCC weights
(:func:`set_acc2pid`). Budget: 003's ``V = 20`` is its number of employed bees (and of
onlookers, section 4 step 1), so the colony is ``population = 40``; ``Phi = 200`` cycles.
Chosen: the fitness window is one 1 s lap of the circle and two 0.5 s passes of the
three-leaf (``scenario_kwargs``; the envs run 003's 10 s windows): 003 tunes online over
some n samples it does not give, and the short window makes the protocol ten times faster.
003 starts its colony at random (eq. 22), and so does this protocol.

Measured on this project's 2-core machine (quiet; seed 0, 40 x 201 candidates, rig): the
search takes 14.4-14.9 s on two threads (25 s on one; ``workers``), against the issue's 15 s.
Every candidate simulates 2 x ~2400 servo ticks at 0.5 ms (the 1 s windows plus getting in
position) through two-dof-PID axes, Stribeck friction, six ripple harmonics and the rig's
encoder and delay; more than half fail and stop within ~100 ticks. Where the time went, and
what took it from 93 s: the ripple's harmonics by recurrence (2 sine calls per axis and
substep instead of 12); the angle estimator's history scan no longer evaluates the path where
the reference rests; a candidate past the hard limit stops on that tick, in the kernel
(:meth:`ServoLoop.run`'s ``stop_above``); the path points the reference and each contour's
estimator share are evaluated once per tick (:func:`contour_gym.contour._history.eval_path_memo`);
a candidate met before is not simulated again (:class:`PopulationObjective`: improved ABC
re-proposes a food source whenever a perturbation is clipped back onto it, 14.5 % of the
candidates); and the threads get slices of equal predicted work. What is left, per tick
(perf): on the three-leaf (868 quintic segments) the exact foot-point searches take 59 %, on
the circle sine and cosine 25 %. Seed 0 reaches 573.7 um (circle 539.6, three-leaf 607.7)
against 1114 um for 003's hand-tuned point (1017, 1211); none of the changes moves the
search's path or its result (same parameters, fitness and history, bit for bit).
Standard ABC against improved ABC over seeds 0-9 (``benchmarks/paper_tables.py``): median
580.9 against 583.4 um, ABC ahead by 0.4 %: even, not the gain 003 reports.
What the parameters do to 003's P_eps and P_e, and 003's claims: :mod:`agents.ccc_policies`.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import threading
import time
import weakref
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import ArrayLike, NDArray

import agents.ccc_laws  # noqa: F401  (registers the fuzzy_pid law)
import contour_gym  # noqa: F401  (registers the env ids)
from agents._files import write_atomically
from agents.ccc_laws import K_DE_000, K_E_000
from agents.optim import OPTIMIZERS, OptimResult, minimize, options_of
from agents.optim._base import make_rng, positive_int
from agents.optim.pso import schedules
from contour_gym._registry import Registry
from contour_gym._validate import choice
from contour_gym.api import Scenario
from contour_gym.envs.config import EnvConfig
from contour_gym.envs.core import _scenario as env_scenario
from contour_gym.loop import ServoLoop
from contour_gym.presets import Preset, get_preset

FloatArray = NDArray[np.float64]
PENALTY_HARD_LIMITS = 2.0  # a failed candidate's fitness, in hard limits (module docstring)
FUZZY_OUTPUT_PEAK = 8.0 / 3.0  # largest |output| of fuzzy_pid_000 (centroids span [-8/3, 8/3])
PSO_FAMILY = ("pso", "improved_pso")


# ------------------------------------------------------------------------------- fitness
def _cea(metrics: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(metrics["cea"], dtype=np.float64)


def _rms(metrics: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(metrics["rms_contour_error"], dtype=np.float64)


def _max(metrics: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(metrics["max_contour_error"], dtype=np.float64)


def _eq38(metrics: Mapping[str, FloatArray]) -> FloatArray:
    tracking = np.asarray(metrics["rms_tracking_error"], dtype=np.float64).sum(axis=1)
    contour = np.asarray(metrics["rms_contour_error_per_contour"], dtype=np.float64).sum(axis=1)
    return np.asarray(tracking + contour, dtype=np.float64)


FITNESSES: dict[str, Callable[[Mapping[str, FloatArray]], FloatArray]] = {
    "cea": _cea,
    "rms": _rms,
    "max": _max,
    "eq38": _eq38,
}
"""Fitness of one scenario from a loop's metrics, (B,), m; each is at most the max |error|.

``cea``: paper 000's eq. (15), ``J = (1/N) sum_i |eps_i|`` over the N servo samples of the
run, ``eps_i`` the true contour error at sample i: the equation was lost in extraction; the
text keeps "where N is the sampling point. eps_i is the contour error modulus at position i",
i.e. a mean of moduli over the samples, which is 000's own CEA ("module average", its
Table 4). Reconstructed as that mean (not a sum, so paths of different durations weigh
alike; not squared, as the text speaks of the modulus). ``rms`` and ``max``: the RMS and the
largest contour error, for other protocols.

``eq38``: paper 003's eq. (38), ``sqrt(mean e_x^2) + sum_i sqrt(mean e_yi^2) + sum_i
sqrt(mean eps_i^2)`` over the n samples of the run: the RMS tracking error of every axis (x,
y1, y2) plus the RMS contour error of every contour (x-y1, x-y2). Reconstructed: the
extraction kept the five mean squares ``(1/n) sum [x_d - x^]^2``, ``(1/n) sum e_yi^2``,
``(1/n) sum eps_i^2`` and the sums over ``i = 1, 2`` but lost any root sign; the roots are
ours (the extraction drops them elsewhere too, and with them the fitness is in metres like
the others and no term's units square away). 003 evaluates it on an observer's predicted
positions ``x^, y^_i``; here the simulated (true) positions are the prediction. 003 keeps
the candidate of "highest fitness" (ABC's ``1/(1 + f)``); minimising ``f`` is the same
order. It sums ``A + C`` errors, none bounded by the contour hard limit, so a protocol using
it has ``A + C`` times the usual penalty and counts ``f >= penalty`` as a failure.
"""

# how many error terms a fitness sums (its penalty scales with it)
FITNESS_TERMS: dict[str, Callable[[Scenario], int]] = {
    "eq38": lambda sc: sc.preset.stage.n_axes + len(sc.preset.stage.contours),
}


# ------------------------------------------------------------------------------ protocols
@dataclass(frozen=True)
class TuneParam:
    """One searched parameter.

    Attributes:
        name: The CCC law parameter's name.
        low: Lower bound, in the parameter's units (> 0 when ``log``).
        high: Upper bound (> ``low``).
        log: Search ``log10`` of the parameter.
        unit: Its unit, for reports.
    """

    name: str
    low: float
    high: float
    log: bool = False
    unit: str = ""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"parameter {self.name!r} needs finite low < high, got "
                             f"[{self.low!r}, {self.high!r}]")  # fmt: skip
        if self.log and self.low <= 0.0:
            raise ValueError(f"log-scaled parameter {self.name!r} needs low > 0, got {self.low!r}")


@dataclass(frozen=True)
class Protocol:
    """A tuning protocol: what to search, on which scenarios, by which fitness, with what budget.

    Attributes:
        name: Registry key.
        params: The searched parameters (D of them), CCC law parameters by name.
        scenarios: Registered env ids (``contour_gym/CCC-...``) the fitness averages over.
        fitness: A key of :data:`FITNESSES`.
        ccc_law: The CCC law whose parameters are searched.
        optimizer: Default optimiser, a key of :data:`agents.optim.OPTIMIZERS`.
        population: Default population (candidates per generation).
        iterations: Default generations after the initial one.
        optimizer_options: Options of the default optimiser.
        episode_seed: Seed every candidate's episodes are reset from.
        doc: What the protocol reproduces.
        setter: How a candidate's parameters reach its batch member, a key of
            :data:`SETTERS`: ``"ccc_law"`` (the CCC law's parameters by name) or
            ``"acc2pid"`` (paper 003's 2PID axes and P compensators, :func:`set_acc2pid`).
        scenario_kwargs: Env id -> env keyword arguments overriding the id's own for this
            protocol (e.g. a shorter window: ``{"laps": 1}``).
    """

    name: str
    params: tuple[TuneParam, ...]
    scenarios: tuple[str, ...]
    fitness: str = "cea"
    ccc_law: str = "fuzzy_pid"
    optimizer: str = "improved_pso"
    population: int = 50
    iterations: int = 100
    optimizer_options: Mapping[str, Any] = field(default_factory=dict)
    episode_seed: int = 0
    doc: str = ""
    setter: str = "ccc_law"
    scenario_kwargs: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        choice(self.fitness, "fitness", FITNESSES)
        choice(self.optimizer, "optimizer", OPTIMIZERS)
        choice(self.setter, "setter", SETTERS)
        stray = sorted(set(self.scenario_kwargs) - set(self.scenarios))
        if stray:
            raise ValueError(f"scenario_kwargs for env ids not in the scenarios: {stray}")
        if not self.params or not self.scenarios:
            raise ValueError(f"protocol {self.name!r} needs parameters and scenarios")

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in search order."""
        return tuple(p.name for p in self.params)

    @property
    def bounds(self) -> FloatArray:
        """(D, 2) box in the parameters' own units."""
        return np.array([(p.low, p.high) for p in self.params], dtype=np.float64)

    @property
    def search_bounds(self) -> FloatArray:
        """(D, 2) box the optimiser searches (``log10`` of the log-scaled parameters)."""
        b = self.bounds
        logs = self._logs()
        b[logs] = np.log10(b[logs])
        return b

    def _logs(self) -> NDArray[np.bool_]:
        return np.array([p.log for p in self.params])

    def to_params(self, z: ArrayLike) -> FloatArray:
        """(n, D) search coordinates -> parameters in their own units, clipped to the box."""
        x = np.array(np.atleast_2d(np.asarray(z, dtype=np.float64)))
        logs = self._logs()
        x[:, logs] = 10.0 ** x[:, logs]
        b = self.bounds
        return np.clip(x, b[:, 0], b[:, 1])

    def to_search(self, x: ArrayLike) -> FloatArray:
        """(n, D) parameters in their own units -> search coordinates."""
        z = np.array(np.atleast_2d(np.asarray(x, dtype=np.float64)))
        logs = self._logs()
        z[:, logs] = np.log10(z[:, logs])
        return z


def _set_ccc_law(loop: ServoLoop, names: Sequence[str], x: FloatArray) -> None:
    loop.set_ccc_params(**{name: x[:, j : j + 1] for j, name in enumerate(names)})


ACC2PID_AXES = ("x", "y1", "y2")
ACC2PID_COMPENSATORS = ("kc1x", "kc1y", "kc2x", "kc2y")
ACC2PID_NAMES = tuple(
    f"{q}_{a}" for a in ACC2PID_AXES for q in ("kp", "ti", "td", "alpha", "beta")
) + ACC2PID_COMPENSATORS
"""Paper 003's 19 ACC2PID parameters in its order (section 5.3's bee ``psi_i``), SI names:
``kp_x ti_x td_x alpha_x beta_x kp_y1 ... beta_y2 kc1x kc1y kc2x kc2y``."""


def acc2pid_rows(x: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """003's 19 parameters per member -> 2PID kernel rows and CCC weights.

    Args:
        x: ``(n, 19)`` in :data:`ACC2PID_NAMES` order, SI: ``Kp`` in V/m, ``TI, TD`` in s,
            ``alpha, beta`` dimensionless, ``K_c`` in V/m of contour error.

    Returns:
        ``(n, 3, P)`` two_dof_pid parameter rows (:func:`contour_gym.servo.two_dof_pid.params_of`)
        and ``(n, 2, 3)`` CCC weights ``[[K_c1x, K_c1y, 0], [K_c2x, K_c2y, 0]]`` (with the
        gantry's PID CCC ``kp = 1``, 003's P compensators eqs. 36-37).

    Raises:
        ValueError: for a shape other than ``(n, 19)`` or a value the 2PID rejects.
    """
    from contour_gym.servo.two_dof_pid import params_of

    v = np.asarray(x, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != len(ACC2PID_NAMES):
        raise ValueError(f"ACC2PID parameters must have shape (n, 19), got {v.shape}")
    rows = params_of(v[:, :15].reshape(-1, 3, 5))
    weights = np.zeros((v.shape[0], 2, 3))
    weights[:, :, :2] = v[:, 15:].reshape(-1, 2, 2)
    return rows, weights


def set_acc2pid(loop: ServoLoop, names: Sequence[str], x: FloatArray) -> None:
    """Give member ``b`` of ``loop`` the ACC2PID of ``x[b]`` (:func:`acc2pid_rows`).

    Raises:
        ValueError: if ``names`` are not :data:`ACC2PID_NAMES` or the loop is not 003's
            2PID gantry (three axes, two contours).
    """
    if tuple(names) != ACC2PID_NAMES:
        raise ValueError(f"the acc2pid setter needs the parameters {ACC2PID_NAMES}")
    if loop.controller.name != "two_dof_pid" or loop.ccc_w.shape[1:] != (2, 3):
        raise ValueError("the acc2pid setter needs 003's two_dof_pid gantry (3 axes, 2 contours)")
    rows, weights = acc2pid_rows(x)
    loop.set_controller_params(rows)
    loop.set_ccc_weights(weights)


SETTERS: dict[str, Callable[[ServoLoop, Sequence[str], FloatArray], None]] = {
    "ccc_law": _set_ccc_law,
    "acc2pid": set_acc2pid,
}
"""How a protocol writes ``(n, D)`` parameters (own units) into the ``n`` members of a loop."""


PROTOCOLS: Registry[Protocol] = Registry("tuning protocol")


def register_protocol(protocol: Protocol, *, replace: bool = False) -> Protocol:
    """Add ``protocol`` to :data:`PROTOCOLS` (under its name); returns it.

    Raises:
        ValueError: for a taken name (unless ``replace``) or an invalid one.
    """
    return PROTOCOLS.register(protocol, replace=replace)


def get_protocol(protocol: str | Protocol) -> Protocol:
    """The protocol itself, or the registered one of that name.

    Raises:
        ValueError: for an unknown name, listing the accepted ones.
    """
    return protocol if isinstance(protocol, Protocol) else PROTOCOLS.get(protocol)


def fuzzy_pid_000_params() -> tuple[TuneParam, ...]:
    """The box of paper 000's five fuzzy PID CCC factors on its machine (``xy_dc_servo``).

    000 gives no box (it "determines the initial values ... by trial and error"). Around the
    law's defaults (:mod:`agents.ccc_laws`, derived from 000's machine), with ``kp0, ki0``
    the machine's PID CCC gains (the law's base gains) and the CCC env's gain range
    ``R = 30`` and ``kd`` scale ``0.01 s`` (:class:`~contour_gym.envs.config.EnvConfig`):

    - ``k_e`` in ``[K_E/10, 100 K_E]``, log (``K_E = 3 / (8 tol)``): the error input
      saturates anywhere from 80 tolerances (608 um, far beyond any peak) down to 0.08 (0.6
      um, below the 1 um encoder count).
    - ``k_de`` in ``[K_DE/100, 10 K_DE]``, log (``K_DE = 1000 s/m``): the rate input
      saturates from 300 mm/s (never) down to 0.3 mm/s (a third of one count per tick).
    - ``k_pf`` in ``[kp0/1000, (R - 1) kp0 * 3/8]``, ``k_if`` likewise with ``ki0``, log:
      from no scheduling at all to a scheduled gain reaching ``R`` times the base gain (the
      fuzzy outputs peak at 8/3), the largest gain the CCC env offers.
    - ``k_df`` in ``[0, 0.01 s * kp0 * 3/8]``, linear (its default 0 is in the box): the
      scheduled ``Kd`` reaches the CCC env's largest kd.
    """
    preset = get_preset("xy_dc_servo")
    env = EnvConfig()
    kp0, ki0 = preset.ccc_gains.kp, preset.ccc_gains.ki
    reach = (env.gain_range - 1.0) / FUZZY_OUTPUT_PEAK
    return (
        TuneParam("k_e", K_E_000 / 10.0, K_E_000 * 100.0, log=True, unit="1/m"),
        TuneParam("k_de", K_DE_000 / 100.0, K_DE_000 * 10.0, log=True, unit="s/m"),
        TuneParam("k_pf", kp0 / 1000.0, reach * kp0, log=True, unit="units of kp"),
        TuneParam("k_if", ki0 / 1000.0, reach * ki0, log=True, unit="units of ki"),
        TuneParam("k_df", 0.0, env.kd_scale * kp0 / FUZZY_OUTPUT_PEAK, unit="units of kd"),
    )


_PATHS_000 = {
    "circle": "contour_gym/CCC-Circle-v0",
    "infinity": "contour_gym/CCC-Infinity-v0",
    "trident": "contour_gym/CCC-Trident-v0",
}
_DOC_000 = (
    "paper 000: improved PSO (m = 50, T = 100) over the fuzzy PID CCC's five factors "
    "(k_e, k_de, k_pf, k_if, k_df), fitness eq. 15 (mean |contour error|)"
)
register_protocol(Protocol(
    "000", fuzzy_pid_000_params(), tuple(_PATHS_000.values()),
    doc=_DOC_000 + ", averaged over the circle, 'infinity' and trident",
))  # fmt: skip
for _path, _env_id in _PATHS_000.items():
    register_protocol(Protocol(
        f"000_{_path}", fuzzy_pid_000_params(), (_env_id,), doc=_DOC_000 + f", {_path} only",
    ))  # fmt: skip


def acc2pid_003_params() -> tuple[TuneParam, ...]:
    """The box of paper 003's 19 ACC2PID parameters on the ``xyy_gantry`` preset, SI.

    003 section 6.3 prints ``psi_min, psi_max`` for the 19 parameters in its own gain units.
    The preset reads them (notes of :func:`contour_gym.presets.get_preset`
    ``("xyy_gantry")``): ``Kp`` in volts per encoder count (50, 10, 10 um on x, y1, y2),
    ``TI, TD`` in s, ``alpha, beta`` dimensionless, the compensators ``K_c`` in volts per mm.
    The box is the printed one in that reading, converted to SI (``Kp`` times 2e4 on x and
    1e5 on y, ``K_c`` times 1e3), with three changes, each keeping 003's hand-tuned point
    (as the preset reads it) inside:

    - ``TI`` in ``[0.01, 10]`` s, log: the printed lower bound 0 is an infinite integral
      gain; 0.01 s is 13 times below the smallest hand-tuned ``TI`` (0.1308 s on y1).
    - ``Kp_y1, Kp_y2`` in ``[0.0001, 0.016]`` per count, log: the printed ``[0.01, 0.016]``
      excludes 003's own hand-tuned ``Kp_y1 = 0.0018`` and ``Kp_y2 = 0.007`` (0.0007 in the
      preset's reading), and every gain in it drives the y loops unstable on the identified
      model (measured: the hand-tuned y2 loop is unstable from about 0.0035 per count); the
      upper end is kept, the lower lowered a hundredfold.
    - ``Kp_x`` in the printed ``[0.001, 0.61]`` per count, but log-searched, as the three
      ``Kp`` and ``TI`` span two to three decades.

    ``TD, alpha, beta`` and the four ``K_c`` keep the printed bounds, searched linearly
    (their lower bounds are 0 or the printed ones).
    """
    preset = get_preset("xyy_gantry")
    counts = [axis.encoder_resolution for axis in preset.stage.axes]
    td_max, alpha_max, beta_max = (0.001, 1e-5, 1e-5), (0.02, 0.002, 0.0002), (1e-5, 1e-6, 1e-6)
    kp_box = ((0.001, 0.61), (0.0001, 0.016), (0.0001, 0.016))
    out: list[TuneParam] = []
    for j, axis in enumerate(ACC2PID_AXES):
        lo, hi = (k / counts[j] for k in kp_box[j])
        out += [
            TuneParam(f"kp_{axis}", lo, hi, log=True, unit="V/m"),
            TuneParam(f"ti_{axis}", 0.01, 10.0, log=True, unit="s"),
            TuneParam(f"td_{axis}", 0.0, td_max[j], unit="s"),
            TuneParam(f"alpha_{axis}", 0.0, alpha_max[j]),
            TuneParam(f"beta_{axis}", 0.0, beta_max[j]),
        ]
    per_mm = 1e3
    for name, (lo, hi) in zip(ACC2PID_COMPENSATORS, ((0.01, 0.31), (0.0001, 0.0031)) * 2,
                              strict=True):  # fmt: skip
        out.append(TuneParam(name, lo * per_mm, hi * per_mm, unit="V/m"))
    params = tuple(out)
    hand = acc2pid_hand_tuned(preset)
    outside = [p.name for p, v in zip(params, hand, strict=True) if not p.low <= v <= p.high]
    if outside:  # the published point must lie inside
        raise RuntimeError(f"003's hand-tuned {outside} outside the box")
    return params


def acc2pid_hand_tuned(preset: Preset) -> FloatArray:
    """003's hand-tuned 19 numbers in SI, read off the gantry preset (its one unit reading).

    ``Kp`` from the preset's axis gains, ``TI = Kp / Ki``, ``TD = Kd / Kp``, ``alpha, beta``
    from its controller options and the compensators from its CCC weights (with ``kp = 1``).

    Returns:
        ``(19,)`` in :data:`ACC2PID_NAMES` order, SI.
    """
    opts = preset.controller_options
    out: list[float] = []
    for j, g in enumerate(preset.axis_gains):
        out += [g.kp, g.kp / g.ki, g.kd / g.kp, opts["alpha"][j], opts["beta"][j]]
    weights = np.broadcast_to(np.asarray(preset.ccc_weights, dtype=np.float64), (2, 3))
    out += [float(w) for row in weights for w in row[:2]]
    return np.array(out, dtype=np.float64)


_PATHS_003 = {
    "circle": "contour_gym/CCC-XYYGantry-Circle-v0",
    "three_leaf": "contour_gym/CCC-XYYGantry-ThreeLeaf-v0",
}
# the fitness window: one 1 s circle lap and two 0.5 s three-leaf passes (the envs run 10 s)
_WINDOW_003: dict[str, Mapping[str, Any]] = {
    _PATHS_003["circle"]: {"laps": 1}, _PATHS_003["three_leaf"]: {"laps": 2},
}
_DOC_003 = (
    "paper 003: improved ABC (V = 20 employed bees, 200 cycles) over the ACC2PID's 19 "
    "parameters (three 2PID axes, two P contour compensators), fitness eq. 38 (sum of the "
    "RMS tracking and contour errors), 1 s windows"
)
_ACC2PID_003: dict[str, Any] = {
    "fitness": "eq38", "ccc_law": "pid", "optimizer": "improved_abc", "population": 40,
    "iterations": 200, "setter": "acc2pid",
}
register_protocol(Protocol(
    "003", acc2pid_003_params(), tuple(_PATHS_003.values()), scenario_kwargs=_WINDOW_003,
    doc=_DOC_003 + ", averaged over the dual circle and the dual three-leaf", **_ACC2PID_003,
))  # fmt: skip
for _path, _env_id in _PATHS_003.items():
    register_protocol(Protocol(
        f"003_{_path}", acc2pid_003_params(), (_env_id,),
        scenario_kwargs={_env_id: _WINDOW_003[_env_id]}, doc=_DOC_003 + f", {_path} only",
        **_ACC2PID_003,
    ))  # fmt: skip


# ------------------------------------------------------------------------------ objective
@dataclass(frozen=True)
class _Case:
    """One scenario of a protocol, built as its env builds it."""

    env_id: str
    scenario: Scenario
    base_gains: tuple[float, float, float]
    hard_limit: float


def _case(
    env_id: str, ccc_law: str, ideal: bool, overrides: Mapping[str, Any] | None = None
) -> _Case:
    if env_id not in gym.registry:
        raise ValueError(f"unknown env id {env_id!r}")
    kwargs = {**gym.spec(env_id).kwargs, **(overrides or {}), "ideal": ideal, "ccc_law": ccc_law}
    config = EnvConfig.from_kwargs(kwargs)
    scenario = env_scenario(config)
    preset = scenario.preset
    kp, ki, kd = config.ccc_gains or preset.ccc_gains.as_tuple()
    hard = config.hard_limit_for(preset)
    return _Case(env_id, scenario, (float(kp), float(ki), float(kd)), float(hard))


MEMO_SIZE = 100_000  # candidates a PopulationObjective remembers (a few hundred bytes each)
RECENT = 400  # recent candidates a PopulationObjective predicts the work of new ones from


class PopulationObjective:
    """A protocol's batch objective: ``(n, D)`` search coordinates -> ``(n,)`` fitness, m.

    The scenarios, and slices of the population, run as separate batches on ``workers``
    threads (the servo loop's kernel releases the GIL), the scenario that has taken the most
    time so far first; every candidate's result is the same for any number of workers and in
    any order (its run depends on its own parameters and seed only). For the same reason a
    candidate met before (the same parameters, bit for bit) is not simulated again: its
    result is remembered (up to :data:`MEMO_SIZE` candidates). Optimisers propose repeats:
    in protocol 003 improved ABC re-proposes a food source whenever a perturbation is
    clipped back onto it, 14.5 % of its candidates and 12.8 % of its simulation time.

    Args:
        protocol: The protocol (or its name).
        ideal: Run the scenarios without the rig's encoder, noise and delay.
        workers: Threads (None: the CPUs this process may use; 1: no threads).

    Attributes:
        penalty: The fitness of a failed candidate (module docstring), m.

    Raises:
        ValueError: for ``workers`` below 1.
    """

    def __init__(
        self, protocol: str | Protocol, ideal: bool = False, workers: int | None = None
    ) -> None:
        self.protocol = get_protocol(protocol)
        self.ideal = bool(ideal)
        self.workers = available_cpus() if workers is None else workers
        if not isinstance(self.workers, int) or self.workers < 1:
            raise ValueError(f"workers must be an int >= 1, got {workers!r}")
        proto = self.protocol
        self.cases = tuple(_case(e, proto.ccc_law, self.ideal, proto.scenario_kwargs.get(e))
                           for e in proto.scenarios)  # fmt: skip
        terms = FITNESS_TERMS.get(proto.fitness, lambda sc: 1)
        self.penalty = PENALTY_HARD_LIMITS * max(c.hard_limit * terms(c.scenario)
                                                 for c in self.cases)  # fmt: skip
        self._set = SETTERS[proto.setter]
        self._fitness = FITNESSES[self.protocol.fitness]
        self._loops: dict[int, list[ServoLoop]] = {}  # slice -> each scenario's loop
        self._lock = threading.Lock()
        # per scenario: seconds and member-ticks simulated so far
        self._cost, self._ticks = np.zeros(len(self.cases)), np.zeros(len(self.cases))
        self._recent_x = np.empty((RECENT, len(self.protocol.params)))
        self._recent_ticks = np.empty((RECENT, len(self.cases)))
        self._n_recent = 0  # candidates simulated so far
        self._pool: ThreadPoolExecutor | None = None
        # candidates met before: parameters (bytes) -> (fitness (S,), failed (S,))
        self._memo: dict[bytes, tuple[FloatArray, NDArray[np.bool_]]] = {}

    def __call__(self, z: FloatArray, /) -> FloatArray:
        """Fitness of each row of ``z`` (search coordinates; see :meth:`Protocol.to_params`)."""
        return self.fitness(self.protocol.to_params(z))

    def fitness(self, params: ArrayLike) -> FloatArray:
        """Fitness of each row of ``params`` (the parameters in their own units), m.

        The mean over the scenarios of the protocol's fitness, or :attr:`penalty` for a
        candidate that failed on any scenario.
        """
        per_case, failed = self.evaluate(params)
        return combine(per_case, failed, self.penalty)

    def evaluate(self, params: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Run every candidate on every scenario.

        Args:
            params: ``(n, D)`` parameters in their own units, in the protocol's order.

        Returns:
            ``(fitness (S, n), failed (S, n))`` per scenario: the protocol's fitness (m) and
            whether the candidate failed there (it then keeps whatever its run measured).

        Raises:
            ValueError: for a shape other than ``(n, D)`` or a value the law rejects.
        """
        x = np.asarray(params, dtype=np.float64)
        d = len(self.protocol.params)
        if x.ndim != 2 or x.shape[1] != d or x.shape[0] < 1:
            raise ValueError(f"params must have shape (n, {d}), got {x.shape}")
        keys = [row.tobytes() for row in x]
        new: dict[bytes, int] = {}  # a candidate not met before -> its first row here
        for r, key in enumerate(keys):
            if key not in self._memo and key not in new:
                new[key] = r
        results: dict[bytes, tuple[FloatArray, NDArray[np.bool_]]] = {}
        if new:
            fit, failed = self._simulate(x[np.fromiter(new.values(), dtype=np.intp)])
            results = {key: (fit[:, c].copy(), failed[:, c].copy()) for c, key in enumerate(new)}
            for key, value in results.items():
                if len(self._memo) < MEMO_SIZE:
                    self._memo[key] = value
        cols = [results[key] if key in results else self._memo[key] for key in keys]
        return (np.stack([c[0] for c in cols], axis=1),
                np.stack([c[1] for c in cols], axis=1))  # fmt: skip

    def _simulate(self, x: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """:meth:`evaluate` without the memo: every row of ``x`` is simulated."""
        n, n_cases = x.shape[0], len(self.cases)
        fit, failed = np.empty((n_cases, n)), np.empty((n_cases, n), dtype=bool)
        ticks = np.empty((n_cases, n))
        units = self._units(x)

        def run(unit: tuple[int, int, NDArray[np.intp]]) -> None:
            i, j, rows = unit
            loop = self._loops_for(n, j)[i]  # one size per batch: no loop built per slice
            start = time.perf_counter()
            fit[i, rows], failed[i, rows] = self._run(self.cases[i], loop, x[rows])
            ticks[i, rows] = loop.ticks_run[: len(rows)]
            with self._lock:
                self._cost[i] += time.perf_counter() - start
                self._ticks[i] += ticks[i, rows].sum()

        if self.workers == 1 or len(units) == 1:
            for unit in units:
                run(unit)
        else:
            list(self._thread_pool().map(run, units))
        self._recall(x, ticks)
        return fit, failed

    def _units(self, x: FloatArray) -> list[tuple[int, int, NDArray[np.intp]]]:
        """Work units ``(scenario, slice, rows)``, dearest first, slices of equal predicted work.

        A candidate's ticks are predicted from a recent candidate that differs from it in at
        most one parameter (an ABC bee's food source: 77 % of protocol 003's candidates; else
        the scenario's mean): one that fails near tick 100 runs 25 times fewer ticks than
        one that gets in position. Each scenario's candidates are dealt to ``workers``
        slices, dearest first, each to the slice with the least work so far; the units run
        longest first. Measured on protocol 003: 15.2-16.5 s with these slices, the
        persistent pool and loops sized per batch, against 16.1-16.9 s before the three; the
        threads still idle ~9 %, mostly in each generation's serial Python.
        """
        n, k = x.shape[0], min(x.shape[0], self.workers)
        mean = np.maximum(self._ticks / max(self._n_recent, 1), 1.0)  # 1: equal counts
        pred = np.repeat(mean[:, None], n, axis=1)
        m = min(self._n_recent, RECENT)
        if m:
            same = (x[:, None, :] == self._recent_x[None, :m]).sum(axis=2)
            best = same.argmax(axis=1)
            near = same[np.arange(n), best] >= x.shape[1] - 1
            pred[:, near] = self._recent_ticks[best[near]].T
        rate = self._cost / np.maximum(self._ticks, 1.0)  # seconds per member-tick
        units = []
        for i in range(len(self.cases)):
            load = np.zeros(k)
            slices: list[list[int]] = [[] for _ in range(k)]
            for r in np.argsort(-pred[i], kind="stable"):
                j = int(load.argmin())
                slices[j].append(int(r))
                load[j] += pred[i, r]
            units += [(rate[i] * load[j], i, j, np.array(sorted(rows), dtype=np.intp))
                      for j, rows in enumerate(slices) if rows]  # fmt: skip
        units.sort(key=lambda u: -u[0])
        return [(i, j, rows) for _, i, j, rows in units]

    def _recall(self, x: FloatArray, ticks: FloatArray) -> None:
        """Keep the last :data:`RECENT` candidates and their ticks for :meth:`_units`."""
        for row, t in zip(x, ticks.T, strict=True):
            slot = self._n_recent % RECENT
            self._recent_x[slot], self._recent_ticks[slot] = row, t
            self._n_recent += 1

    def _thread_pool(self) -> ThreadPoolExecutor:
        """The objective's worker threads (started once, shut down with the objective)."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.workers)
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def metrics(self, params: ArrayLike) -> list[dict[str, FloatArray]]:
        """Every scenario's full loop metrics for each candidate (``(n,)`` arrays, SI)."""
        x = np.atleast_2d(np.asarray(params, dtype=np.float64))
        n = x.shape[0]
        out = []
        for case, loop in zip(self.cases, self._loops_for(n), strict=True):
            self._run(case, loop, x)
            out.append({**{k: v[:n] for k, v in loop.metrics().items()},
                        "failed": loop.failed[:n].astype(float),
                        "finished": loop.done[:n].astype(float)})  # fmt: skip
        return out

    def _loops_for(self, n: int, part: int = 0) -> list[ServoLoop]:
        """Each scenario's loop for ``n`` candidates of slice ``part`` (one per thread).

        A part's loops hold the most candidates it has been given so far and run as many as
        it has now (:meth:`_run`): the memo and the balanced slices leave batches of any
        size, and building a loop took ~40 ms.
        """
        with self._lock:
            loops = self._loops.get(part)
            if loops is None or loops[0].batch_size < n:
                loops = self._loops[part] = [
                    c.scenario.loop(batch_size=n, ccc_gains=c.base_gains) for c in self.cases
                ]
            return loops

    def _run(
        self, case: _Case, loop: ServoLoop, x: FloatArray
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        n, size = x.shape[0], loop.batch_size
        if n < size:  # the spare members get the last candidate's values and sit out
            x = np.concatenate([x, np.repeat(x[-1:], size - n, axis=0)])
        self._set(loop, self.protocol.names, x)
        # every member from the same seed: a candidate's result is its own (loop docstring)
        loop.reset([self.protocol.episode_seed] * size)
        # a member past the hard limit stops on that tick, in the kernel: it fails whatever it
        # does next, and a diverging candidate's ticks are the slowest (its error widens every
        # foot-point search); stopping it there, not at the end of a 256-tick call, took
        # protocol 003 on one thread from 63 s to 34 s
        run = loop.run(stop_above=case.hard_limit, members=np.arange(n) if n < size else None)
        metrics = {k: v[:n] for k, v in run.items()}
        f = self._fitness(metrics)
        failed = (~loop.done[:n] | ~np.isfinite(f)
                  | ~(metrics["max_contour_error"] <= case.hard_limit))  # fmt: skip
        return f, failed | ~(f < self.penalty)


def available_cpus() -> int:
    """CPUs this process may run on (its affinity where the OS tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def combine(per_case: ArrayLike, failed: ArrayLike, penalty: float) -> FloatArray:
    """Total fitness: the mean over scenarios, ``penalty`` wherever a scenario failed.

    Args:
        per_case: ``(S, n)`` fitness per scenario and candidate.
        failed: ``(S, n)`` failures (a non-finite fitness counts as one).
        penalty: Finite fitness of a failed candidate.

    Returns:
        ``(n,)`` finite fitness.
    """
    f = np.asarray(per_case, dtype=np.float64)
    bad = np.asarray(failed, dtype=bool) | ~np.isfinite(f)
    mean = np.where(bad, 0.0, f).mean(axis=0)
    return np.where(bad.any(axis=0), float(penalty), mean)


# ----------------------------------------------------------------------------------- runs
@dataclass(frozen=True)
class TuneResult:
    """Outcome of :func:`tune`.

    Attributes:
        protocol: Protocol name.
        optimizer: Optimiser name.
        seed: The optimiser's seed.
        params: Best parameters by name, in their own units.
        fitness: Their fitness, m (the protocol's; :attr:`PopulationObjective.penalty` if
            every candidate failed).
        history: Best-so-far fitness after each generation, non-increasing, m.
        per_scenario: Env id -> the best parameters' fitness there, m.
        nfev: Candidates evaluated.
        wall_time: Seconds the search took.
        settings: Everything else the run was given (budget, box, scales, options, ...).
        out: The run folder, or None.
    """

    protocol: str
    optimizer: str
    seed: int
    params: dict[str, float]
    fitness: float
    history: list[float]
    per_scenario: dict[str, float]
    nfev: int
    wall_time: float
    settings: dict[str, Any]
    out: Path | None = None

    def to_json(self) -> dict[str, Any]:
        """The ``result.json`` content (``"status": "complete"``)."""
        return {
            "status": "complete", "protocol": self.protocol, "optimizer": self.optimizer,
            "seed": self.seed, "params": self.params, "fitness": self.fitness,
            "fitness_unit": "m", "per_scenario": self.per_scenario, "nfev": self.nfev,
            "wall_time_s": self.wall_time, "settings": self.settings,
            "generations": len(self.history), "history": self.history,
        }  # fmt: skip


class _Monitor:
    """Wraps the objective: counts generations, keeps the best so far, reports each generation.

    Every optimiser evaluates exactly ``population`` candidates per generation (in one or
    several calls), so generation ``k`` ends when ``population * (k + 1)`` candidates are done;
    the best so far is kept as :class:`agents.optim._base.Problem` keeps it (first strict
    minimum; non-finite values count as ``inf``), so the history equals the optimiser's.
    """

    def __init__(
        self, objective: PopulationObjective, population: int,
        on_generation: Callable[[_Monitor], None], bar: Any,
    ) -> None:  # fmt: skip
        self.objective, self.population = objective, population
        self.on_generation, self.bar = on_generation, bar
        self.nfev, self.best_f = 0, math.inf
        self.best_z: FloatArray | None = None
        self.history: list[float] = []

    def __call__(self, z: FloatArray, /) -> FloatArray:
        f = self.objective(z)
        for row, value in zip(z, f, strict=True):
            v = float(value) if math.isfinite(value) else math.inf
            if self.best_z is None or v < self.best_f:
                self.best_f, self.best_z = v, np.array(row)
            self.nfev += 1
            if self.nfev % self.population == 0 and self.nfev > self.population:
                self.history.append(self.best_f)
                self.on_generation(self)
        if self.bar is not None:
            self.bar.update(len(f))
            self.bar.set_postfix_str(f"best {self.best_f * 1e6:.4g} um", refresh=False)
        return f


def tune(
    protocol: str | Protocol,
    optimizer: str | None = None,
    *,
    seed: int = 0,
    population: int | None = None,
    iterations: int | None = None,
    ideal: bool = False,
    out: str | os.PathLike[str] | None = None,
    progress: bool = True,
    options: Mapping[str, Any] | None = None,
    command: str | None = None,
    workers: int | None = None,
    overwrite: bool = False,
) -> TuneResult:
    """Run a tuning protocol with an optimiser.

    Args:
        protocol: A :data:`PROTOCOLS` name or a :class:`Protocol`.
        optimizer: A key of :data:`agents.optim.OPTIMIZERS` (None: the protocol's).
        seed: The optimiser's seed (the episodes use the protocol's ``episode_seed``).
        population: Candidates per generation (None: the protocol's).
        iterations: Generations after the initial one (None: the protocol's).
        ideal: Run the scenarios without the rig's encoder, noise and delay.
        out: Run folder for ``result.json`` and the plots (module docstring); None writes
            nothing.
        progress: Show a progress bar (tqdm, on stderr).
        options: The optimiser's own options (None: the protocol's for its own optimiser,
            else none).
        command: The command line to record in ``result.json`` (None: the equivalent
            ``contour-gym tune`` command).
        workers: Threads running the population (:class:`PopulationObjective`; None: every
            CPU). The result does not depend on it.
        overwrite: Replace a finished result in ``out`` (else refused: :func:`check_run_folder`).

    Returns:
        The :class:`TuneResult`.

    Raises:
        ValueError: for an unknown protocol or optimiser (listing the accepted names), or a
            bad budget, seed or option (naming it).
    """
    proto = get_protocol(protocol)
    name = choice(optimizer or proto.optimizer, "optimizer", OPTIMIZERS)
    if options is None:
        options = proto.optimizer_options if name == proto.optimizer else {}
    unknown = sorted(set(options) - set(options_of(name)))
    if unknown:
        raise ValueError(f"unknown option(s) {', '.join(unknown)} for {name!r}; accepted: "
                         f"{', '.join(options_of(name))}")  # fmt: skip
    m = proto.population if population is None else population
    t = proto.iterations if iterations is None else iterations
    _check_budget(m, t, seed)
    folder = None if out is None else Path(out)
    if folder is not None:
        check_run_folder(folder, overwrite)
    settings: dict[str, Any] = {
        "population": m, "iterations": t, "ideal": bool(ideal), "scenarios": list(proto.scenarios),
        "fitness": proto.fitness, "ccc_law": proto.ccc_law, "episode_seed": proto.episode_seed,
        "setter": proto.setter, "scenario_kwargs": {k: dict(v) for k, v in
                                                    proto.scenario_kwargs.items()},
        "bounds": {p.name: [p.low, p.high] for p in proto.params},
        "log_scaled": [p.name for p in proto.params if p.log],
        "optimizer_options": dict(options),
        "command": command or _command(proto.name, name, seed, m, t, ideal, out),
    }  # fmt: skip
    if name in PSO_FAMILY:  # checks the budget too, before any simulation
        settings["schedules"] = schedules(name, t, **options).tolist()
    objective = PopulationObjective(proto, ideal=ideal, workers=workers)
    settings["penalty"] = objective.penalty
    start = time.perf_counter()

    def partial(mon: _Monitor, status: str = "running") -> None:
        if folder is not None:
            _write_json(folder / "result.json", _partial_json(proto, name, seed, settings, mon,
                                                              time.perf_counter() - start, status))

    from tqdm.auto import tqdm

    bar = tqdm(total=m * (t + 1), desc=f"tune {proto.name} ({name})", unit="cand",
               disable=not progress, dynamic_ncols=True)  # fmt: skip
    monitor = _Monitor(objective, m, partial, bar)
    try:
        res = minimize(name, monitor, proto.search_bounds, population=m, iterations=t,
                       seed=seed, **options)  # fmt: skip
    except KeyboardInterrupt:
        partial(monitor, "interrupted")
        raise
    except BaseException:
        partial(monitor, "failed")
        raise
    finally:
        bar.close()
    wall = time.perf_counter() - start
    result = _result(proto, res, objective, seed, settings, wall, folder)
    if folder is not None:
        _write_json(folder / "result.json", result.to_json())
        write_plots(result, folder)
    return result


def _result(
    proto: Protocol, res: OptimResult, objective: PopulationObjective, seed: int,
    settings: dict[str, Any], wall: float, folder: Path | None,
) -> TuneResult:  # fmt: skip
    best = proto.to_params(res.x)
    per_case, failed = objective.evaluate(best)
    per = {c.env_id: float(objective.penalty if failed[i, 0] else per_case[i, 0])
           for i, c in enumerate(objective.cases)}  # fmt: skip
    return TuneResult(
        protocol=proto.name, optimizer=res.name, seed=int(seed),
        params={n: float(v) for n, v in zip(proto.names, best[0], strict=True)},
        fitness=float(res.fun), history=[float(h) for h in res.history], per_scenario=per,
        nfev=int(res.nfev), wall_time=float(wall), settings=settings, out=folder,
    )  # fmt: skip


def _partial_json(
    proto: Protocol, name: str, seed: int, settings: dict[str, Any], mon: _Monitor, wall: float,
    status: str,
) -> dict[str, Any]:  # fmt: skip
    params = None
    if mon.best_z is not None:
        best = proto.to_params(mon.best_z)[0]
        params = {n: float(v) for n, v in zip(proto.names, best, strict=True)}
    return {
        "status": status, "protocol": proto.name, "optimizer": name, "seed": int(seed),
        "params": params, "fitness": mon.best_f if math.isfinite(mon.best_f) else None,
        "fitness_unit": "m", "nfev": mon.nfev, "wall_time_s": wall, "settings": settings,
        "generations": len(mon.history), "history": list(mon.history),
    }  # fmt: skip


def _command(
    proto: str, optimizer: str, seed: int, m: int, t: int, ideal: bool,
    out: str | os.PathLike[str] | None,
) -> str:  # fmt: skip
    args = ["contour-gym", "tune", proto, "--optimizer", optimizer, "--seed", str(seed),
            "--population", str(m), "--iterations", str(t)]  # fmt: skip
    if ideal:
        args.append("--ideal")
    if out is not None:
        args += ["--out", os.fspath(out)]
    return shlex.join(args)


def _check_budget(population: Any, iterations: Any, seed: Any) -> None:
    # before anything runs or is written: a bad budget must not touch a run folder
    positive_int(population, "population")
    positive_int(iterations, "iterations")
    make_rng(seed)


def check_run_folder(folder: Path, overwrite: bool) -> None:
    """Refuse a run folder that is a file or holds a finished result (unless ``overwrite``).

    An unfinished result (``"status"`` running, interrupted or failed) is replaced: a tuning
    run restarts from its first generation (the optimisers keep no state to resume from).

    Raises:
        ValueError: naming the folder or file, and how to go on.
    """
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--out {folder} is a file, not a folder")
    target = folder / "result.json"
    if overwrite or not target.exists():
        return
    try:
        status = json.loads(target.read_text(encoding="utf-8")).get("status")
    except (OSError, ValueError, AttributeError) as exc:
        raise ValueError(f"{target} cannot be read ({exc}); pass --overwrite to replace it, "
                         "or choose another --out") from None  # fmt: skip
    if status == "complete":
        raise ValueError(f"{target} holds a finished tuning result; pass --overwrite to "
                         "replace it, or choose another --out")  # fmt: skip


def _write_json(target: Path, data: Mapping[str, Any]) -> None:
    """Write ``data`` as JSON, whole or not at all (:func:`agents._files.write_atomically`)."""
    text = json.dumps(data, indent=2) + "\n"
    write_atomically(target, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def write_plots(result: TuneResult, folder: str | os.PathLike[str]) -> list[Path]:
    """Write ``convergence.png`` and, for the PSO family, ``schedules.png`` into ``folder``.

    Returns:
        The files written.
    """
    from matplotlib.figure import Figure

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    gens = np.arange(1, len(result.history) + 1)
    fig = Figure(figsize=(6.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(gens, np.asarray(result.history) * 1e6, drawstyle="steps-post")
    ax.set(xlabel="generation", ylabel=f"best fitness ({result.settings['fitness']}, um)",
           title=f"tune {result.protocol}: {result.optimizer}, seed {result.seed}")  # fmt: skip
    ax.grid(True, alpha=0.3)
    written = [folder / "convergence.png"]
    fig.savefig(written[0], dpi=120)
    sched = result.settings.get("schedules")
    if sched is not None:
        arr = np.asarray(sched)
        fig = Figure(figsize=(6.0, 4.0), layout="constrained")
        ax = fig.add_subplot()
        for j, label in enumerate(("w", "c1", "c2")):
            ax.plot(np.arange(1, len(arr) + 1), arr[:, j], label=label)
        ax.set(xlabel="generation", ylabel="coefficient",
               title=f"{result.optimizer}: inertia weight and learning factors")  # fmt: skip
        ax.legend()
        ax.grid(True, alpha=0.3)
        written.append(folder / "schedules.png")
        fig.savefig(written[-1], dpi=120)
    return written


def compare(
    protocol: str | Protocol, optimizers: Sequence[str], seeds: Sequence[int], **kwargs: Any
) -> dict[str, list[float]]:
    """Best fitness of each optimiser over several seeds (no files, no progress bar).

    Args:
        protocol: A :data:`PROTOCOLS` name or a :class:`Protocol`.
        optimizers: Keys of :data:`agents.optim.OPTIMIZERS`.
        seeds: Optimiser seeds.
        **kwargs: More :func:`tune` arguments (``population``, ``iterations``, ``ideal``).

    Returns:
        Optimiser -> best fitness per seed, m.
    """
    return {name: [tune(protocol, name, seed=s, progress=False, **kwargs).fitness for s in seeds]
            for name in optimizers}  # fmt: skip


__all__ = [
    "ACC2PID_NAMES",
    "FITNESSES",
    "FITNESS_TERMS",
    "PENALTY_HARD_LIMITS",
    "PROTOCOLS",
    "PopulationObjective",
    "Protocol",
    "TuneParam",
    "SETTERS",
    "TuneResult",
    "acc2pid_003_params",
    "acc2pid_hand_tuned",
    "acc2pid_rows",
    "combine",
    "compare",
    "fuzzy_pid_000_params",
    "get_protocol",
    "register_protocol",
    "set_acc2pid",
    "tune",
    "write_plots",
]
