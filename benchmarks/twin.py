"""A twin against the machine it models, on paths it never saw (issue 64's Done means).

For each preset named (default: all five), a hidden machine is drawn
(``agents.twin.generate.perturbed_plant``: every axis parameter scaled by a factor in
[0.6, 1.6]), a 30 s recording made on the rig (``excitation``, ``machine_log``) and a twin
identified from it (``agents.twin.fit.identify``, ``--like`` the preset). Both machines then run
held-out paths (the preset's paper path and a random path of another seed), without CCC and with
the preset's PID CCC, on the same seed of noise and disturbances. Printed per run: the time to
identify, the twin's fit, the largest error of a determined value's ratio to the force constant
(``Identified.undetermined`` lists the others, with their errors), and the twin's relative error
on the held-out max contour error, max tracking error and cycle time (the targets: 10 %, 10 %,
1 %), beside the largest change of the machine's own metrics when every axis's mass, or every
axis's damping, moves by 0.1 % (``--nudge``): where that is over a target, no twin can be
expected to meet it (a run that saturates, or ends when a coarse encoder's count creeps into
its in-position band). With ``--tune``, the ``pid`` protocol is tuned on the twin (as ``tune``
does: with copies within its values' uncertainty where its logs left some undetermined) and
on the true machine and both gains run on the true machine: its paper path (tuned on) and paths
neither saw (the target: within 10 %), each with ``--tuner-seeds`` optimiser seeds and their
medians compared.

    python benchmarks/twin.py [PRESET ...] [--seconds 30] [--seed 5] [--nudge 0.001]
                              [--tune [--tuner-seeds 9]]
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.tune import get_protocol, tune
from agents.tune.setters import pid_gains
from agents.twin.fit import identify
from agents.twin.generate import excitation, machine_log, perturbed_plant
from agents.twin.identified import Identified, ratio_errors
from contour_gym.api import simulate
from contour_gym.paths import Path, helix, random_path
from contour_gym.presets import PRESETS, resolve_preset

FloatArray = NDArray[np.float64]
ALL = ("xy_dc_servo", "xyz_pmlsm", "lugre_linear_motor", "xyy_gantry", "xy_servo_coulomb")
COMPARED = {"max_contour_error": "contour", "peak_tracking_error": "tracking",
            "cycle_time": "cycle"}


def held_out(name: str, seed: int) -> dict[str, str | Path | None]:
    """The paths the twin is checked on, none of them recorded.

    The preset's paper path and three random paths from ``seed`` on (3-D: helices of other
    radii and pitches).
    """
    if resolve_preset(name).stage.dim == 3:
        return {"paper": None, "helix r15": helix(0.015, 0.005, 1.5),
                "helix r30": helix(0.03, 0.02, 1.0), "helix r8": helix(0.008, 0.003, 2.0)}
    paths = {f"random {s}": random_path(np.random.default_rng(s)) for s in range(seed, seed + 3)}
    return {"paper": None, **paths}


def compare(hidden: dict[str, Any], twin: dict[str, Any], path: str | Path | None,
            ccc: Any, true: dict[str, Any] | None = None) -> dict[str, float]:
    """The twin's relative error on each :data:`COMPARED` metric (inf when one failed).

    ``true``: the hidden machine's run on ``path`` if already made (``simulate``'s metrics).
    """
    true = simulate(hidden, path, ccc_gains=ccc, seed=1) if true is None else true
    model = simulate(twin, path, ccc_gains=ccc, seed=1)
    if true["failed"] or model["failed"]:
        return {key: float("inf") for key in COMPARED}
    return {key: abs(model[key] / true[key] - 1.0) for key in COMPARED}


def sensitivity(hidden: dict[str, Any], path: str | Path | None, ccc: Any, nudge: float,
                true: dict[str, Any] | None = None) -> dict[str, float]:
    """The largest relative change of each :data:`COMPARED` metric of the machine itself.

    Over four copies: every axis's mass, or every axis's damping, times ``1 - nudge`` or
    ``1 + nudge`` (inf when a copy failed). ``true``: as :func:`compare`'s.
    """
    true = simulate(hidden, path, ccc_gains=ccc, seed=1) if true is None else true
    out = dict.fromkeys(COMPARED, 0.0)
    for key in ("mass", "damping"):
        for factor in (1.0 - nudge, 1.0 + nudge):
            axes = {n: {**a, key: a[key] * factor} for n, a in hidden["stage"]["axes"].items()}
            moved = {**hidden, "stage": {**hidden["stage"], "axes": axes}}
            for metric, error in compare(hidden, moved, path, ccc, true).items():
                out[metric] = max(out[metric], error)
    return out


def tuned_on(plant: dict[str, Any], seed: int, copies: list[dict[str, Any]] | None = None
             ) -> FloatArray:
    """The ``pid`` protocol's gains (absolute) tuned on ``plant`` (protocol defaults).

    ``copies``: machines tuned on beside it, as ``tune`` does on a twin whose logs left
    values undetermined (:meth:`Identified.copies`).
    """
    protocol = get_protocol("pid").on_plant(plant, str(plant.get("name", plant["preset"])),
                                            copies or [])
    result = tune(protocol, seed=seed, progress=False)
    base = resolve_preset(plant).ccc_gains.as_tuple()
    return pid_gains([list(result.params.values())], base)[0]


def tuning_rows(name: str, hidden: dict[str, Any], twin: Identified, seeds: range
                ) -> list[str]:
    """Gains tuned on the twin and on the true machine, both run on the true machine.

    Each tuned with every optimiser seed of ``seeds``: one tuning's score spreads over seeds
    as much as the target (10 %), so the medians are compared. The twin is tuned as ``tune``
    tunes it: with its copies within its values' uncertainty where its logs left some.
    """
    plant, copies = {**twin.plant, "name": f"{name}_twin"}, twin.copies()
    gains = {"true": [tuned_on(hidden, s) for s in seeds],
             "twin": [tuned_on(plant, s, copies) for s in seeds]}
    rows = []
    for label, path in held_out(name, seeds[0] + 200).items():
        peak = {k: np.array([simulate(hidden, path, ccc_gains=tuple(g), seed=1)[
            "max_contour_error"] for g in found]) * 1e6 for k, found in gains.items()}
        mid = {k: float(np.median(v)) for k, v in peak.items()}
        cells = [f"{mid[k]:.3g} ({peak[k].min():.3g}-{peak[k].max():.3g})" for k in peak]
        rows.append(f"| {name} | {label} | {cells[0]} | {cells[1]} | "
                    f"{100 * (mid['twin'] / mid['true'] - 1.0):+.1f} % |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("presets", nargs="*", default=list(ALL), metavar="PRESET",
                        help=f"presets (default all: {', '.join(sorted(PRESETS.names()))})")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--seed", type=int, default=5)
    parser.add_argument("--nudge", type=float, default=1e-3,
                        help="the machine's own change is measured at masses and dampings this "
                        "fraction off (default 0.001)")
    parser.add_argument("--tune", action="store_true",
                        help="also tune the pid protocol on the twin and on the true machine")
    parser.add_argument("--tuner-seeds", type=int, default=9, metavar="K",
                        help="with --tune: optimiser seeds per machine (medians compared)")
    args = parser.parse_args()
    print("| preset | identify (s) | NRMSE per axis | worst determined | undetermined (error) | "
          "held-out path | CCC | contour | tracking | cycle | the machine's own change "
          f"at {100 * args.nudge:g} % (contour / tracking / cycle) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    tuning = []
    for name in args.presets:
        rng = np.random.default_rng(args.seed)
        hidden = perturbed_plant(name, rng)
        log = machine_log(hidden, excitation(resolve_preset(hidden), rng, args.seconds),
                          seed=args.seed)
        start = time.perf_counter()
        twin = identify([log], name)
        wall = time.perf_counter() - start
        for row in _check_rows(name, hidden, twin, (wall, args.nudge), args.seed):
            print(row, flush=True)
        if args.tune:
            tuning += tuning_rows(name, hidden, twin,
                                  range(args.seed, args.seed + args.tuner_seeds))
    if tuning:
        print("\n| preset | path (paper: tuned on) | peak, tuned on the machine: median "
              "(range), um | tuned on the twin | median against median |")
        print("|---|---|---|---|---|")
        print("\n".join(tuning))


def _check_rows(name: str, hidden: dict[str, Any], twin: Identified,
                wall_nudge: tuple[float, float], seed: int) -> list[str]:
    wall, nudge = wall_nudge
    nrmse = ", ".join(f"{100 * v:.2g} %" for v in twin.nrmse.values())
    errors = ratio_errors(twin.values, hidden, name)
    loose = {(a, n) for a, names in twin.undetermined().items() for n in names}
    kept = [abs(e) for k, e in errors.items() if k not in loose]
    worst = f"{100 * max(kept, default=0.0):.2g} %"
    undetermined = ", ".join(f"{a}.{n} ({100 * errors[(a, n)]:+.0f} %)"
                             for a, n in sorted(loose)) or "none"
    gains = resolve_preset(name).ccc_gains
    rows = []
    for label, path in held_out(name, seed + 100).items():
        for ccc_label, ccc in (("none", None), ("PID", gains)):
            true = simulate(hidden, path, ccc_gains=ccc, seed=1)
            cells = " | ".join(f"{100 * e:.2f} %" for e in
                               compare(hidden, twin.plant, path, ccc, true).values())
            own = " / ".join(f"{100 * e:.2f}" for e in
                             sensitivity(hidden, path, ccc, nudge, true).values())
            rows.append(f"| {name} | {wall:.1f} | {nrmse} | {worst} | {undetermined} | {label} | "
                        f"{ccc_label} | {cells} | {own} % |")
    return rows


if __name__ == "__main__":
    main()
