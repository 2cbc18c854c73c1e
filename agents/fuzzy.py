"""Fuzzy rule bases defined with scikit-fuzzy, evaluated by compiled batched numba kernels.

**Definition.** A :class:`FuzzySystem` is a frozen description: input and output
:class:`Variable` s (a uniform universe ``linspace(low, high, n_points)`` and named
:class:`FuzzySet` s, each a ``skfuzzy.membership`` function sampled on that universe), a
table of :class:`Rule` s and the inference kind. Membership between samples is the linear
interpolation skfuzzy uses (``fuzz.interp_membership``), in the reference and the kernels
alike, so both work on the same arrays. Two kinds:

- ``"mamdani"``: min for AND, min implication, max aggregation, centroid defuzzification
  (the defaults of ``skfuzzy.control``). Inputs are clipped to their universes first (as
  ``ControlSystemSimulation(clip_to_bounds=True)`` does). Where no rule fires the aggregate
  is empty: skfuzzy then omits the output (``reference_evaluate`` gives NaN), the compiled
  code returns the middle of the output universe.
- ``"product_centre_average"`` (paper 001): singleton fuzzifier, product inference,
  centre-average defuzzifier, ``y = theta . xi(x)`` with the fuzzy basis functions
  ``xi_l(x) = prod_i mu_{A_i^l}(x_i) / sum_l prod_i mu_{A_i^l}(x_i)`` (:func:`basis`);
  ``theta`` (one row per output) is adapted online by the caller; :func:`initial_theta`
  gives the centres of the rules' output sets. Inputs are clipped to their universes.
  skfuzzy.control has no product inference or centre-average defuzzifier, so the
  reference is plain numpy on skfuzzy's memberships (:func:`reference_basis`).

**Reference.** :func:`control_system` builds the equivalent ``skfuzzy.control`` system,
fresh every call (simulations that share rule or variable objects but differ in ``cache=``
return stale outputs silently); :func:`reference_evaluate` runs it. It is the reference the
compiled code is tested against, never the hot path: one ``compute()`` costs 60-100 ms for
000's 49 rules and 4-6 ms for 004's 8 (networkx re-sorts the rules on every call).

**Compiled evaluation, and the choice between exact inference and a surface.**
:func:`mamdani_exact_into` replicates skfuzzy's arithmetic (the output universe upsampled at
the points where each clipped set crosses its cut, the aggregate sampled there, its
piecewise-linear centroid) and matches ``ControlSystemSimulation`` to < 1e-15 of the output
range, but costs 4.3-4.8 us per member (601-sample output universes): too slow for the 1 us
per member target. The default is therefore a precomputed surface (:class:`Surface`,
:func:`surface_eval`) for two-input systems, tabulated by the exact kernel at build time.
Plain bilinear interpolation of the output failed: the min/max kinks and the steep
centroid near the universe edges (a half set of small area against a weakly firing one)
left 0.05 of 6 (dKd of 000) at 241 nodes per input and 0.016 at 1201, converging only
linearly. What passes: tabulate the aggregate's moment and area (smooth piecewise
polynomials of the firing strengths, without the division's steepness) and interpolate each
linearly on triangles, every grid square split along the diagonal that interpolates the
exact value at its centre better (so the split follows the diagonal kinks ``mu_e = mu_de``),
then divide. With 241 nodes per input (spacing 0.025 on [-3, 3], 1/120 on [-1, 1]: half
the spacing of the sets is a whole number of node spacings, so the lines where two
memberships of these evenly spaced sets are equal, along which min and max kink, run
along grid lines or square diagonals) the largest deviation from the exact inference over
1e5 random inputs is 2.4e-4 (000) and 2.3e-4 (004) of the output range. Measured with
``benchmarks/fuzzy.py`` (2 shared cores, medians; ranges over three runs):

================================  ==========  ==========  =================  ===========
system / method                   skfuzzy     B = 1       B = 1024           max error
================================  ==========  ==========  =================  ===========
fuzzy_pid_000, surface (default)  60-100 ms   4.1 us      0.07 us/member     1.5e-4
fuzzy_pid_000, exact                          9.4-9.7 us  4.6-4.8 us/member  7e-16
fuzzy_feedrate_004, surface       4.4-6.2 ms  4.1-6.5 us  0.06 us/member     1.1e-4
fuzzy_feedrate_004, exact                     9.2-9.4 us  4.3-4.5 us/member  9e-16
adaptive_fuzzy_001, 5 sets        0.17 ms     7.0-7.2 us  0.15 us/member     7e-16 (abs)
adaptive_fuzzy_001, 7 sets        0.25 ms     7.1-7.5 us  0.21 us/member     9e-16 (abs)
================================  ==========  ==========  =================  ===========

(skfuzzy: one ``compute()``, or for 001 the numpy reference; max error: of the output
range, against skfuzzy on 300 random inputs plus every pair of set peaks and the universe
corners; B = 1 includes the Python call and the input checks.)
Tabulating a surface takes 0.5-0.9 s at a system's first use (:func:`compile_system`, cached).

**Calling the kernels from other compiled code.** The lookups are plain
``@numba.njit(cache=True, inline="always")`` functions of plain arrays, e.g. in the servo
loop kernel, per member and tick::

    sf = fuzzy_pid_000().compiled.surface        # outside: tables, flips, grid, empty
    surface_eval_into(sf.tables, sf.flips, sf.grid, sf.empty, k_e * eps, k_de * deps, d_k)

A component that gets one constant float vector (a CCC law's ``data``,
:mod:`contour_gym.ccc`) takes the surface flattened by :func:`surface_table` and reads it with
:func:`surface_eval_flat` (views of the same numbers, then :func:`surface_eval`: bit for bit
the same output)::

    data = surface_table(fuzzy_pid_000().compiled.surface)    # outside, once
    d_kp = surface_eval_flat(data, 0, k_e * eps, k_de * deps)  # inside, per output

and for 001, with workspaces ``mu`` (n_in, S) and ``xi`` (L,)::

    c = adaptive_fuzzy_001().compiled
    product_basis_into(c.inputs.mf, c.inputs.meta, c.ant, x, mu, xi)
    product_output_into(theta, xi, y)

**The papers' rule bases.** :func:`fuzzy_pid_000` (000's lost tables 1-3 replaced by Liu
Jinkun's classic self-tuning fuzzy PID tables), :func:`adaptive_fuzzy_001` (001's sets and
table lost; set count and shape chosen) and :func:`fuzzy_feedrate_004` (004's table 3.1 as
it survived extraction); each docstring says what is reconstructed and what is chosen.
Scaling (000's quantisation factors ``k_e, k_de`` and proportional factors, 004's gains
``g_e, g_ce, g_dF``) is applied by the caller: the systems work on normalised universes.
"""

from __future__ import annotations

import functools
import math
import operator
import warnings
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np
import skfuzzy as fuzz
from numpy.typing import ArrayLike, NDArray
from skfuzzy import control as ctrl

from contour_gym._validate import as_finite_array, choice, finite

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

MAMDANI = "mamdani"
PRODUCT = "product_centre_average"
KINDS = (MAMDANI, PRODUCT)
MF_KINDS = {"trimf": 3, "trapmf": 4, "gaussmf": 2}  # skfuzzy.membership name -> parameter count
LABELS7 = ("NB", "NM", "NS", "ZO", "PS", "PM", "PB")
DEFAULT_POINTS = 601  # samples of every universe (step 0.01 on [-3, 3])
DEFAULT_SURFACE_POINTS = 241  # surface nodes per input; the module docstring says why
FEEDRATE_GAIN_004 = 0.35  # 004 section IV: g_dF, applied by the caller to dF
EPS = 2.220446049250313e-16  # np.finfo(float).eps, as skfuzzy's centroid floors the area


# ----------------------------------------------------------------------------------------
# definition
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FuzzySet:
    """A named membership function, sampled by ``skfuzzy.membership`` on its universe.

    Attributes:
        name: Linguistic label, e.g. ``"NB"``.
        kind: ``"trimf"`` (params a <= b <= c), ``"trapmf"`` (a <= b <= c <= d) or
            ``"gaussmf"`` (mean, sigma > 0; 004's bell ``exp(-(x - b)^2 / a)`` is
            ``gaussmf`` with mean ``b`` and ``sigma = sqrt(a / 2)``).
        params: The skfuzzy parameters, in skfuzzy's order.
    """

    name: str
    kind: str
    params: tuple[float, ...]

    def __post_init__(self) -> None:
        choice(self.kind, f"membership kind of set {self.name!r}", MF_KINDS)
        params = tuple(float(p) for p in self.params)
        object.__setattr__(self, "params", params)
        if len(params) != MF_KINDS[self.kind] or not all(math.isfinite(p) for p in params):
            raise ValueError(
                f"set {self.name!r}: {self.kind} needs {MF_KINDS[self.kind]} finite "
                f"parameters, got {params}"
            )
        if self.kind == "gaussmf" and params[1] <= 0.0:
            raise ValueError(f"set {self.name!r}: gaussmf sigma must be > 0, got {params[1]}")
        if self.kind != "gaussmf" and list(params) != sorted(params):
            raise ValueError(f"set {self.name!r}: {self.kind} parameters must be non-decreasing")

    def sample(self, universe: Array) -> Array:
        """Membership values on ``universe``, computed by ``skfuzzy.membership``."""
        if self.kind == "trimf":
            return np.asarray(fuzz.trimf(universe, list(self.params)), dtype=np.float64)
        if self.kind == "trapmf":
            return np.asarray(fuzz.trapmf(universe, list(self.params)), dtype=np.float64)
        mean, sigma = self.params
        return np.asarray(fuzz.gaussmf(universe, mean, sigma), dtype=np.float64)

    @property
    def centre(self) -> float:
        """Where the set peaks: the centre a centre-average defuzzifier uses."""
        p = self.params
        if self.kind == "trimf":
            return p[1]
        if self.kind == "trapmf":
            return 0.5 * (p[1] + p[2])
        return p[0]


@dataclass(frozen=True)
class Variable:
    """A fuzzy variable: a uniform universe ``linspace(low, high, n_points)`` and its sets.

    Attributes:
        name: Variable name (an skfuzzy Antecedent / Consequent label).
        low: Lower end of the universe.
        high: Upper end of the universe (> low).
        sets: The fuzzy sets, each unimodal and non-zero somewhere on the universe.
        n_points: Samples of the universe (>= 2). Membership between samples is the linear
            interpolation skfuzzy uses (``fuzz.interp_membership``).
    """

    name: str
    low: float
    high: float
    sets: tuple[FuzzySet, ...]
    n_points: int = DEFAULT_POINTS

    def __post_init__(self) -> None:
        object.__setattr__(self, "sets", tuple(self.sets))
        for end in ("low", "high"):
            object.__setattr__(self, end, finite(getattr(self, end), f"{self.name} {end}"))
        if self.low >= self.high:
            raise ValueError(
                f"variable {self.name!r}: universe low must be < high, "
                f"got [{self.low}, {self.high}]"
            )
        if int(self.n_points) != self.n_points or self.n_points < 2:
            raise ValueError(f"variable {self.name!r}: n_points must be an integer >= 2")
        if not self.sets:
            raise ValueError(f"variable {self.name!r} has no fuzzy sets")
        names = [s.name for s in self.sets]
        if len(set(names)) != len(names):
            raise ValueError(f"variable {self.name!r}: duplicate set names {names}")
        for s, mf in zip(self.sets, self.memberships(), strict=True):
            if not mf.max() > 0.0:
                raise ValueError(f"variable {self.name!r}: set {s.name!r} is 0 on the universe")
            peak = int(np.argmax(mf))
            if np.any(np.diff(mf[: peak + 1]) < 0.0) or np.any(np.diff(mf[peak:]) > 0.0):
                raise ValueError(f"variable {self.name!r}: set {s.name!r} is not unimodal")

    @property
    def set_names(self) -> tuple[str, ...]:
        """The set labels, in order."""
        return tuple(s.name for s in self.sets)

    def universe(self) -> Array:
        """The sampled universe, ``np.linspace(low, high, n_points)``."""
        return np.linspace(self.low, self.high, int(self.n_points))

    def memberships(self) -> Array:
        """(n_sets, n_points) membership of every set on the sampled universe."""
        u = self.universe()
        return np.stack([s.sample(u) for s in self.sets])

    def index(self, set_name: str, where: str) -> int:
        """Position of ``set_name`` among the sets; ValueError naming ``where`` if unknown."""
        try:
            return self.set_names.index(set_name)
        except ValueError:
            raise ValueError(
                f"{where}: variable {self.name!r} has no set {set_name!r} "
                f"(sets: {', '.join(self.set_names)})"
            ) from None


@dataclass(frozen=True)
class Rule:
    """IF input_1 is A_1 AND ... AND input_n is A_n THEN output_1 is C_1, ..., output_m is C_m.

    Attributes:
        when: One set name per input, in the system's input order (AND of all of them).
        then: One set name per output, in the system's output order.
    """

    when: tuple[str, ...]
    then: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "when", tuple(str(w) for w in self.when))
        object.__setattr__(self, "then", tuple(str(t) for t in self.then))


@dataclass(frozen=True)
class FuzzySystem:
    """A frozen description of a fuzzy system: variables, rules and the inference kind.

    Attributes:
        name: A label for reports.
        kind: ``"mamdani"`` (min AND, min implication, max aggregation, centroid; the
            defaults of ``skfuzzy.control``) or ``"product_centre_average"`` (singleton
            fuzzifier, product inference, centre-average defuzzifier, paper 001).
        inputs: The input variables.
        outputs: The output variables.
        rules: The rule base.
        surface_points: Surface nodes per input of a two-input Mamdani system.

    Raises:
        ValueError: on an unknown kind, repeated variable names, a rule of the wrong length
            or naming a set its variable does not have.
    """

    name: str
    kind: str
    inputs: tuple[Variable, ...]
    outputs: tuple[Variable, ...]
    rules: tuple[Rule, ...]
    surface_points: int = DEFAULT_SURFACE_POINTS

    def __post_init__(self) -> None:
        for part in ("inputs", "outputs", "rules"):
            object.__setattr__(self, part, tuple(getattr(self, part)))
        choice(self.kind, "fuzzy system kind", KINDS)
        if not self.inputs or not self.outputs or not self.rules:
            raise ValueError(f"system {self.name!r} needs inputs, outputs and rules")
        names = [v.name for v in self.inputs + self.outputs]
        if len(set(names)) != len(names):
            raise ValueError(f"system {self.name!r}: duplicate variable names {names}")
        if int(self.surface_points) != self.surface_points or self.surface_points < 2:
            raise ValueError(f"system {self.name!r}: surface_points must be an integer >= 2")
        self.antecedent_indices()
        self.consequent_indices()

    @functools.cached_property
    def compiled(self) -> CompiledMamdani | CompiledProduct:
        """The kernel arrays (:func:`compile_system`), kept on this instance."""
        return compile_system(self)

    def antecedent_indices(self) -> IntArray:
        """(R, n_in) set index of every rule's antecedent per input."""
        return _rule_indices(self.rules, self.inputs, "when")

    def consequent_indices(self) -> IntArray:
        """(R, n_out) set index of every rule's consequent per output."""
        return _rule_indices(self.rules, self.outputs, "then")


def _rule_indices(rules: tuple[Rule, ...], variables: tuple[Variable, ...], part: str) -> IntArray:
    out = np.empty((len(rules), len(variables)), dtype=np.int64)
    for r, rule in enumerate(rules):
        labels = getattr(rule, part)
        if len(labels) != len(variables):
            raise ValueError(
                f"rule {r}: '{part}' names {len(labels)} sets, the system has "
                f"{len(variables)} {'inputs' if part == 'when' else 'outputs'}"
            )
        for k, (label, var) in enumerate(zip(labels, variables, strict=True)):
            out[r, k] = var.index(label, f"rule {r}")
    return out


# ----------------------------------------------------------------------------------------
# the scikit-fuzzy reference (never the hot path)
# ----------------------------------------------------------------------------------------


def control_system(system: FuzzySystem) -> ctrl.ControlSystem:
    """A fresh ``skfuzzy.control.ControlSystem`` equivalent to a Mamdani ``system``.

    Every call builds new Antecedent / Consequent / Rule objects: skfuzzy simulations that
    share them but differ in ``cache=`` mode return stale outputs silently.

    Raises:
        ValueError: if ``system`` is not Mamdani (skfuzzy.control has no product inference
            or centre-average defuzzifier).
    """
    if system.kind != MAMDANI:
        raise ValueError(f"control_system needs a mamdani system, got kind {system.kind!r}")
    ants = [_skfuzzy_variable(ctrl.Antecedent, v) for v in system.inputs]
    cons = [_skfuzzy_variable(ctrl.Consequent, v) for v in system.outputs]
    rules = []
    for r, rule in enumerate(system.rules):
        terms = [a[label] for a, label in zip(ants, rule.when, strict=True)]
        antecedent = functools.reduce(operator.and_, terms)
        consequent = [c[label] for c, label in zip(cons, rule.then, strict=True)]
        rules.append(ctrl.Rule(antecedent, consequent, label=f"rule{r}"))
    return ctrl.ControlSystem(rules)


def _skfuzzy_variable(cls: Any, var: Variable) -> Any:
    fv = cls(var.universe(), var.name)
    for s, mf in zip(var.sets, var.memberships(), strict=True):
        fv[s.name] = mf
    return fv


def reference_evaluate(
    system: FuzzySystem, inputs: ArrayLike, *, vectorised: bool = False
) -> Array:
    """Evaluate a Mamdani ``system`` with scikit-fuzzy's ``ControlSystemSimulation``.

    One fresh control system and simulation per call. Slow: skfuzzy re-sorts the rules with
    networkx on every ``compute()``.

    Args:
        system: A Mamdani system.
        inputs: (B, n_in) crisp inputs (skfuzzy clips them to the universes).
        vectorised: False: one ``compute()`` per row (``cache=False``). True: skfuzzy's
            array-input mode, one ``compute()`` for the whole batch (same arithmetic, one
            rule sort); skfuzzy supports it only if every output set appears in a rule, and
            it raises skfuzzy's ``EmptyMembershipError`` on an empty aggregate.

    Returns:
        (B, n_out) outputs; in row mode NaN where skfuzzy produced none (every rule fired
        0, so the aggregate is empty and the lenient simulation omits that output).

    Raises:
        ValueError: on bad inputs, a non-Mamdani system, or ``vectorised`` with an output
            set that no rule uses.
    """
    x = _check_inputs(system, inputs)
    with warnings.catch_warnings():
        # skfuzzy 0.5 passes np.maximum's output positionally; numpy 2.4 deprecates that
        warnings.filterwarnings("ignore", "Passing more than 2 positional", DeprecationWarning)
        return _reference_evaluate(system, x, vectorised)


def _reference_evaluate(system: FuzzySystem, x: Array, vectorised: bool) -> Array:
    sim = ctrl.ControlSystemSimulation(control_system(system), cache=False)
    if vectorised:
        used = system.consequent_indices()
        for o, var in enumerate(system.outputs):
            if len(np.unique(used[:, o])) != len(var.sets):
                raise ValueError(
                    f"vectorised reference needs every set of output {var.name!r} in a rule"
                )
        for i, var in enumerate(system.inputs):
            sim.input[var.name] = x[:, i].copy()
        sim.compute()
        return np.stack([np.asarray(sim.output[v.name], dtype=float) for v in system.outputs], -1)
    out = np.full((x.shape[0], len(system.outputs)), np.nan)
    for b in range(x.shape[0]):
        for var, value in zip(system.inputs, x[b], strict=True):
            sim.input[var.name] = float(value)
        sim.compute()
        for o, var in enumerate(system.outputs):
            out[b, o] = float(sim.output.get(var.name, np.nan))
    return out


def reference_basis(system: FuzzySystem, inputs: ArrayLike) -> Array:
    """Fuzzy basis functions of a product / centre-average system in plain numpy.

    ``xi_l(x) = prod_i mu_{A_i^l}(x_i) / sum_l prod_i mu_{A_i^l}(x_i)``, the memberships
    from ``fuzz.interp_membership`` on the skfuzzy-sampled sets, inputs clipped to their
    universes; all zeros where no rule fires. skfuzzy.control has no product inference or
    centre-average defuzzifier, so this is the reference the compiled basis is tested against.

    Args:
        system: Any system (only its inputs and rule antecedents are used).
        inputs: (B, n_in) crisp inputs.

    Returns:
        (B, L) basis functions.
    """
    x = _check_inputs(system, inputs)
    ant = system.antecedent_indices()
    w = np.ones((x.shape[0], ant.shape[0]))
    for i, var in enumerate(system.inputs):
        xi = np.clip(x[:, i], var.low, var.high)
        mu = np.stack([fuzz.interp_membership(var.universe(), mf, xi) for mf in var.memberships()])
        w *= mu[ant[:, i]].T
    total = w.sum(axis=1, keepdims=True)
    return np.divide(w, total, out=np.zeros_like(w), where=total > 0.0)


# ----------------------------------------------------------------------------------------
# kernels (plain njit functions on plain arrays, callable from other compiled code)
# ----------------------------------------------------------------------------------------

# columns of a variables' ``meta`` table (see SampledVariables)
M_LOW, M_HIGH, M_STEP, M_POINTS, M_SETS = 0, 1, 2, 3, 4


@numba.njit(cache=True, inline="always")
def _grid_point(j, n, lo, hi, step):
    # np.linspace(lo, hi, n)[j], bit for bit
    return hi if j == n - 1 else j * step + lo


@numba.njit(cache=True, inline="always")
def _has_nan(x):
    for v in x:  # noqa: SIM110 (a loop: no generator or temporary array in the kernel)
        if v != v:
            return True
    return False


@numba.njit(cache=True, inline="always")
def fuzzify_into(mf, meta, x, mu):
    """Membership of crisp inputs in every set, as ``np.interp`` on the sampled sets.

    Args:
        mf: (n_in, S, N) sampled sets, zero-padded.
        meta: (n_in, 5) universe low, high, step, sample count and set count per input.
        x: (n_in,) crisp inputs, not NaN; each is clipped to its universe.
        mu: (n_in, S) result.
    """
    for i in range(x.shape[0]):
        lo, hi, step = meta[i, M_LOW], meta[i, M_HIGH], meta[i, M_STEP]
        n = int(meta[i, M_POINTS])
        xc = min(max(x[i], lo), hi)
        j = min(int((xc - lo) / step), n - 2)
        uj = _grid_point(j, n, lo, hi, step)
        du = _grid_point(j + 1, n, lo, hi, step) - uj
        for s in range(int(meta[i, M_SETS])):
            if xc >= hi:
                mu[i, s] = mf[i, s, n - 1]
            else:
                f0 = mf[i, s, j]
                mu[i, s] = (mf[i, s, j + 1] - f0) / du * (xc - uj) + f0


@numba.njit(cache=True, inline="always")
def _fire_into(mu, ant, cons, cut):
    # min AND over the inputs, max aggregation of the rules per output set
    cut[:, :] = 0.0
    for r in range(ant.shape[0]):
        w = mu[0, ant[r, 0]]
        for i in range(1, ant.shape[1]):
            w = min(w, mu[i, ant[r, i]])
        for o in range(cons.shape[1]):
            t = cons[r, o]
            if w > cut[o, t]:
                cut[o, t] = w


@numba.njit(cache=True, inline="always")
def _aggregate_at(mf, meta, o, cut, j, x):
    # the clipped-and-maxed membership of output o at x inside universe interval j
    lo, hi, step, n = meta[o, M_LOW], meta[o, M_HIGH], meta[o, M_STEP], int(meta[o, M_POINTS])
    uj = _grid_point(j, n, lo, hi, step)
    du = _grid_point(j + 1, n, lo, hi, step) - uj
    y = 0.0
    for t in range(int(meta[o, M_SETS])):
        c = cut[o, t]
        if c > 0.0:
            f0 = mf[o, t, j]
            y = max(y, min(c, (mf[o, t, j + 1] - f0) / du * (x - uj) + f0))
    return y


@numba.njit(cache=True)
def _crossings(mf, meta, sup, o, t, c, buf, nb):
    # where set t of output o crosses its cut c (skfuzzy's _interp_universe_fast): at most
    # two for a unimodal set; appended to buf[nb:], returns the new count
    lo, hi, step, n = meta[o, M_LOW], meta[o, M_HIGH], meta[o, M_STEP], int(meta[o, M_POINTS])
    for j in range(max(sup[o, t, 0] - 1, 0), min(sup[o, t, 1], n - 2) + 1):
        a = mf[o, t, j]
        b = mf[o, t, j + 1]
        if (a >= c) != (b >= c) and nb < buf.shape[0]:
            uj = _grid_point(j, n, lo, hi, step)
            buf[nb] = uj + (c - a) * (_grid_point(j + 1, n, lo, hi, step) - uj) / (b - a)
            nb += 1
    return nb


@numba.njit(cache=True, inline="always")
def _sort_prefix(buf, nb):
    # insertion sort of buf[:nb] (nb <= 2 * sets)
    for a in range(1, nb):
        v = buf[a]
        k = a - 1
        while k >= 0 and buf[k] > v:
            buf[k + 1] = buf[k]
            k -= 1
        buf[k + 1] = v


@numba.njit(cache=True, inline="always")
def _fired_span(meta, sup, o, cut):
    # samples of output o around the sets that fired (the aggregate is 0 elsewhere)
    n = int(meta[o, M_POINTS])
    jlo, jhi = n, -1
    for t in range(int(meta[o, M_SETS])):
        if cut[o, t] > 0.0:  # a cut of 0 adds zeros, and crossings only at universe points
            jlo = min(jlo, sup[o, t, 0])
            jhi = max(jhi, sup[o, t, 1])
    return max(jlo - 1, 0), min(jhi + 1, n - 1), jhi >= 0


@numba.njit(cache=True)
def _centroid(mf, meta, sup, o, cut, agg, buf):
    # skfuzzy's CrispValueCalculator.defuzz: the universe upsampled at the cut crossings,
    # the aggregate sampled there, its piecewise-linear moment and area (0, 0 if empty)
    jlo, jhi, fired = _fired_span(meta, sup, o, cut)
    if not fired:
        return 0.0, 0.0
    lo, hi, step, n = meta[o, M_LOW], meta[o, M_HIGH], meta[o, M_STEP], int(meta[o, M_POINTS])
    agg[jlo : jhi + 1] = 0.0
    nb = 0
    for t in range(int(meta[o, M_SETS])):
        c = cut[o, t]
        if c > 0.0:
            for j in range(sup[o, t, 0], sup[o, t, 1] + 1):
                agg[j] = max(agg[j], min(c, mf[o, t, j]))
            nb = _crossings(mf, meta, sup, o, t, c, buf, nb)
    _sort_prefix(buf, nb)
    num = 0.0
    den = 0.0
    px = _grid_point(jlo, n, lo, hi, step)
    py = agg[jlo]
    k = 0
    for j in range(jlo + 1, jhi + 1):
        uj = _grid_point(j, n, lo, hi, step)
        while k < nb and buf[k] < uj:
            x = buf[k]
            y = _aggregate_at(mf, meta, o, cut, j - 1, x)
            num += (x - px) * (py * (2.0 * px + x) + y * (px + 2.0 * x))
            den += (x - px) * (py + y)
            px, py = x, y
            k += 1
        y = agg[j]
        num += (uj - px) * (py * (2.0 * px + uj) + y * (px + 2.0 * uj))
        den += (uj - px) * (py + y)
        px, py = uj, y
    return num / 6.0, 0.5 * den


@numba.njit(cache=True)
def mamdani_exact_into(
    in_mf, in_meta, ant, cons, out_mf, out_meta, out_sup, x, mu, cut, agg, buf, out, raw
):
    """Exact Mamdani inference of one member, as skfuzzy's ``ControlSystemSimulation``.

    min AND, min implication, max aggregation; centroid of the aggregate sampled on the
    output universe upsampled at the cut crossings, integrated piecewise linearly (what
    skfuzzy does). Inputs are clipped to their universes. An empty aggregate (no rule
    fired) gives the middle of the output universe (skfuzzy gives no output there).

    Args:
        in_mf: (n_in, S, N) sampled input sets (:class:`SampledVariables`).
        in_meta: (n_in, 5) input universes and set counts.
        ant: (R, n_in) antecedent set indices.
        cons: (R, n_out) consequent set indices.
        out_mf: (n_out, T, M) sampled output sets.
        out_meta: (n_out, 5) output universes and set counts.
        out_sup: (n_out, T, 2) first and last sample where each output set is > 0.
        x: (n_in,) crisp inputs (any NaN: every output NaN).
        mu: (n_in, S) workspace.
        cut: (n_out, T) workspace.
        agg: (M,) workspace.
        buf: (2 T,) workspace.
        out: (n_out,) result.
        raw: (n_out, 2) receives each aggregate's moment and area; pass (0, 2) to skip.
    """
    if _has_nan(x):
        out[:] = np.nan
        raw[:, :] = np.nan
        return
    fuzzify_into(in_mf, in_meta, x, mu)
    _fire_into(mu, ant, cons, cut)
    for o in range(out.shape[0]):
        moment, area = _centroid(out_mf, out_meta, out_sup, o, cut, agg, buf)
        if area > 0.0:
            out[o] = moment / max(area, EPS)
        else:
            out[o] = 0.5 * (out_meta[o, M_LOW] + out_meta[o, M_HIGH])
        if raw.shape[0] > 0:
            raw[o, 0] = moment
            raw[o, 1] = area


@numba.njit(cache=True)
def _mamdani_exact_batch(
    in_mf, in_meta, ant, cons, out_mf, out_meta, out_sup, x, out, raw
):
    mu = np.zeros((in_mf.shape[0], in_mf.shape[1]))
    cut = np.zeros((out_mf.shape[0], out_mf.shape[1]))
    agg = np.zeros(out_mf.shape[2])
    buf = np.zeros(2 * out_mf.shape[1])
    for b in range(x.shape[0]):
        mamdani_exact_into(
            in_mf,
            in_meta,
            ant,
            cons,
            out_mf,
            out_meta,
            out_sup,
            x[b],
            mu,
            cut,
            agg,
            buf,
            out[b],
            raw[b],
        )


@numba.njit(cache=True, inline="always")
def _cell(x, lo, step, n):
    # interval index and fraction of x on the nodes lo + k step, k < n, clipped to the ends
    u = (x - lo) / step
    if u <= 0.0:
        return 0, 0.0
    if u >= n - 1:
        return n - 2, 1.0
    i = min(int(u), n - 2)
    return i, u - i


@numba.njit(cache=True, inline="always")
def _split_square(tables, flips, o, p, i, k, t, s):
    # linear interpolation on the half of square (i, k) that holds (t, s); the square is
    # split along the diagonal flips[o, p, i, k] marks (0: (i, k)-(i+1, k+1), 1: the other)
    f00 = tables[o, p, i, k]
    f10 = tables[o, p, i + 1, k]
    f01 = tables[o, p, i, k + 1]
    f11 = tables[o, p, i + 1, k + 1]
    if flips[o, p, i, k] == 0:
        if t >= s:
            return f00 + t * (f10 - f00) + s * (f11 - f10)
        return f00 + s * (f01 - f00) + t * (f11 - f01)
    if t + s <= 1.0:
        return f00 + t * (f10 - f00) + s * (f01 - f00)
    return f11 + (1.0 - t) * (f01 - f11) + (1.0 - s) * (f10 - f11)


@numba.njit(cache=True, inline="always")
def _surface_ratio(tables, flips, empty, o, i, k, t, s):
    area = _split_square(tables, flips, o, 1, i, k, t, s)
    if area <= 0.0:
        return empty[o]
    return _split_square(tables, flips, o, 0, i, k, t, s) / max(area, EPS)


@numba.njit(cache=True, inline="always")
def surface_eval(tables, flips, grid, empty, o, x0, x1):
    """Output ``o`` of a two-input Mamdani surface at one point; inlinable into other kernels.

    The output is ``moment / area`` of the aggregate, both interpolated linearly on the
    triangles of a node grid whose squares are split along the diagonal that follows the
    min/max kinks (:class:`Surface`).

    Args:
        tables: (n_out, 2, G0, G1) moment and area of each output's aggregate at the nodes
            ``(grid[0] + i grid[1], grid[2] + k grid[3])``.
        flips: (n_out, 2, G0 - 1, G1 - 1) uint8 diagonal of each square.
        grid: (4,) first node and node spacing of input 0, then of input 1.
        empty: (n_out,) output where the aggregate is empty (middle of the output universe).
        o: Output index.
        x0: First crisp input; clipped to the grid (its universe).
        x1: Second crisp input; clipped to the grid.

    Returns:
        The output (NaN if an input is NaN).
    """
    if x0 != x0 or x1 != x1:
        return np.nan
    i, t = _cell(x0, grid[0], grid[1], tables.shape[2])
    k, s = _cell(x1, grid[2], grid[3], tables.shape[3])
    return _surface_ratio(tables, flips, empty, o, i, k, t, s)


@numba.njit(cache=True, inline="always")
def surface_eval_into(tables, flips, grid, empty, x0, x1, out):
    """Every output of a two-input Mamdani surface at one point (the cell is found once).

    Args:
        tables: (n_out, 2, G0, G1) moment and area at the nodes (see :func:`surface_eval`).
        flips: (n_out, 2, G0 - 1, G1 - 1) uint8 diagonal of each square.
        grid: (4,) first node and node spacing of input 0, then of input 1.
        empty: (n_out,) output where the aggregate is empty.
        x0: First crisp input; clipped to the grid.
        x1: Second crisp input; clipped to the grid.
        out: (n_out,) result (NaN if an input is NaN).
    """
    if x0 != x0 or x1 != x1:
        out[:] = np.nan
        return
    i, t = _cell(x0, grid[0], grid[1], tables.shape[2])
    k, s = _cell(x1, grid[2], grid[3], tables.shape[3])
    for o in range(tables.shape[0]):
        out[o] = _surface_ratio(tables, flips, empty, o, i, k, t, s)


@numba.njit(cache=True)
def _surface_batch(tables, flips, grid, empty, x, out):
    for b in range(x.shape[0]):
        surface_eval_into(tables, flips, grid, empty, x[b, 0], x[b, 1], out[b])


# a surface as one float64 vector: header (n_out, G0, G1, grid[4]), empty (n_out,), tables
# (n_out, 2, G0, G1), flips (n_out, 2, G0 - 1, G1 - 1) as 0.0 / 1.0, all C order
FLAT_HEADER = 7


def surface_table(surface: Surface) -> Array:
    """A surface flattened into one float64 vector (the layout :func:`surface_views` reads).

    Header ``n_out, G0, G1`` and the 4 grid numbers, then ``empty``, ``tables`` and ``flips``
    (as 0.0 / 1.0), each in C order.

    Args:
        surface: A tabulated surface (``compile_system(system).surface``).

    Returns:
        The (7 + n_out + 2 n_out G0 G1 + 2 n_out (G0 - 1) (G1 - 1),) vector.
    """
    n_out, _, g0, g1 = surface.tables.shape
    head = np.array([n_out, g0, g1], dtype=np.float64)
    parts = (head, surface.grid, surface.empty, surface.tables, surface.flips)
    return np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in parts])


@numba.njit(cache=True, inline="always")
def surface_views(data):
    """``tables, flips, grid, empty`` of a :func:`surface_table` vector, as views (no copy).

    ``flips`` is a float view (0.0 / 1.0); :func:`surface_eval` compares it with 0 either way.
    """
    n_out, g0, g1 = int(data[0]), int(data[1]), int(data[2])
    a = FLAT_HEADER
    grid = data[3:a]
    empty = data[a : a + n_out]
    a += n_out
    size = n_out * 2 * g0 * g1
    tables = data[a : a + size].reshape((n_out, 2, g0, g1))
    a += size
    size = n_out * 2 * (g0 - 1) * (g1 - 1)
    flips = data[a : a + size].reshape((n_out, 2, g0 - 1, g1 - 1))
    return tables, flips, grid, empty


@numba.njit(cache=True, inline="always")
def surface_eval_flat(data, o, x0, x1):
    """:func:`surface_eval` on a :func:`surface_table` vector (the same output, bit for bit).

    Args:
        data: The flattened surface.
        o: Output index.
        x0: First crisp input; clipped to the grid.
        x1: Second crisp input; clipped to the grid.

    Returns:
        The output (NaN if an input is NaN).
    """
    tables, flips, grid, empty = surface_views(data)
    return surface_eval(tables, flips, grid, empty, o, x0, x1)


@numba.njit(cache=True)
def _surface_flat_batch(data, x, out):
    for b in range(x.shape[0]):
        for o in range(out.shape[1]):
            out[b, o] = surface_eval_flat(data, o, x[b, 0], x[b, 1])


@numba.njit(cache=True, inline="always")
def product_basis_into(mf, meta, ant, x, mu, xi):
    """Fuzzy basis functions of one member (singleton fuzzifier, product inference).

    ``xi_l = prod_i mu_{A_i^l}(x_i) / sum_l prod_i mu_{A_i^l}(x_i)``; all zeros if no rule
    fires. Inputs are clipped to their universes.

    Args:
        mf: (n_in, S, N) sampled input sets (:class:`SampledVariables`).
        meta: (n_in, 5) input universes and set counts.
        ant: (L, n_in) antecedent set indices (integers, or whole floats: a table read
            from one float vector).
        x: (n_in,) crisp inputs (any NaN: every basis function NaN).
        mu: (n_in, S) workspace.
        xi: (L,) result.
    """
    if _has_nan(x):
        xi[:] = np.nan
        return
    fuzzify_into(mf, meta, x, mu)
    total = 0.0
    for rule in range(ant.shape[0]):
        w = 1.0
        for i in range(ant.shape[1]):
            w *= mu[i, int(ant[rule, i])]
        xi[rule] = w
        total += w
    for rule in range(ant.shape[0]):
        xi[rule] = xi[rule] / total if total > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def product_output_into(theta, xi, out):
    """Centre-average outputs of one member, ``out[o] = sum_l theta[o, l] xi[l]``.

    Args:
        theta: (n_out, L) consequent centres.
        xi: (L,) basis functions (:func:`product_basis_into`).
        out: (n_out,) result.
    """
    for o in range(theta.shape[0]):
        y = 0.0
        for rule in range(xi.shape[0]):
            y += theta[o, rule] * xi[rule]
        out[o] = y


@numba.njit(cache=True)
def _product_batch(mf, meta, ant, theta, x, xi, out):
    mu = np.zeros((mf.shape[0], mf.shape[1]))
    for b in range(x.shape[0]):
        product_basis_into(mf, meta, ant, x[b], mu, xi[b])
        product_output_into(theta, xi[b], out[b])


# ----------------------------------------------------------------------------------------
# compilation to arrays
# ----------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SampledVariables:
    """Variables as kernel arrays: zero-padded sampled sets and their universes.

    Attributes:
        mf: (n_var, S, N) every set sampled on its variable's universe by
            ``skfuzzy.membership`` (the arrays the skfuzzy reference holds), zero-padded.
        meta: (n_var, 5) universe low, high, step, sample count and set count (columns
            ``M_LOW``, ``M_HIGH``, ``M_STEP``, ``M_POINTS``, ``M_SETS``).
        support: (n_var, S, 2) int64 first and last sample where each set is > 0.
    """

    mf: Array
    meta: Array
    support: IntArray

    @classmethod
    def of(cls, variables: tuple[Variable, ...]) -> SampledVariables:
        """Sample ``variables`` into padded arrays."""
        s_max = max(len(v.sets) for v in variables)
        n_max = max(int(v.n_points) for v in variables)
        mf = np.zeros((len(variables), s_max, n_max))
        support = np.zeros((len(variables), s_max, 2), dtype=np.int64)
        meta = np.zeros((len(variables), 5))
        for k, var in enumerate(variables):
            m = var.memberships()
            mf[k, : m.shape[0], : m.shape[1]] = m
            for s in range(m.shape[0]):
                nz = np.flatnonzero(m[s] > 0.0)
                support[k, s] = nz[0], nz[-1]
            n = int(var.n_points)
            meta[k] = var.low, var.high, (var.high - var.low) / (n - 1), n, len(var.sets)
        return cls(mf, meta, support)


@dataclass(frozen=True, eq=False)
class Surface:
    """A two-input Mamdani system tabulated for :func:`surface_eval` (arrays only).

    Attributes:
        tables: (n_out, 2, G0, G1) moment and area of each output's aggregate at the nodes,
            from the exact compiled inference; the output is their ratio.
        flips: (n_out, 2, G0 - 1, G1 - 1) uint8: 0 splits a square along its
            (i, k)-(i+1, k+1) diagonal, 1 along the other: whichever interpolates the exact
            value at the square's centre better (so the split follows a min/max kink).
        grid: (4,) first node and node spacing of input 0, then of input 1.
        empty: (n_out,) output where the aggregate is empty (the middle of its universe).
    """

    tables: Array
    flips: NDArray[np.uint8]
    grid: Array
    empty: Array


@dataclass(frozen=True, eq=False)
class CompiledMamdani:
    """A Mamdani system as kernel arrays, with its surface when it has two inputs.

    Attributes:
        system: The definition.
        inputs: Sampled input sets.
        outputs: Sampled output sets.
        ant: (R, n_in) antecedent set indices.
        cons: (R, n_out) consequent set indices.
        surface: The surface (two-input systems), else None.
    """

    system: FuzzySystem
    inputs: SampledVariables
    outputs: SampledVariables
    ant: IntArray
    cons: IntArray
    surface: Surface | None = None

    def workspace(self) -> tuple[Array, Array, Array, Array]:
        """Fresh ``mu, cut, agg, buf`` workspaces for :func:`mamdani_exact_into`."""
        i, o = self.inputs.mf.shape, self.outputs.mf.shape
        return np.zeros(i[:2]), np.zeros(o[:2]), np.zeros(o[2]), np.zeros(2 * o[1])

    def exact(self, x: Array, raw: Array | None = None) -> Array:
        """Exact compiled inference on checked inputs.

        Args:
            x: (B, n_in) finite inputs, C-contiguous.
            raw: Optional (B, n_out, 2) array that receives each aggregate's moment and area.

        Returns:
            (B, n_out) outputs.
        """
        out = np.empty((x.shape[0], self.cons.shape[1]))
        raw_ = np.empty((x.shape[0], 0, 2)) if raw is None else raw
        i, o = self.inputs, self.outputs
        _mamdani_exact_batch(
            i.mf, i.meta, self.ant, self.cons, o.mf, o.meta, o.support, x, out, raw_
        )
        return out

    def lookup(self, x: Array) -> Array:
        """Surface lookup on checked (B, 2) C-contiguous inputs."""
        if self.surface is None:
            raise ValueError(f"system {self.system.name!r} has no surface (needs 2 inputs)")
        sf = self.surface
        out = np.empty((x.shape[0], sf.tables.shape[0]))
        _surface_batch(sf.tables, sf.flips, sf.grid, sf.empty, x, out)
        return out

    def with_surface(self) -> CompiledMamdani:
        """A copy with the surface tabulated on ``system.surface_points`` nodes per input."""
        g = int(self.system.surface_points)
        nodes = [np.linspace(v.low, v.high, g) for v in self.system.inputs]
        at_nodes = self._raw_grid(nodes[0], nodes[1])
        at_mids = self._raw_grid(*(0.5 * (n[1:] + n[:-1]) for n in nodes))
        slash = 0.5 * (at_nodes[..., :-1, :-1] + at_nodes[..., 1:, 1:])
        back = 0.5 * (at_nodes[..., 1:, :-1] + at_nodes[..., :-1, 1:])
        flips = (np.abs(back - at_mids) < np.abs(slash - at_mids)).astype(np.uint8)
        grid = np.array([[v.low, (v.high - v.low) / (g - 1)] for v in self.system.inputs])
        empty = np.array([0.5 * (v.low + v.high) for v in self.system.outputs])
        surface = Surface(at_nodes, flips, grid.ravel(), empty)
        return CompiledMamdani(self.system, self.inputs, self.outputs, self.ant, self.cons, surface)

    def _raw_grid(self, n0: Array, n1: Array) -> Array:
        # (n_out, 2, len(n0), len(n1)) moment and area on the grid n0 x n1
        points = np.stack(np.meshgrid(n0, n1, indexing="ij"), axis=-1).reshape(-1, 2)
        raw = np.empty((points.shape[0], self.cons.shape[1], 2))
        self.exact(np.ascontiguousarray(points), raw)
        grid = raw.reshape(len(n0), len(n1), -1, 2).transpose(2, 3, 0, 1)
        return np.ascontiguousarray(grid)


@dataclass(frozen=True, eq=False)
class CompiledProduct:
    """A product / centre-average system as kernel arrays.

    Attributes:
        system: The definition.
        inputs: Sampled input sets.
        ant: (L, n_in) antecedent set indices.
        theta0: (n_out, L) initial consequent centres (the centres of the rules' output sets).
    """

    system: FuzzySystem
    inputs: SampledVariables
    ant: IntArray
    theta0: Array


@functools.lru_cache(maxsize=32)
def compile_system(system: FuzzySystem) -> CompiledMamdani | CompiledProduct:
    """Compile a definition to kernel arrays (cached per definition; see also ``.compiled``).

    A two-input Mamdani system also gets its :class:`Surface`, tabulated by the exact
    compiled inference at ``surface_points`` nodes per input plus one point per square.
    """
    inputs = SampledVariables.of(system.inputs)
    ant = system.antecedent_indices()
    cons = system.consequent_indices()
    if system.kind == PRODUCT:
        centres = np.array(
            [[var.sets[c].centre for c in cons[:, o]] for o, var in enumerate(system.outputs)]
        )
        return CompiledProduct(system, inputs, ant, centres)
    compiled = CompiledMamdani(system, inputs, SampledVariables.of(system.outputs), ant, cons)
    return compiled.with_surface() if len(system.inputs) == 2 else compiled


# ----------------------------------------------------------------------------------------
# batched evaluation for Python callers
# ----------------------------------------------------------------------------------------


def _check_inputs(system: FuzzySystem, inputs: ArrayLike) -> Array:
    return np.ascontiguousarray(
        as_finite_array(inputs, "inputs", ndim=2, shape=(None, len(system.inputs)))
    )


def evaluate(
    system: FuzzySystem, inputs: ArrayLike, *, method: str = "auto", theta: ArrayLike | None = None
) -> Array:
    """Evaluate a fuzzy system on a batch of crisp inputs.

    Args:
        system: The definition (compiled on first use, then cached).
        inputs: (B, n_in) crisp inputs, finite; clipped to the input universes.
        method: Mamdani only: ``"surface"`` (the precomputed surface, two inputs only),
            ``"exact"`` (compiled inference matching skfuzzy) or ``"auto"`` (the surface
            when there is one).
        theta: Product / centre-average only: (n_out, L) consequent centres; default the
            initial ones (:func:`initial_theta`).

    Returns:
        (B, n_out) outputs.

    Raises:
        ValueError: on misshaped or non-finite ``inputs`` or ``theta``, or an option that
            does not apply to the system's kind.
    """
    compiled = system.compiled
    x = _check_inputs(system, inputs)
    if isinstance(compiled, CompiledProduct):
        if method != "auto":
            raise ValueError(f"method applies to mamdani systems only, got {method!r}")
        return _product_eval(compiled, x, theta)[1]
    if theta is not None:
        raise ValueError("theta applies to product_centre_average systems only")
    choice(method, "method", ("auto", "surface", "exact"))
    if method == "exact" or (method == "auto" and compiled.surface is None):
        return compiled.exact(x)
    return compiled.lookup(x)


def basis(system: FuzzySystem, inputs: ArrayLike) -> Array:
    """Fuzzy basis functions of a product / centre-average system.

    Args:
        system: A ``product_centre_average`` system.
        inputs: (B, n_in) crisp inputs, finite; clipped to the input universes.

    Returns:
        (B, L) basis functions ``xi``; each row sums to 1 (all zeros if no rule fires).
    """
    compiled = system.compiled
    x = _check_inputs(system, inputs)
    if not isinstance(compiled, CompiledProduct):
        raise ValueError(f"basis needs a {PRODUCT} system, got kind {system.kind!r}")
    return _product_eval(compiled, x, None)[0]


def initial_theta(system: FuzzySystem) -> Array:
    """(n_out, L) initial consequent centres of a product / centre-average system."""
    compiled = system.compiled
    if not isinstance(compiled, CompiledProduct):
        raise ValueError(f"initial_theta needs a {PRODUCT} system, got kind {system.kind!r}")
    return compiled.theta0.copy()


def _product_eval(
    compiled: CompiledProduct, x: Array, theta: ArrayLike | None
) -> tuple[Array, Array]:
    th = (
        compiled.theta0
        if theta is None
        else as_finite_array(theta, "theta", shape=compiled.theta0.shape)
    )
    xi = np.empty((x.shape[0], compiled.ant.shape[0]))
    out = np.empty((x.shape[0], th.shape[0]))
    i = compiled.inputs
    _product_batch(i.mf, i.meta, compiled.ant, np.ascontiguousarray(th), x, xi, out)
    return xi, out


# ----------------------------------------------------------------------------------------
# the papers' rule bases
# ----------------------------------------------------------------------------------------


def _triangles(labels: tuple[str, ...], low: float, high: float) -> tuple[FuzzySet, ...]:
    # evenly spaced triangles, half triangles (shoulders) at the universe ends
    peaks = np.linspace(low, high, len(labels))
    step = peaks[1] - peaks[0]
    return tuple(
        FuzzySet(name, "trimf", (max(p - step, low), p, min(p + step, high)))
        for name, p in zip(labels, peaks.tolist(), strict=True)
    )


def _gaussians(
    labels: tuple[str, ...], low: float, high: float, cross: float
) -> tuple[FuzzySet, ...]:
    # evenly spaced Gaussians; neighbours cross at membership `cross`
    centres = np.linspace(low, high, len(labels))
    half = 0.5 * (centres[1] - centres[0])
    sigma = half / math.sqrt(-2.0 * math.log(cross))
    return tuple(
        FuzzySet(name, "gaussmf", (c, sigma))
        for name, c in zip(labels, centres.tolist(), strict=True)
    )


# Self-tuning fuzzy PID tables (Liu Jinkun, "Advanced PID Control and its MATLAB
# Simulation"): rows e = NB..PB, columns de = NB..PB.
PID_TABLES_000 = {
    "dKp": (
        "PB PB PM PM PS ZO ZO",
        "PB PB PM PS PS ZO NS",
        "PM PM PM PS ZO NS NS",
        "PM PM PS ZO NS NM NM",
        "PS PS ZO NS NS NM NM",
        "PS ZO NS NM NM NM NB",
        "ZO ZO NM NM NM NB NB",
    ),
    "dKi": (
        "NB NB NM NM NS ZO ZO",
        "NB NB NM NS NS ZO ZO",
        "NB NM NS NS ZO PS PS",
        "NM NM NS ZO PS PM PM",
        "NM NS ZO PS PS PM PB",
        "ZO ZO PS PS PM PB PB",
        "ZO ZO PS PM PM PB PB",
    ),
    "dKd": (
        "PS NS NB NB NB NM PS",
        "PS NS NB NM NM NS ZO",
        "ZO NS NM NM NS NS ZO",
        "ZO NS NS NS NS NS ZO",
        "ZO ZO ZO ZO ZO ZO ZO",
        "PB NS PS PS PS PS PB",
        "PB PM PM PM PS PS PB",
    ),
}


def fuzzy_pid_000() -> FuzzySystem:
    """The fuzzy PID gain scheduler of paper 000 (Mamdani, 49 rules, three outputs).

    Inputs ``e`` (``k_e`` times the contour error) and ``de`` (``k_de`` times its change)
    on [-3, 3]; outputs ``dKp``, ``dKi``, ``dKd`` on [-3, 3] (the caller multiplies them by
    000's proportional factors ``k_pf``, ``k_if``, ``k_df``). Seven evenly spaced triangles
    NB..PB per variable, half triangles at the universe ends (so the centroids span
    [-8/3, 8/3]); 601 samples per universe (chosen). 000's rule tables 1-3 were lost
    in extraction; these are the classic self-tuning fuzzy PID tables of Liu Jinkun,
    "Advanced PID Control and its MATLAB Simulation" (:data:`PID_TABLES_000`).
    """
    sets = _triangles(LABELS7, -3.0, 3.0)
    inputs = tuple(Variable(name, -3.0, 3.0, sets) for name in ("e", "de"))
    outputs = tuple(Variable(name, -3.0, 3.0, sets) for name in PID_TABLES_000)
    rules = []
    for r, e_label in enumerate(LABELS7):
        rows = [PID_TABLES_000[name][r].split() for name in PID_TABLES_000]
        for c, de_label in enumerate(LABELS7):
            rules.append(Rule((e_label, de_label), tuple(row[c] for row in rows)))
    return FuzzySystem("fuzzy_pid_000", MAMDANI, inputs, outputs, tuple(rules))


def adaptive_fuzzy_001(n_sets: int = 5) -> FuzzySystem:
    """The adaptive fuzzy PID of paper 001 (product inference, centre average).

    Inputs ``e`` and ``de`` (scaled contour error and its change) on [-3, 3]; ``n_sets``
    evenly spaced Gaussian sets per input, neighbours crossing at membership 0.5; one rule
    per pair of sets (``n_sets ** 2`` rules, the full grid). Three outputs ``dKp``, ``dKi``,
    ``dKd``, each ``theta . xi(e, de)`` with its own ``theta``; every rule's consequent is
    ``ZO`` (centre 0), so :func:`initial_theta` is 0 and the adapted gains start at the
    base PID gains (``theta`` is not bounded by the output universes, which only place the
    consequent sets). 001's membership figure and rule table 1 were lost in extraction: the
    set count, shape and universe are chosen here.

    Args:
        n_sets: Sets per input: 3, 5 or 7. Default 5 (chosen: 25 weights to adapt per
            output; 7 gives 49).
    """
    if n_sets not in (3, 5, 7):
        raise ValueError(f"n_sets must be 3, 5 or 7, got {n_sets!r}")
    labels = {3: ("NB", "ZO", "PB"), 5: ("NB", "NS", "ZO", "PS", "PB"), 7: LABELS7}[n_sets]
    sets = _gaussians(labels, -3.0, 3.0, 0.5)
    inputs = tuple(Variable(name, -3.0, 3.0, sets) for name in ("e", "de"))
    outputs = tuple(Variable(name, -3.0, 3.0, sets) for name in PID_TABLES_000)
    rules = tuple(Rule((a, b), ("ZO",) * 3) for a in labels for b in labels)
    return FuzzySystem(f"adaptive_fuzzy_001_{n_sets}", PRODUCT, inputs, outputs, rules)


LABELS5_004 = ("NB", "NS", "ZE", "PS", "PB")
# 004 table 3.1 as extracted: (DE, E, dF), i.e. IF DE AND E THEN dF
RULES_004 = (
    ("PS", "NS", "PS"),
    ("PS", "ZE", "PB"),
    ("PS", "PS", "PB"),
    ("ZE", "NB", "NS"),
    ("ZE", "PB", "NS"),
    ("NS", "NS", "PB"),
    ("NS", "ZE", "PB"),
    ("NS", "PS", "PS"),
)


def fuzzy_feedrate_004() -> FuzzySystem:
    """The fuzzy feedrate controller of paper 004 (Mamdani, bell sets, eight rules).

    Inputs ``E`` (contour error times ``g_e``) and ``DE`` (its change per sample times
    ``g_ce``); with 004's gains "scaled as the contour error bound" (``g_e = 1 / tol``) the
    input universes [-1, 1] end at the tolerance, larger values are clipped to it. Output
    ``dF`` on [-1, 1], the feedrate change per sample before 004's gain ``g_dF = 0.35``
    (:data:`FEEDRATE_GAIN_004`), which the caller applies (``F(k) = F(k-1) + g_dF dF``,
    004 eq. 3.3, in the caller's feedrate unit). Every variable has five bell sets
    NB NS ZE PS PB (004 eq. 3.1, ``mu = exp(-(x - b)^2 / a)``) at b = -1, -0.5, 0, 0.5, 1
    with ``a = 0.25^2 / ln 2 = 0.0902`` (chosen: neighbours cross at 0.5). Mamdani, centroid.

    The rules are 004's table 3.1 as it survived extraction (:data:`RULES_004`; 8 rules,
    as 004's text says): DE = PS: E = NS -> PS, ZE -> PB, PS -> PB; DE = ZE: E = NB -> NS,
    PB -> NS; DE = NS: E = NS -> PB, ZE -> PB, PS -> PS; rows DE = PB and NB empty. Small
    errors speed up (dF(0, 0) = 0.46), steady errors at the tolerance slow down
    (dF(+-1, 0) = -0.39). As extracted, the table speeds up more where the error grows (E
    and DE of one sign: PB) than where it shrinks (PS). Where no rule covers the inputs
    (|DE| near 1) the nearest rules' bell tails decide, e.g. dF(1, 1) = 0.71: every rule
    fires at least ``exp(-2^2 / a) = 5e-20`` on the universe, so the aggregate is never
    empty.
    """
    sets = _gaussians(LABELS5_004, -1.0, 1.0, 0.5)
    inputs = (Variable("E", -1.0, 1.0, sets), Variable("DE", -1.0, 1.0, sets))
    outputs = (Variable("dF", -1.0, 1.0, sets),)
    rules = tuple(Rule((e, de), (df,)) for de, e, df in RULES_004)
    return FuzzySystem("fuzzy_feedrate_004", MAMDANI, inputs, outputs, rules)
