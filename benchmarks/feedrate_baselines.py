"""Feedrate baselines: the best constant feedrate against a CNC's own look-ahead planning.

On ``contour_gym/Feedrate-Circle-v0``, ``contour_gym/Feedrate-Corner-v0`` and the 2-D corpus
part ``tests/data/gcode/part_2d.ngc`` (on ``contour_gym/Feedrate-v0`` with plant
``xy_servo_coulomb``, at the part's own F words), one episode each (seed 0, the rig), of:

* ``constant``, best feasible: the feed override swept over ``--grid`` values spanning the
  env's ``feedrate_range`` (``feedrate_override=c``, action 0), the fastest run that finishes
  with its peak contour error within the tolerance; under the env's own path control (the
  circle: none; the corner id: G61; the part: its own modes, G64 at the library's default
  tolerance with exact stops at rapid/feed changes) and, where that differs, with
  ``path_control="none"`` (no planning: only the path end stops);
* ``cnc_lookahead`` (``agents.policies``) at G64 tolerances ``--tolerances`` (mm) and with G61.

Prints a Markdown table of the cycle time, the peak contour error (um and / tolerance) and
whether the run finished within the tolerance, then the sweep (peak / tolerance per override),
then the run time. Not a test: ``tests/test_policies.py`` checks G61 against G64 on the corner.

Then (``--table fuzzy``, or both by default) paper 004's comparison on the same cases, under the
env's own path control: ``fuzzy_feedrate`` (``agents.feedrate_policies``, 004's defaults;
``--fuzzy-units`` adds a row per other reading of dF's unit) against ``constant_feedrate`` at
1.0 and at the fastest override that keeps the tolerance. That override is searched with one
native vector env per round (``--members`` overrides spanning ``feedrate_range``, then as many
between the fastest feasible one and the next): member i ramps the override from the range's
low end to its target at the env's top rate (ahead of the machine's acceleration from rest)
and holds it, which is the constant run bit for bit; the row is the confirming
``constant_feedrate`` run (marked ``!`` if it differs from its search member).
"""

from __future__ import annotations

import argparse
import pathlib
import time
import warnings
from typing import Any

import gymnasium as gym
import numpy as np

from agents.evaluate import env_arguments, run_policy
from agents.feedrate_policies import DEFAULT_DF_UNIT, DF_UNITS
from agents.feedrate_search import fastest_constant
from agents.policies import make, make_policy
from contour_gym.paths import from_gcode

PART = pathlib.Path(__file__).resolve().parents[1] / "tests" / "data" / "gcode" / "part_2d.ngc"


def cases() -> dict[str, Any]:
    """Label -> env id or ``{"id": ..., **kwargs}``."""
    part = from_gcode(PART.read_text())
    return {
        "Feedrate-Circle-v0": "contour_gym/Feedrate-Circle-v0",
        "Feedrate-Corner-v0": "contour_gym/Feedrate-Corner-v0",
        PART.name: {"id": "contour_gym/Feedrate-v0", "path": part, "plant": "xy_servo_coulomb"},
    }


def env_settings(spec: Any) -> tuple[str, tuple[float, float]]:
    """The env's own path-control label and its ``feedrate_range``, read from a built env."""
    env_id, kwargs = env_arguments(spec, make_policy("constant"), {})
    env = gym.make(env_id, **kwargs)
    config, path = env.unwrapped.config, env.unwrapped.task.path
    env.close()
    own = config.path_control or ("part's own" if hasattr(path, "exact_stop") else "none")
    lo, hi = config.feedrate_range
    return own, (float(lo), float(hi))


def run(spec: Any, policy_name: str, **kwargs: Any) -> dict[str, Any]:
    """One episode; ``capped`` says whether the interpolator capped the feed (a warning)."""
    params = kwargs.pop("params", {})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        out = run_policy(spec, make(policy_name, **params), seed=0, **kwargs)
    out["capped"] = any("machine limit" in str(w.message) for w in caught)
    out["ok"] = bool(out["finished"] and out["max_contour_error"] <= out["tolerance"])
    return out


def sweep(spec: Any, grid: np.ndarray, **kwargs: Any) -> list[dict[str, Any]]:
    """``constant`` at each override of ``grid`` (action 0)."""
    return [run(spec, "constant", feedrate_override=float(c), **kwargs) for c in grid]


def best(results: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The fastest feasible run, or None."""
    feasible = [r for r in results if r["ok"]]
    return min(feasible, key=lambda r: r["cycle_time"]) if feasible else None


def row(label: str, policy: str, control: str, override: str, r: dict[str, Any]) -> str:
    """One Markdown row."""
    verdict = "yes" if r["ok"] else ("FAILED" if r["failed"] else "no")
    return (f"| {label} | {policy} | {control} | {override} | {r['cycle_time']:.3f} | "
            f"{r['max_contour_error'] * 1e6:.2f} | {r['max_contour_error'] / r['tolerance']:.2f} | "
            f"{verdict} | {r['return']:.1f} |")


def constant_rows(
    label: str, control: str, grid: np.ndarray, results: list[dict[str, Any]]
) -> list[str]:
    """The best feasible constant row (or the least bad, marked none feasible)."""
    top = best(results)
    if top is not None:
        i = results.index(top)
        return [row(label, "constant, best feasible", control, _override(grid[i], top), top)]
    i = int(np.argmin([r["max_contour_error"] for r in results]))
    return [row(label, "constant: NONE feasible (least peak shown)", control,
                _override(grid[i], results[i]), results[i])]


def _override(c: float, r: dict[str, Any]) -> str:
    return f"{c:.3f}{'*' if r['capped'] else ''}"


def baseline_tables(args: argparse.Namespace) -> None:
    """Print the constant sweep and cnc_lookahead tables."""
    t0 = time.perf_counter()
    rows, sweeps, times = [], [], []
    for label, spec in cases().items():
        start = time.perf_counter()
        own, (lo, hi) = env_settings(spec)
        grid = np.linspace(lo, hi, args.grid)
        modes = [(own, {})] + ([("none", {"path_control": "none"})] if own != "none" else [])
        for control, extra in modes:
            results = sweep(spec, grid, **extra)
            rows += constant_rows(label, control, grid, results)
            sweeps.append((label, control, grid, results))
        for tol_mm in args.tolerances:
            r = run(spec, "cnc_lookahead", params={"tolerance": tol_mm * 1e-3})
            rows.append(row(label, "cnc_lookahead", f"G64 P{tol_mm:g} mm", "1", r))
        r = run(spec, "cnc_lookahead", params={"mode": "G61"})
        rows.append(row(label, "cnc_lookahead", "G61", "1", r))
        times.append((label, time.perf_counter() - start))
    print(
        "| path | policy | path control | override | cycle time (s) | peak error (um) | "
        "peak / tol | within tol | return |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\nConstant-override sweep (seed 0): peak contour error / tolerance, then cycle time "
          f"(s), at {args.grid} overrides spanning feedrate_range; F = failed, "
          "* = feed capped at the machine's limit.\n")
    shown = None
    for label, control, grid, results in sweeps:
        if shown is None or not np.array_equal(grid, shown):
            print("| path | path control | " + " | ".join(f"{c:.3f}" for c in grid) + " |")
            print("|---|---|" + "---|" * grid.size)
            shown = grid
        peaks = [f"{r['max_contour_error'] / r['tolerance']:.2f}{'F' if r['failed'] else ''}"
                 f"{'*' if r['capped'] else ''}" for r in results]
        print(f"| {label} | {control} | " + " | ".join(peaks) + " |")
        print("| | cycle time (s) | " + " | ".join(f"{r['cycle_time']:.3f}" for r in results)
              + " |")
    print("\nrun time: " + ", ".join(f"{label} {s:.1f} s" for label, s in times)
          + f"; total {time.perf_counter() - t0:.1f} s")


def fuzzy_row(label: str, policy: str, override: str, r: dict[str, Any], ref: float) -> str:
    """One Markdown row of the fuzzy table (``ref``: constant 1.0's cycle time)."""
    verdict = "yes" if r["ok"] else ("FAILED" if r["failed"] else "no")
    change = r["cycle_time"] / ref - 1.0
    return (f"| {label} | {policy} | {override} | {r['cycle_time']:.3f} | {change:+.1%} | "
            f"{r['max_contour_error'] * 1e6:.2f} | {r['max_contour_error'] / r['tolerance']:.2f} | "
            f"{verdict} |")


def fuzzy_table(args: argparse.Namespace) -> None:
    """Print 004's comparison: fuzzy_feedrate against constant overrides."""
    t0 = time.perf_counter()
    units = [DEFAULT_DF_UNIT] + ([u for u in DF_UNITS if u != DEFAULT_DF_UNIT]
                                 if args.fuzzy_units else [])
    rows = []
    for label, spec in cases().items():
        _, (lo, hi) = env_settings(spec)
        ref = run(spec, "constant_feedrate")
        rows.append(fuzzy_row(label, "constant_feedrate", "1", ref, ref["cycle_time"]))
        best = fastest_constant(spec, args.members, lo, hi)
        if best is None:
            rows.append(f"| {label} | constant_feedrate: NONE within tol in [{lo:g}, {hi:g}] "
                        "| | | | | | |")
        else:
            c, member = best
            r = run(spec, "constant_feedrate", params={"override": c})
            same = all(r[k] == member[k] for k in ("cycle_time", "max_contour_error"))
            rows.append(fuzzy_row(label, "constant_feedrate, fastest within tol",
                                  f"{_override(c, r)}{'' if same else '!'}", r,
                                  ref["cycle_time"]))
        for unit in units:
            r = run(spec, "fuzzy_feedrate", params={"unit": unit})
            rows.append(fuzzy_row(label, f"fuzzy_feedrate, dF in {unit}", "varies", r,
                                  ref["cycle_time"]))
    print("\n004's fuzzy feedrate controller against constant overrides (seed 0, the env's "
          "own path control; cycle vs the constant 1.0 run's):\n")
    print("| path | policy | override | cycle time (s) | cycle vs 1.0 | peak error (um) | "
          "peak / tol | within tol |")
    print("|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"\nrun time {time.perf_counter() - t0:.1f} s; ! = the confirming constant run "
          "differs from its search member; * = feed capped at the machine's limit")


def main() -> None:
    """Print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=int, default=12, help="overrides swept (default 12)")
    parser.add_argument("--tolerances", type=float, nargs="*", default=[0.001, 0.01, 0.05],
                        help="G64 tolerances of cnc_lookahead, mm")
    parser.add_argument("--table", choices=("baselines", "fuzzy", "both"), default="both")
    parser.add_argument("--members", type=int, default=24,
                        help="overrides per round of the fuzzy table's search")
    parser.add_argument("--fuzzy-units", action="store_true",
                        help="a fuzzy_feedrate row per reading of dF's unit")
    args = parser.parse_args()
    if args.table in ("baselines", "both"):
        baseline_tables(args)
    if args.table in ("fuzzy", "both"):
        fuzzy_table(args)


if __name__ == "__main__":
    main()
