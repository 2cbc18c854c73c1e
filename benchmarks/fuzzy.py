"""Compiled fuzzy systems against scikit-fuzzy (agents/fuzzy/): speed and accuracy, one table.

Rows: every rule base of agents/fuzzy/ with each compiled method. Mamdani systems:
``surface`` (the default lookup) and ``exact`` (the compiled inference); the reference is
skfuzzy's ``ControlSystemSimulation``. The product / centre-average system: the reference is
the plain numpy basis on skfuzzy's memberships (skfuzzy.control has no such mode), the
compiled row computes basis and output.

Columns: ``ref ms`` one reference call on one input (median of REF_CALLS calls): for Mamdani
setting the inputs and ``compute()`` on a simulation built beforehand, for the product
system :func:`agents.fuzzy.reference_basis` and the output;
``us B=1`` one :func:`agents.fuzzy.evaluate` call on one input, checks included (median of
REPEATS blocks of 200 calls); ``us/member B=1024`` one call on 1024 inputs divided by 1024
(median of REPEATS calls); ``err/range`` the largest |compiled - reference| over ERR_POINTS
random inputs (10 % of them outside the universes, so clipped) plus every pair of set peaks
and the universe corners, divided by the output range (largest over outputs);
``vs exact`` the same against the compiled exact inference on 100 000 random inputs.
Targets: 10 us at B = 1, 1 us per member at B = 1024, 1e-3 of the output range.
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable

import numpy as np
from skfuzzy import control as ctrl

from agents import fuzzy as F  # noqa: N812

REPEATS = 21
REF_CALLS = 15
ERR_POINTS = 300
TARGET_B1_US = 10.0
TARGET_MEMBER_US = 1.0
TARGET_ERR = 1e-3


def median_time(fn: Callable[[], object], repeats: int = REPEATS, inner: int = 1) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(inner):
            fn()
        times.append((time.perf_counter() - t0) / inner)
    return float(np.median(times))


def test_inputs(system: F.FuzzySystem, n: int, seed: int) -> np.ndarray:
    lo = np.array([v.low for v in system.inputs])
    hi = np.array([v.high for v in system.inputs])
    rng = np.random.default_rng(seed)
    pad = 0.05 * (hi - lo)
    x = rng.uniform(lo - pad, hi + pad, (n, len(lo)))
    centres = [np.unique([s.centre for s in v.sets] + [v.low, v.high]) for v in system.inputs]
    peaks = np.stack(np.meshgrid(*centres, indexing="ij"), axis=-1).reshape(-1, len(lo))
    return np.ascontiguousarray(np.concatenate([x, peaks]))


def skfuzzy_call_time(system: F.FuzzySystem, x: np.ndarray) -> float:
    # one simulation, built once (fresh objects), then inputs + compute() per call
    sim = ctrl.ControlSystemSimulation(F.control_system(system), cache=False)
    points = iter(x)

    def call() -> None:
        for var, value in zip(system.inputs, next(points), strict=True):
            sim.input[var.name] = float(value)
        sim.compute()

    return median_time(call, REF_CALLS)


def mamdani_rows(system: F.FuzzySystem) -> list[tuple[str, ...]]:
    t0 = time.perf_counter()
    compiled = system.compiled
    assert isinstance(compiled, F.CompiledMamdani)
    build = time.perf_counter() - t0
    x = test_inputs(system, ERR_POINTS, 0)
    used_all = all(
        len(np.unique(system.consequent_indices()[:, o])) == len(v.sets)
        for o, v in enumerate(system.outputs)
    )
    ref = F.reference_evaluate(system, x, vectorised=used_all)
    ref_ms = 1e3 * skfuzzy_call_time(system, x)
    span = np.array([v.high - v.low for v in system.outputs])
    dense = test_inputs(system, 100_000, 1)
    exact_dense = compiled.exact(dense)
    rows = []
    for method in ("surface", "exact"):
        out = F.evaluate(system, x, method=method)
        err = float(np.max(np.abs(out - ref) / span))
        vs_exact = float(
            np.max(np.abs(F.evaluate(system, dense, method=method) - exact_dense) / span)
        )
        rows.append(
            speed_row(system, method, ref_ms, err, vs_exact, lambda m=method: {"method": m})
        )
    rows[0] = (*rows[0][:-1], f"{build:.2f}")
    return rows


def speed_row(
    system: F.FuzzySystem,
    method: str,
    ref_ms: float,
    err: float,
    vs_exact: float,
    kwargs: Callable[[], dict[str, str]],
) -> tuple[str, ...]:
    x1 = test_inputs(system, 1, 2)[:1]
    xb = test_inputs(system, 1024, 3)[:1024]
    b1 = median_time(lambda: F.evaluate(system, x1, **kwargs()), inner=200)
    bn = median_time(lambda: F.evaluate(system, xb, **kwargs())) / 1024
    return (
        system.name,
        method,
        f"{ref_ms:.2f}",
        f"{1e6 * b1:.2f}",
        f"{1e6 * bn:.3f}",
        f"{err:.1e}",
        f"{vs_exact:.1e}" if vs_exact >= 0 else "-",
        "",
    )


def product_rows(system: F.FuzzySystem) -> list[tuple[str, ...]]:
    t0 = time.perf_counter()
    theta = F.initial_theta(system)
    build = time.perf_counter() - t0
    theta = np.random.default_rng(4).normal(size=theta.shape)
    x = test_inputs(system, ERR_POINTS, 0)
    ref_xi = F.reference_basis(system, x)
    ref_ms = 1e3 * median_time(lambda: F.reference_basis(system, x[:1]) @ theta.T, REF_CALLS)
    xi = F.basis(system, x)
    y = F.evaluate(system, x, theta=theta)
    err = max(float(np.max(np.abs(xi - ref_xi))), float(np.max(np.abs(y - ref_xi @ theta.T))))
    row = speed_row(system, "basis+output", ref_ms, err, -1.0, lambda: {"theta": theta})
    return [(*row[:-1], f"{build:.2f}")]


def main() -> None:
    print(__doc__.split("\n\n")[0])
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    rows = []
    for builder in (F.fuzzy_pid_000, F.fuzzy_feedrate_004):
        rows += mamdani_rows(builder())
    for n_sets in (5, 7):
        rows += product_rows(F.adaptive_fuzzy_001(n_sets))
    head = (
        "system",
        "method",
        "ref ms",
        "us B=1",
        "us/member B=1024",
        "err/range",
        "vs exact",
        "build s",
    )
    targets = (
        "target",
        "",
        "",
        f"<= {TARGET_B1_US:g}",
        f"<= {TARGET_MEMBER_US:g}",
        f"<= {TARGET_ERR:g}",
        "",
        "",
    )
    table = [head, targets, *rows]
    widths = [max(len(r[c]) for r in table) for c in range(len(head))]
    for r in table:
        print(
            "  ".join(
                cell.rjust(w) if c > 1 else cell.ljust(w)
                for c, (cell, w) in enumerate(zip(r, widths, strict=True))
            )
        )
    print("err/range of the product rows: absolute error of basis and output (theta ~ N(0, 1)).")
    print("build s: first use of the system (sampling, and for Mamdani the surface tabulation).")


if __name__ == "__main__":
    main()
