"""The ``contour-gym`` command.

``contour-gym simulate`` runs a preset on its paper's path (or any library path) without and
with PID CCC, prints the metrics side by side (um, s) and writes the contour plot.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path as FilePath

from contour_gym.api import make_scenario, run_trace
from contour_gym.presets import PRESETS

ROWS = (
    ("max_contour_error", "max |contour error| (um)", 1e6),
    ("mean_contour_error", "mean |contour error| (um)", 1e6),
    ("rms_contour_error", "RMS contour error (um)", 1e6),
    ("p_e", "P_e, sum of mean |tracking error| (um)", 1e6),
    ("chattering", "control total variation", 1.0),
    ("cycle_time", "cycle time (s)", 1.0),
)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="contour-gym", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sim = sub.add_parser("simulate", help="no CCC vs PID CCC on one preset and path")
    sim.add_argument("--plant", default="xy_dc_servo", choices=PRESETS)
    sim.add_argument("--path", default=None, help="library path name (default: the paper's)")
    sim.add_argument("--feedrate", type=float, default=None, help="mm/min (default: the paper's)")
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument("--out", default="contour_gym_simulate.png", help="plot file")
    train = sub.add_parser("train", help="train a stable-baselines3 agent (needs the rl extra)")
    train.add_argument("--env", default="contour_gym/CCC-Circle-v0", help="registered env id")
    train.add_argument("--algo", default="ppo", choices=("ppo", "sac"))
    train.add_argument("--steps", type=int, default=50_000, help="env steps")
    train.add_argument("--seed", type=int, default=0)
    train.add_argument("--out", default="runs", help="folder for checkpoints and the model")
    return parser


def format_table(columns: dict[str, dict[str, float]]) -> str:
    """Render metrics of several runs as an aligned text table (reporting units)."""
    names = list(columns)
    width = max(len(label) for _, label, _ in ROWS)
    lines = [f"{'metric':<{width}}  " + "  ".join(f"{n:>12}" for n in names)]
    for key, label, scale in ROWS:
        cells = "  ".join(f"{columns[n][key] * scale:>12.4g}" for n in names)
        lines.append(f"{label:<{width}}  {cells}")
    return "\n".join(lines)


def _save_atomically(fig: object, target: FilePath) -> None:
    # Write next to the target, then rename: an interrupted run never leaves half a file.
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(suffix=target.suffix, dir=target.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=120)  # type: ignore[attr-defined]
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def simulate_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym simulate``."""
    from contour_gym.render import contour_figure

    feedrate = None if args.feedrate is None else args.feedrate / 60e3
    scenario = make_scenario(args.plant, args.path, feedrate)
    columns, traces = {}, {}
    for label, gains in (("no CCC", None), ("PID CCC", scenario.preset.ccc_gains.as_tuple())):
        columns[label], traces[label] = run_trace(scenario, gains, args.seed)
    preset = scenario.preset
    print(
        f"plant {preset.name} (paper {preset.paper}), path {scenario.path.name} "
        f"({scenario.path.length * 1e3:.1f} mm), feedrate {scenario.feedrate * 60e3:.0f} mm/min"
    )
    print(format_table(columns))
    contour = preset.stage.contours[0]
    fig = contour_figure(
        scenario.path, traces, axes=contour.axes[:2], offset=(contour.offset or (0.0, 0.0))[:2]
    )
    _save_atomically(fig, FilePath(args.out))
    print(f"plot written to {args.out}")
    return 0


def train_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym train``: checkpoints as it goes, the model at the end or on Ctrl-C."""
    from agents.rl.train import train

    path = train(args.env, args.algo, args.steps, seed=args.seed, out_dir=args.out)
    print(f"model saved to {path}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``contour-gym`` command."""
    args = _parser().parse_args(argv)
    command = {"simulate": simulate_command, "train": train_command}[args.command]
    try:
        return command(args)
    except ValueError as exc:
        print(f"contour-gym: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
