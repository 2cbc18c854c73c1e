"""Contour error estimators against the exact nearest point (issue 3): one table.

For each library path the reference runs at constant feedrate F with the servo tick Ts of
the paper machine that uses the path (000: circle, infinity, trident; 004: corner; 003:
three-leaf; 001: helix; 002: B-spline complex), at F = the paper's feedrate and 3x it. The
tool follows the reference through first-order axis lags, the closed-loop model of a P/PD
position loop (002 section 4.2): time constants tau, 1.2 tau (and 1.4 tau for z), with
tau = 5 ms (a stiff loop) or 30 ms (000's Kv = 30/s, which reproduces its 49 um circle
error). Every tick while the reference moves is one sample; the interpolation history is
the constant step F Ts.

Columns: ``true max`` the largest exact contour error |eps| (um); ``max|d|`` / ``mean|d|``
the largest and mean distance between the estimated and the exact contour error vector
(um), ``%`` those as a percentage of the largest / mean exact |eps|; ``fb%`` the share of
samples where the estimator could not find a foot point and fell back to the exact search;
``us B=1`` the time of one Python call on one position (median over 200 positions, best of
three repeats) and ``us B=1024`` of one call on 1024 positions. One core. ``n/a``: exact
is defined for lines and arcs only.
"""

from __future__ import annotations

import math
import os
import platform
import time
from dataclasses import dataclass

import numpy as np

from contour_gym.contour import ESTIMATORS, Estimator
from contour_gym.paths import Path, load
from contour_gym.presets import get_preset

PATHS = (
    ("circle", "xy_dc_servo"),
    ("corner", "xy_servo_coulomb"),
    ("infinity", "xy_dc_servo"),
    ("trident", "xy_dc_servo"),
    ("three_leaf", "xyy_gantry"),
    ("helix", "xyz_pmlsm"),
    ("bspline_complex", "lugre_linear_motor"),
)
FREE_FORM = ("infinity", "trident", "three_leaf", "bspline_complex")
FEED_FACTORS = (1.0, 3.0)
LAGS = (0.005, 0.030)  # s
MISMATCH = np.array([1.0, 1.2, 1.4])  # axis time constants relative to tau
UM = 1e6


@dataclass(frozen=True)
class Case:
    """One path at one feedrate and lag: the samples and their exact contour error vectors."""

    path: Path
    feedrate: float
    ts: float
    tau: float
    s: np.ndarray
    pos: np.ndarray
    truth: np.ndarray


def make_case(name: str, preset: str, factor: float, tau: float) -> Case:
    """Reference at constant feedrate, tool through first-order axis lags, exact errors."""
    path = load(name)
    pre = get_preset(preset)
    feed, ts = factor * pre.feedrate, pre.stage.ts
    n = int(math.ceil(path.length / (feed * ts)))
    s = np.minimum(np.arange(n + 1) * feed * ts, path.length)
    ref = path.point(s)
    alpha = 1.0 - np.exp(-ts / (tau * MISMATCH[: path.dim]))
    pos = np.empty_like(ref)
    pos[0] = ref[0]
    for k in range(n):
        pos[k + 1] = pos[k] + alpha * (ref[k] - pos[k])
    keep = (s > 0.0) & (s < path.length)
    s, pos = s[keep], pos[keep]
    foot, _ = path.nearest(pos, s_hint=s)
    return Case(path, feed, ts, tau, s, pos, path.point(foot) - pos)


def accuracy(est: Estimator, case: Case) -> tuple[float, float, float]:
    """(max |d|, mean |d|, fallback share) of the estimate against the exact vectors."""
    out = est(case.path, case.s, case.pos, ds=case.feedrate * case.ts)
    d = np.linalg.norm(out.vector - case.truth, axis=1)
    return float(d.max()), float(d.mean()), float(out.fallback.mean())


def call_time(est: Estimator, case: Case) -> tuple[float, float]:
    """Seconds per call at B = 1 (median over 200 positions, best of 3) and at B = 1024."""
    ds = case.feedrate * case.ts
    idx = np.linspace(0, case.s.size - 1, 200).astype(int)
    singles = [(case.s[i : i + 1], case.pos[i : i + 1]) for i in idx]
    one = math.inf
    for _ in range(3):
        times = []
        for s, p in singles:
            t0 = time.perf_counter()
            est(case.path, s, p, ds=ds)
            times.append(time.perf_counter() - t0)
        one = min(one, float(np.median(times)))
    big = np.linspace(0, case.s.size - 1, 1024).astype(int)
    many = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        est(case.path, case.s[big], case.pos[big], ds=ds)
        many = min(many, time.perf_counter() - t0)
    return one, many


def row(name: str, est: Estimator, case: Case, factor: float, true_max: float,
        true_mean: float) -> tuple[str, float]:
    """One printed line and its max |d| as % of the true max (inf where not applicable)."""
    head = f"{case.path.name:<16}{factor:>4.0f}x {case.feedrate * 1e3:>7.1f} {case.tau * 1e3:>4.0f}"
    head += f" {true_max * UM:>9.2f} {name:<13}"
    try:
        dmax, dmean, fb = accuracy(est, case)
    except ValueError:
        return head + f"{'n/a':>10}", math.inf
    one, many = call_time(est, case)
    pct = 100.0 * dmax / true_max
    return (head + f"{dmax * UM:>10.3f} {pct:>8.2f} {dmean * UM:>9.3f} "
            f"{100.0 * dmean / true_mean:>8.2f} {100.0 * fb:>5.1f} {one * 1e6:>7.1f} "
            f"{many * 1e6:>9.0f}"), pct


def main() -> None:
    ests = {name: factory() for name, factory in ESTIMATORS.items()}
    for est in ests.values():  # compile outside the timings
        est(load("circle"), [0.0], [[0.0, 0.0]], ds=1e-5)
    print(f"# contour error estimators vs exact nearest point; {platform.machine()}, "
          f"{os.cpu_count()} cores visible, one used")
    print(f"{'path':<16}{'F':>5} {'mm/s':>7} {'tau':>4} {'true max':>9} {'estimator':<13}"
          f"{'max|d|':>10} {'%':>8} {'mean|d|':>9} {'%':>8} {'fb%':>5} {'us B=1':>7} "
          f"{'us B=1024':>9}")
    print(f"{'':<16}{'':>5} {'':>7} {'ms':>4} {'um':>9} {'':<13}{'um':>10} {'of max':>8} "
          f"{'um':>9} {'of mean':>8}")
    best: dict[tuple[str, float], list[tuple[float, str]]] = {}
    for name, preset in PATHS:
        for factor in FEED_FACTORS:
            for tau in LAGS:
                case = make_case(name, preset, factor, tau)
                mag = np.linalg.norm(case.truth, axis=1)
                for ename, est in ests.items():
                    line, pct = row(ename, est, case, factor, float(mag.max()), float(mag.mean()))
                    print(line)
                    if ename not in ("ground_truth", "exact"):
                        best.setdefault((name, factor), []).append((pct, ename))
            print()
    print("# worst max|d| (% of true max) over both lags at the paper's feedrate, free-form paths")
    for name in FREE_FORM:
        per = best[(name, 1.0)]
        worst = {e: max(p for p, n in per if n == e) for _, e in per}
        ranked = sorted(worst.items(), key=lambda kv: kv[1])
        print(f"{name:<16} " + "  ".join(f"{e} {p:.3g}%" for e, p in ranked))


if __name__ == "__main__":
    main()
