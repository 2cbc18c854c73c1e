"""Fuzzy rule bases defined with scikit-fuzzy, evaluated by compiled batched numba kernels.

**Definition** (:mod:`agents.fuzzy.system`). A :class:`FuzzySystem` is a frozen description:
input and output :class:`Variable` s (a uniform universe ``linspace(low, high, n_points)`` and
named :class:`FuzzySet` s, each a ``skfuzzy.membership`` function sampled on that universe), a
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

**Reference** (:mod:`agents.fuzzy.reference`): the equivalent ``skfuzzy.control`` system
(:func:`control_system`, :func:`reference_evaluate`) and a plain numpy basis
(:func:`reference_basis`), what the compiled code is tested against.

**Compiled evaluation** (:mod:`agents.fuzzy.kernels`, :mod:`agents.fuzzy.compiled`): exact
Mamdani inference matching skfuzzy, a precomputed surface for two-input systems (the default,
within 2.4e-4 of the output range), and product inference; :func:`compile_system` builds the
arrays, :func:`evaluate` runs a batch. The kernels are plain njit functions, callable from
other compiled code (the kernels module says how).

**The papers' rule bases** (:mod:`agents.fuzzy.rules`): :func:`fuzzy_pid_000`,
:func:`adaptive_fuzzy_001` and :func:`fuzzy_feedrate_004`.
"""

from __future__ import annotations

from agents.fuzzy.compiled import (
    CompiledMamdani,
    CompiledProduct,
    SampledVariables,
    Surface,
    basis,
    compile_system,
    evaluate,
    initial_theta,
)
from agents.fuzzy.kernels import (
    EPS,
    FLAT_HEADER,
    M_HIGH,
    M_LOW,
    M_POINTS,
    M_SETS,
    M_STEP,
    fuzzify_into,
    mamdani_exact_into,
    product_basis_into,
    product_output_into,
    surface_eval,
    surface_eval_flat,
    surface_eval_into,
    surface_table,
    surface_views,
)
from agents.fuzzy.reference import control_system, reference_basis, reference_evaluate
from agents.fuzzy.rules import (
    FEEDRATE_GAIN_004,
    LABELS5_004,
    LABELS7,
    PID_TABLES_000,
    RULES_004,
    adaptive_fuzzy_001,
    fuzzy_feedrate_004,
    fuzzy_pid_000,
)
from agents.fuzzy.system import (
    DEFAULT_POINTS,
    DEFAULT_SURFACE_POINTS,
    KINDS,
    MAMDANI,
    MF_KINDS,
    PRODUCT,
    Array,
    FuzzySet,
    FuzzySystem,
    IntArray,
    Rule,
    Variable,
)

__all__ = [
    "DEFAULT_POINTS",
    "DEFAULT_SURFACE_POINTS",
    "EPS",
    "FEEDRATE_GAIN_004",
    "FLAT_HEADER",
    "KINDS",
    "LABELS5_004",
    "LABELS7",
    "MAMDANI",
    "MF_KINDS",
    "M_HIGH",
    "M_LOW",
    "M_POINTS",
    "M_SETS",
    "M_STEP",
    "PID_TABLES_000",
    "PRODUCT",
    "RULES_004",
    "Array",
    "CompiledMamdani",
    "CompiledProduct",
    "FuzzySet",
    "FuzzySystem",
    "IntArray",
    "Rule",
    "SampledVariables",
    "Surface",
    "Variable",
    "adaptive_fuzzy_001",
    "basis",
    "compile_system",
    "control_system",
    "evaluate",
    "fuzzify_into",
    "fuzzy_feedrate_004",
    "fuzzy_pid_000",
    "initial_theta",
    "mamdani_exact_into",
    "product_basis_into",
    "product_output_into",
    "reference_basis",
    "reference_evaluate",
    "surface_eval",
    "surface_eval_flat",
    "surface_eval_into",
    "surface_table",
    "surface_views",
]
