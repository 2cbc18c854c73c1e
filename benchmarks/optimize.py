"""A part program's new F words against the fastest constant override (issue 65).

For each G-code part of the generalization suite (configs/suites/parts; 3-D programs mapped onto
the X-Y machine as the suite maps them) and the docs' part, on
004's machine at 5 um and on 000's machine at twice its PID CCC's peak error on the part:
``agents.optimize.optimize_part`` (its result read back and run) against the fastest constant
feed override (on a grid of 0.05 from 0.05 to 5, the machine's largest feed capping it) whose
run keeps the tolerance. Printed: the given program's cycle, the override's, the optimised
one's and its peak error, the saving against the override (the target: >= 10 %), and the
optimiser's wall time; then the time to optimise a 1000-block program (the target: <= 2 min).

    python benchmarks/optimize.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from agents.optimize import optimize_part
from contour_gym import simulate
from contour_gym.paths import from_gcode
from contour_gym.presets import resolve_preset

ROOT = Path(__file__).resolve().parents[1]
PARTS = sorted((ROOT / "configs" / "suites" / "parts").glob("*")) + [ROOT / "docs" /
                                                                      "metrics_part.nc"]
OVERRIDES = np.round(np.arange(0.05, 5.0001, 0.05), 2)


def fastest_override(plant: str, text: str, tolerance: float) -> tuple[float, float]:
    """The fastest constant override keeping ``tolerance``: (override, cycle time)."""
    path = from_gcode(text)
    gains = resolve_preset(plant).ccc_gains
    best = (math.nan, math.inf)
    for q in OVERRIDES:
        m = simulate(plant, path, ccc_gains=gains, feedrate_override=float(q))
        if m["finished"] and m["max_contour_error"] <= tolerance and m["cycle_time"] < best[1]:
            best = (float(q), float(m["cycle_time"]))
    return best


def thousand_blocks(seed: int = 0) -> str:
    """A 2-D program of 1000 feed moves: lines and arcs on a random walk, one F word."""
    rng = np.random.default_rng(seed)
    lines, x, y = ["G21 G90 G17 G94", "G0 X0 Y0", "F1200"], 0.0, 0.0
    for k in range(1000):
        if k % 3 == 2:  # a quarter arc of 2 to 6 mm to the left
            r = rng.uniform(2.0, 6.0)
            x, y = x + r, y + r
            lines.append(f"G3 X{x:.3f} Y{y:.3f} R{r:.3f}")
        else:
            x, y = x + rng.uniform(-4.0, 6.0), y + rng.uniform(-4.0, 5.0)
            lines.append(f"G1 X{x:.3f} Y{y:.3f}")
        x, y = float(np.clip(x, -100.0, 100.0)), float(np.clip(y, -100.0, 100.0))
    return "\n".join(lines + ["M2"]) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="004's machine only, no 1000 blocks")
    args = parser.parse_args()
    print("| part | machine | tolerance (um) | given (s) | fastest override | optimised (s) | "
          "peak (um) | saving | optimise (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for part in PARTS:
        text = part.read_text()
        cases = [("xy_servo_coulomb", 5e-6)]
        if not args.quick:
            gains = resolve_preset("xy_dc_servo").ccc_gains
            try:
                peak = simulate("xy_dc_servo", from_gcode(text), ccc_gains=gains)
                cases.append(("xy_dc_servo", 2.0 * peak["max_contour_error"]))
            except ValueError as exc:
                print(f"| {part.name} | xy_dc_servo | refused: {exc} |||||||")
        for plant, tol in cases:
            try:
                q, constant = fastest_override(plant, text, tol)
                start = time.perf_counter()
                result = optimize_part(text, plant, tol, best_effort=True)
            except ValueError as exc:  # a program the machine cannot run (3-D on X-Y)
                print(f"| {part.name} | {plant} | refused: {exc} |||||||")
                continue
            wall = time.perf_counter() - start
            saving = 1.0 - result.after["cycle_time"] / constant
            print(f"| {part.name} | {plant} | {tol * 1e6:.3g} | {result.before['cycle_time']:.2f} "
                  f"| x{q:g}: {constant:.2f} s | {result.after['cycle_time']:.2f} | "
                  f"{result.after['max_contour_error'] * 1e6:.3g} | {100 * saving:.1f} % | "
                  f"{wall:.1f} |", flush=True)
    if not args.quick:
        text = thousand_blocks()
        start = time.perf_counter()
        try:
            result = optimize_part(text, "xy_servo_coulomb", 5e-6, best_effort=True)
        except ValueError as exc:
            print(f"\n1000 feed moves on xy_servo_coulomb at 5 um: refused after "
                  f"{time.perf_counter() - start:.1f} s: {exc}")
            return
        print(f"\n1000 feed moves on xy_servo_coulomb at 5 um: {time.perf_counter() - start:.1f} s "
              f"({result.before['cycle_time']:.1f} s -> {result.after['cycle_time']:.1f} s, "
              f"peak {result.after['max_contour_error'] * 1e6:.3g} um, "
              f"{len(result.too_tight)} blocks too tight)")


if __name__ == "__main__":
    main()
