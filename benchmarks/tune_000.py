"""Paper 000's tuned fuzzy PID CCC against no CCC and the untuned one, and its claims.

Runs ``no_ccc``, ``fuzzy_pid_ccc`` (the law's defaults), ``pso_fuzzy_pid_ccc_000`` (the factors
of tuning protocol 000, ``agents/data/pso_fuzzy_pid_ccc_000.json``) and ``pso_fuzzy_pid_ccc``
(protocol 000_general's general factor set) with
:func:`agents.evaluate.run_policy` (seed 0, one episode) on 000's three envs, rig and ideal,
and prints max / mean true contour error (um) and 000's claims: PSO-tuned vs no CCC on the
circle >= 90 % lower max error; PSO-tuned vs untuned on "infinity" and trident >= 50 % lower
(:func:`agents.claims.claims_000`, the one home of those comparisons).

    python benchmarks/tune_000.py
"""

from __future__ import annotations

from agents.ccc_policies import tuned_factors_000
from agents.claims import claims_000
from agents.evaluate import run_policy
from agents.policies import make_policy

ENVS = ("contour_gym/CCC-Circle-v0", "contour_gym/CCC-Infinity-v0", "contour_gym/CCC-Trident-v0")
POLICIES = ("no_ccc", "fuzzy_pid_ccc", "pso_fuzzy_pid_ccc_000", "pso_fuzzy_pid_ccc")
UM = 1e6


def main() -> None:
    print("factors:", {k: f"{v:.4g}" for k, v in tuned_factors_000().items()})
    print(f"{'env':<18}{'policy':<20}{'rig max':>9}{'rig mean':>10}{'ideal max':>11}"
          f"{'ideal mean':>12}")
    peak: dict[tuple[str, str, bool], float] = {}
    for env in ENVS:
        for i, name in enumerate(POLICIES):
            cells = []
            for ideal in (False, True):
                m = run_policy(env, make_policy(name), ideal=ideal)
                peak[env, name, ideal] = m["max_contour_error"]
                cells += [m["max_contour_error"] * UM, m["mean_contour_error"] * UM]
            label = env.split("/")[1] if i == 0 else ""
            print(f"{label:<18}{name:<20}{cells[0]:>9.2f}{cells[1]:>10.2f}{cells[2]:>11.2f}"
                  f"{cells[3]:>12.2f}")
    print("claims (agents.claims.claims_000; max contour error):")
    for ideal in (False, True):
        for c in claims_000(ideal):
            print(f"  {c.scenario:<9} {c.model:<5} {c.comparison:<45} {c.ours * 100:+7.1f} % "
                  f"(000: {c.paper_change * 100:+.1f} %, needs <= {c.need * 100:+.0f} %)  "
                  f"{c.verdict}")

if __name__ == "__main__":
    main()
