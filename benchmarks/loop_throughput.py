"""Closed-loop throughput: env-ticks per second at B = 1, 64, 1024 on the default circle.

Default scenario: 000's X-Y DC servo on its 10 mm circle with PID CCC (the `contour-gym
simulate` job), on the rig (encoder, one-tick delay: the default) and with ``ideal=True``.
"ideal, truth" is the ideal machine with the ground-truth estimator, the scenario this
benchmark ran before the rig and 000's own estimator (``exact``) became the defaults: the
like-for-like column against earlier figures. One core (numba runs single-threaded here).
Prints medians of 5 repeats. Targets (issue 2):
>= 2e4 ticks/s at B = 1 and >= 3e6 env-ticks/s at B = 1024.

A second table (no target) gives B = 1024 for every preset on its paper path, with its
friction, ripple, disturbances, encoder and substeps.
"""

from __future__ import annotations

import os
import platform
import time

import numpy as np

from contour_gym.api import make_scenario
from contour_gym.presets import PRESETS


def measure(
    batch: int, ticks: int, repeats: int = 5, preset: str = "xy_dc_servo", **options: object
) -> float:
    sc = make_scenario(preset, **options)
    loop = sc.loop(batch_size=batch, ccc_gains=sc.preset.ccc_gains.as_tuple())
    loop.step(5)  # compile / warm up
    times = []
    for _ in range(repeats):
        loop.reset(0)
        start = time.perf_counter()
        loop.step(ticks)
        times.append(time.perf_counter() - start)
    return batch * ticks / float(np.median(times))


def main() -> None:
    print(f"# loop throughput, {platform.machine()}, {os.cpu_count()} cores visible, one used")
    print(f"{'B':>6} {'ticks/call':>10} {'rig ticks/s':>14} {'ideal ticks/s':>14} "
          f"{'ideal, truth':>14} {'target':>10}")
    for batch, ticks, target in ((1, 2000, 2e4), (64, 2000, None), (1024, 1000, 3e6)):
        rate, ideal = measure(batch, ticks), measure(batch, ticks, ideal=True)
        truth = measure(batch, ticks, ideal=True, estimator="ground_truth")
        want = "" if target is None else f"{target:.0e}"
        print(f"{batch:>6} {ticks:>10} {rate:>14.3g} {ideal:>14.3g} {truth:>14.3g} {want:>10}")
    print(f"\n{'preset (B = 1024, 1000 ticks)':<32} {'env-ticks/s':>14}")
    for preset in PRESETS:
        print(f"{preset:<32} {measure(1024, 1000, preset=preset):>14.3g}")


if __name__ == "__main__":
    main()
