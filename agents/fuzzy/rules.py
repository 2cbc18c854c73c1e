"""The papers' rule bases: paper 000's fuzzy PID, 001's adaptive fuzzy PID, 004's feedrate.

:func:`fuzzy_pid_000` (000's lost tables 1-3 replaced by Liu Jinkun's classic self-tuning
fuzzy PID tables), :func:`adaptive_fuzzy_001` (001's sets and table lost; set count and shape
chosen) and :func:`fuzzy_feedrate_004` (004's table 3.1 as it survived extraction); each
docstring says what is reconstructed and what is chosen. Scaling (000's quantisation factors
``k_e, k_de`` and proportional factors, 004's gains ``g_e, g_ce, g_dF``) is applied by the
caller: the systems work on normalised universes.
"""

from __future__ import annotations

import math

import numpy as np

from agents.fuzzy.system import MAMDANI, PRODUCT, FuzzySet, FuzzySystem, Rule, Variable

LABELS7 = ("NB", "NM", "NS", "ZO", "PS", "PM", "PB")
FEEDRATE_GAIN_004 = 0.35  # 004 section IV: g_dF, applied by the caller to dF


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
