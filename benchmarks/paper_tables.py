"""Every paper's comparison with the paper's figure beside ours, on the rig and ideal.

One line per claim (:mod:`agents.claims`): the paper's change, ours, the change the claim
needs, our two values, and HOLDS or FALLS SHORT. Then the optimisers' median best fitness over
seeds (improved PSO against PSO on protocol ``000_circle``; IABC against ABC on ``003``) and
the speed lines: the wall time of 000's full protocol (``000_circle``: 50 x 101 episodes of
the 2 s circle at 1 kHz, fuzzy PID every tick) and of 003's (40 x 201 candidates), each
against the issue's 15 s.

    python benchmarks/paper_tables.py                 # everything (about 35 min here)
    python benchmarks/paper_tables.py --seeds 3       # fewer optimiser seeds
    python benchmarks/paper_tables.py --skip-optimizers

Optimiser seeds run the protocols' full budgets: about 8 s a run for ``000_circle`` and 80 s
for ``003`` on this 2-core machine.
"""

from __future__ import annotations

import argparse
import time

from agents.claims import (
    Claim,
    claims_000,
    claims_001,
    claims_003,
    claims_004,
    optimizer_claim,
)
from agents.tune import tune


def _pct(x: float | None) -> str:
    return "" if x is None else f"{x * 100:+.1f} %"


def print_claims(claims: list[Claim]) -> None:
    """A Markdown table of claims."""
    print("| paper | scenario | model | comparison | paper | ours | needs | values | verdict |")
    print("|---|---|---|---|---|---|---|---|---|")
    for c in claims:
        need = "lower" if c.paper_change is None else f"<= {c.need * 100:+.0f} %"
        if c.extra:
            need += f", {c.extra}"
        print(f"| {c.paper} | {c.scenario} | {c.model} | {c.comparison} | "
              f"{_pct(c.paper_change)} | {_pct(c.ours)} | {need} | {c.detail} | "
              f"{c.verdict} |", flush=True)


def speed_line(protocol: str, optimizer: str) -> str:
    """Wall time of one full protocol run (seed 0) against the 15 s target."""
    start = time.perf_counter()
    result = tune(protocol, optimizer, seed=0, progress=False)
    wall = time.perf_counter() - start
    verdict = "HOLDS" if wall <= 15.0 else "FALLS SHORT"
    return (f"protocol {protocol} ({optimizer}, {result.nfev} candidates): {wall:.1f} s wall "
            f"(target <= 15 s) {verdict}")


def main() -> None:
    """Print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="optimiser seeds (default 10)")
    parser.add_argument("--skip-optimizers", action="store_true",
                        help="leave out the optimiser comparisons and speed lines")
    args = parser.parse_args()
    t0 = time.perf_counter()
    claims: list[Claim] = []
    for ideal in (False, True):
        claims += claims_000(ideal) + claims_001(ideal) + claims_003(ideal) + claims_004(ideal)
    claims.sort(key=lambda c: (c.paper, c.scenario, c.model))
    print_claims(claims)
    print(f"\n(controller claims: {time.perf_counter() - t0:.0f} s)\n", flush=True)
    if args.skip_optimizers:
        return
    seeds = range(args.seeds)
    print(speed_line("000_circle", "improved_pso"), flush=True)
    print(speed_line("003", "improved_abc"), flush=True)
    opt = [optimizer_claim("000", "000_circle", "improved_pso", "pso", seeds)[0],
           optimizer_claim("003", "003", "improved_abc", "abc", seeds)[0]]
    print()
    print_claims(opt)
    print(f"\n(total {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
