"""Where is the peak contour error: along the path, or as the axes stop at its end?

For each path and policy it runs one episode with a per-tick trace and splits the true contour
error at the moment the reference comes within ``--end-reach`` of the path's end: the peak
before (the cut along the path, where a CCC acts) and from then on (the final deceleration and
the stop, where the axes' lag carries them past the end point along the last move and the
contour error estimate, lying along the path, reads little). The episode's peak is the larger
of the two, the ``max_contour_error`` every table quotes; the tool checks that it agrees.

Paths: random paths of ``--seeds`` on ``--plant`` (as ``path="random"`` draws them for that
seed), registered ids (``--ids``) and library paths (``--library``), each with
``--env-kwargs``. G-code parts are left out: their rapid moves are traced but not counted by
the metrics. It is the split docs/measurements.md quotes for 002's machine::

    python benchmarks/end_stop.py --plant lugre_linear_motor --seeds 7000-7011 \\
        --ids contour_gym/CCC-LuGre-BSpline-v1
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from gain_bound import add_path_arguments, failed, paths

from agents.evaluate import make_vector_env, run_episodes
from agents.policies import make_policy
from contour_gym.params import positive

POLICIES = ("no_ccc", "pid_ccc", "ppo_002_ccc_general")


def split(spec: dict[str, Any], policy_name: str, seed: int, reach: float) -> tuple[float, ...]:
    """(peak, peak before ``reach`` of the end, peak after) of one episode, um, and failed.

    Failed as in gain_bound.py: failed, or never in position at the end.
    """
    policy = make_policy(policy_name)
    venv = make_vector_env(spec, policy, num_envs=1, record=True)  # with the policy's env_kwargs
    try:
        out, trace = run_episodes(venv, policy, seed=seed, trace_member=0)
    finally:
        venv.close()
    if trace is None:  # run_episodes returns one for a recording env
        raise RuntimeError("no trace")
    eps = np.abs(np.nan_to_num(trace.eps[0])).max(axis=1)
    s = np.nan_to_num(trace.s[0])
    near = s >= s.max() - reach
    peak = float(out["max_contour_error"][0]) * 1e6
    before = float(eps[~near].max(initial=0.0)) * 1e6
    after = float(eps[near].max(initial=0.0)) * 1e6
    if not np.isclose(max(before, after), peak, rtol=1e-6, atol=1e-3):
        raise RuntimeError(f"{policy_name}: the trace's peak {max(before, after)} um is not the "
                           f"episode's {peak} um")
    return peak, before, after, float(failed(out)[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_path_arguments(parser, gcode=False)
    parser.add_argument("--policies", nargs="+", default=list(POLICIES))
    parser.add_argument("--end-reach", type=float, default=1e-4,
                        help="m: the split, this far before the path's end (default 0.1 mm)")
    args = parser.parse_args()
    try:
        positive(args.end_reach, "--end-reach")
    except ValueError as err:
        parser.error(str(err))
    specs = paths(args)
    if not specs:
        parser.error("give paths: --seeds, --ids or --library")
    head = " | ".join(f"{p}: peak, before, end" for p in args.policies)
    print(f"| path | {head} |\n|---|{'---|' * len(args.policies)}")
    table = []
    for name, spec, seed in specs:
        row = [split({**spec, **args.env_kwargs}, p, seed, args.end_reach) for p in args.policies]
        table.append(row)
        cells = " | ".join(f"{pk:.1f}{' F' if f else ''}, {b:.1f}, {e:.1f}" for pk, b, e, f in row)
        print(f"| {name} | {cells} |", flush=True)
    med = np.median(np.array([[r[:3] for r in row] for row in table]), axis=0)
    print(f"| median | {' | '.join(', '.join(f'{v:.1f}' for v in m) for m in med)} |")
    at_stop = ", ".join(f"{p} {sum(r[i][2] >= r[i][1] for r in table)}"
                        for i, p in enumerate(args.policies))
    print(f"Peak contour error, um: the episode's, before the reference comes within "
          f"{args.end_reach * 1e3:g} mm of the path's end, and from then on (the stop); "
          f"F: failed or never in position. Peaks at the stop: {at_stop} of "
          f"{len(table)}.")


if __name__ == "__main__":
    main()
