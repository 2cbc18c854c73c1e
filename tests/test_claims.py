"""The papers' comparisons (agents.claims) on short budgets and fixed seeds."""

from __future__ import annotations

import math

import pytest

from agents.claims import (
    Claim,
    claims_000,
    claims_001,
    claims_003,
    claims_004,
    optimizer_claim,
)


def _check(claims: list[Claim], papers: set[str]) -> None:
    assert {c.paper for c in claims} == papers
    for c in claims:
        assert math.isfinite(c.ours), c
        assert c.verdict == ("HOLDS" if c.ours <= c.need and c.extra_ok else "FALLS SHORT")


def test_000_tuned_factors_cut_the_peaks_where_000_says_they_do() -> None:
    claims = {c.scenario: c for c in claims_000()}
    _check(list(claims.values()), {"000"})
    # measured (agents.ccc_policies docstring): -63 % on the circle (000: -98.8 %, falls short),
    # the trident's >= 50 % holds, "infinity" grows where 000 says it falls
    assert -0.90 < claims["circle"].ours < -0.5
    assert claims["trident"].holds
    assert claims["infinity"].ours > 0.0 and not claims["infinity"].holds


def test_001_adaptive_law_lowers_the_mean_error_on_two_seeds() -> None:
    (claim,) = claims_001(episodes=2)
    _check([claim], {"001"})
    assert -0.30 < claim.ours < -0.05  # about -20 % on the rig: short of 001's -30.5 %


def test_003_iabc_acc2pid_lowers_p_eps_on_both_paths() -> None:
    claims = claims_003()
    _check(claims, {"003"})
    assert [c.scenario for c in claims] == ["dual circle", "three-leaf"]
    assert all(c.ours < -0.3 for c in claims)


@pytest.mark.slow
def test_004_fuzzy_feedrate_against_the_fastest_constant_on_a_coarse_search() -> None:
    claims = claims_004(members=6)
    assert [c.scenario for c in claims] == ["circle R = 20 mm", "corner"]
    for c in claims:
        # the fuzzy controller is faster than any constant within the tolerance, but breaks it
        # (agents.feedrate_policies docstring): the side condition fails, so the claim does
        assert c.ours < 0.0 and not c.extra_ok and c.verdict == "FALLS SHORT"


def test_optimizer_claim_reports_medians_of_each_seed_on_a_short_budget() -> None:
    claim, runs = optimizer_claim("000", "000_circle", "improved_pso", "pso", [0, 1],
                                  population=6, iterations=2)
    assert set(runs) == {"improved_pso", "pso"}
    assert all(len(v) == 2 and all(math.isfinite(f) and f > 0 for f in v) for v in runs.values())
    assert claim.paper_change is None and math.isfinite(claim.ours)
    again, runs2 = optimizer_claim("000", "000_circle", "improved_pso", "pso", [0, 1],
                                   population=6, iterations=2)
    assert runs2 == runs and again == claim  # same seeds, same result


def test_iabc_against_abc_on_protocol_003_on_a_short_budget() -> None:
    claim, runs = optimizer_claim("003", "003", "improved_abc", "abc", [0], population=4,
                                  iterations=1)
    assert set(runs) == {"improved_abc", "abc"}
    assert all(math.isfinite(v[0]) and v[0] > 0 for v in runs.values())
    assert claim.paper == "003" and math.isfinite(claim.ours)
