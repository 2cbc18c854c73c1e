"""Fuzzy system definitions: sets, variables, rules and systems, frozen and checked.

A :class:`FuzzySystem` is a frozen description: input and output :class:`Variable` s (a
uniform universe ``linspace(low, high, n_points)`` and named :class:`FuzzySet` s, each a
``skfuzzy.membership`` function sampled on that universe), a table of :class:`Rule` s and the
inference kind, :data:`MAMDANI` or :data:`PRODUCT` (the package docstring describes both).
Its :attr:`FuzzySystem.compiled` arrays come from :func:`agents.fuzzy.compiled.compile_system`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import skfuzzy as fuzz
from numpy.typing import ArrayLike, NDArray

from contour_gym.params import as_finite_array, choice, finite

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

MAMDANI = "mamdani"
PRODUCT = "product_centre_average"
KINDS = (MAMDANI, PRODUCT)
MF_KINDS = {"trimf": 3, "trapmf": 4, "gaussmf": 2}  # skfuzzy.membership name -> parameter count
DEFAULT_POINTS = 601  # samples of every universe (step 0.01 on [-3, 3])
DEFAULT_SURFACE_POINTS = 241  # surface nodes per input (agents.fuzzy.kernels says why)


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
    def compiled(self) -> Any:
        """The kernel arrays, compiled on first use and kept here.

        A :class:`~agents.fuzzy.compiled.CompiledMamdani` or
        :class:`~agents.fuzzy.compiled.CompiledProduct`, from the registered compiler
        (:func:`~agents.fuzzy.compiled.compile_system`, see :func:`register_compiler`).
        """
        if not _COMPILER:
            raise RuntimeError("no fuzzy system compiler is registered (import agents.fuzzy)")
        return _COMPILER[0](self)

    def antecedent_indices(self) -> IntArray:
        """(R, n_in) set index of every rule's antecedent per input."""
        return _rule_indices(self.rules, self.inputs, "when")

    def consequent_indices(self) -> IntArray:
        """(R, n_out) set index of every rule's consequent per output."""
        return _rule_indices(self.rules, self.outputs, "then")


# What FuzzySystem.compiled calls: agents.fuzzy.compiled registers its compile_system when
# imported (agents.fuzzy imports it), so that a definition does not import what compiles it.
_COMPILER: list[Callable[[FuzzySystem], Any]] = []


def register_compiler(compile_system: Callable[[FuzzySystem], Any]) -> None:
    """Make ``compile_system`` what :attr:`FuzzySystem.compiled` calls (once per system)."""
    _COMPILER[:] = [compile_system]


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



def check_inputs(system: FuzzySystem, inputs: ArrayLike) -> Array:
    """``inputs`` as a C-contiguous ``(B, n_in)`` float array of ``system``'s inputs.

    Raises:
        ValueError: for another shape or a non-finite value (naming it).
    """
    return np.ascontiguousarray(
        as_finite_array(inputs, "inputs", ndim=2, shape=(None, len(system.inputs)))
    )
