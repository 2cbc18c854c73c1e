"""The scikit-fuzzy reference the compiled code is tested against (never the hot path).

:func:`control_system` builds the ``skfuzzy.control`` system equivalent to a Mamdani
:class:`~agents.fuzzy.system.FuzzySystem`, fresh every call (simulations that share rule or
variable objects but differ in ``cache=`` return stale outputs silently);
:func:`reference_evaluate` runs it. skfuzzy.control has no product inference or centre-average
defuzzifier, so the reference of a product system is plain numpy on skfuzzy's memberships
(:func:`reference_basis`). One ``compute()`` is slow: networkx re-sorts the rules on every call.

``skfuzzy.control`` (and networkx, which it imports) is imported by the functions that use it,
not with this module: ``import agents.policies`` took 0.86-0.89 s with it, 0.59-0.63 s
without (measured), a cost every command that loads a fuzzy policy paid.
"""

from __future__ import annotations

import functools
import operator
import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
import skfuzzy as fuzz
from numpy.typing import ArrayLike

from agents.fuzzy.system import MAMDANI, Array, FuzzySystem, Variable, check_inputs

if TYPE_CHECKING:
    from skfuzzy import control as ctrl


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
    from skfuzzy import control as ctrl

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
    x = check_inputs(system, inputs)
    with warnings.catch_warnings():
        # skfuzzy 0.5 passes np.maximum's output positionally; numpy 2.4 deprecates that
        warnings.filterwarnings("ignore", "Passing more than 2 positional", DeprecationWarning)
        return _reference_evaluate(system, x, vectorised)


def _reference_evaluate(system: FuzzySystem, x: Array, vectorised: bool) -> Array:
    from skfuzzy import control as ctrl

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
    x = check_inputs(system, inputs)
    ant = system.antecedent_indices()
    w = np.ones((x.shape[0], ant.shape[0]))
    for i, var in enumerate(system.inputs):
        xi = np.clip(x[:, i], var.low, var.high)
        mu = np.stack([fuzz.interp_membership(var.universe(), mf, xi) for mf in var.memberships()])
        w *= mu[ant[:, i]].T
    total = w.sum(axis=1, keepdims=True)
    return np.divide(w, total, out=np.zeros_like(w), where=total > 0.0)

