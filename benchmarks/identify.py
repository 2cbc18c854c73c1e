"""Identifying a twin from a servo log: time and recovery, per preset (issue 64).

For each preset named (default: 000's and 004's two-axis machines), a hidden machine is drawn
(``agents.twin.generate.perturbed_plant``, seed 5: every axis parameter scaled by a factor in
[0.6, 1.6]), a 30 s recording made on the rig (``excitation``, ``machine_log``) and a twin
identified from it (``agents.twin.fit.identify``, ``--like`` the preset). Prints the time to
identify (the target: <= 60 s for one two-axis 30 s log on a 2-core machine), the fit (NRMSE
per axis) and the largest error of an identified ratio to the force constant.

    python benchmarks/identify.py [PRESET ...] [--seconds 30]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from agents.twin.fit import identify
from agents.twin.generate import excitation, machine_log, perturbed_plant
from agents.twin.identified import ratio_errors
from contour_gym.presets import resolve_preset


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("presets", nargs="*", default=["xy_dc_servo", "xy_servo_coulomb"])
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    print("| preset | samples | identify (s) | NRMSE per axis | worst ratio error |")
    print("|---|---|---|---|---|")
    for name in args.presets:
        rng = np.random.default_rng(5)
        plant = perturbed_plant(name, rng)
        log = machine_log(plant, excitation(resolve_preset(plant), rng, args.seconds), seed=5)
        start = time.perf_counter()
        twin = identify([log], name)
        wall = time.perf_counter() - start
        nrmse = ", ".join(f"{100 * v:.2g} %" for v in twin.nrmse.values())
        worst = max(abs(e) for e in ratio_errors(twin.values, plant, name).values())
        print(f"| {name} | {len(log.time)} | {wall:.1f} | {nrmse} | {100 * worst:.2g} % |")


if __name__ == "__main__":
    main()
