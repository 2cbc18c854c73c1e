"""``contour-gym optimize PART``: the part program back with new F words (agents.optimize).

Reads the program, searches its feeds on the machine (:func:`agents.optimize.optimize_part`),
writes the new program beside it (or to ``--out``), and prints the cycle time and peak error
before and after, the per-block table (line, old F, new F, peak error there) and, with
``--diff``, the changed lines; the part drawn by its new feed and its error goes to
``OUT_report.png``. With ``--robust N`` the feeds hold on N machines drawn around the given one
(and the whole program on ``AUDIT`` times N more), and the new program is then run on N fresh
ones: how many it holds on is printed.
"""

from __future__ import annotations

import argparse
import difflib
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from agents._files import save_figure
from agents.optimize import SPREAD, OptimizedPart, optimize_part, peaks_on_machines, random_machines
from agents.optimize_plot import part_figure
from contour_gym.files import write_text
from contour_gym.paths import GcodeError, feed_moves, from_gcode

_LENGTH = re.compile(r"^\s*([0-9.eE+-]+)\s*(um|mm|m)?\s*$")
_TO_METRES = {"um": 1e-6, "mm": 1e-3, "m": 1.0, None: 1e-6}


def tolerance(text: str) -> float:
    """A tolerance as the command line gives it: ``5um``, ``0.005mm``, or a number of um."""
    match = _LENGTH.match(text)
    if match is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not a length (e.g. 5um or 0.005mm)")
    try:
        value = float(match.group(1)) * _TO_METRES[match.group(2)]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a length (e.g. 5um)") from None
    if not value > 0.0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"{text!r}: a tolerance is > 0")
    return value


def add_optimize_parser(sub: argparse._SubParsersAction, plant: Callable[[str], str]) -> None:
    """The ``optimize`` subcommand (``plant``: the CLI's preset-or-machine-file type)."""
    opt = sub.add_parser("optimize", help="a part program back with new F words: the shortest "
                         "cycle within a contour tolerance on a machine")
    opt.add_argument("part", metavar="PART", help="the G-code program")
    opt.add_argument("--plant", required=True, type=plant, metavar="PRESET|MACHINE.yaml",
                     help="the machine (a preset or a machine file: a twin from identify)")
    opt.add_argument("--tolerance", required=True, type=tolerance, metavar="LENGTH",
                     help="the largest true contour error allowed, e.g. 5um")
    opt.add_argument("--max-feed", type=float, default=None, metavar="MM_PER_MIN",
                     help="the largest feed to write (default: the machine's)")
    opt.add_argument("--out", default=None, metavar="FILE",
                     help="the new program (default: PART_opt with PART's suffix)")
    opt.add_argument("--no-ccc", action="store_true", help="the machine without its CCC")
    opt.add_argument("--best-effort", action="store_true",
                     help="run blocks no feed holds at the slowest feed (and say so) instead "
                     "of refusing")
    opt.add_argument("--robust", type=int, default=0, metavar="N",
                     help="keep the tolerance on N machines drawn around this one as well (the "
                     "envs' domain randomisation), then check it on N fresh ones")
    opt.add_argument("--seed", type=int, default=0, help="seed of the --robust machines")
    opt.add_argument("--diff", action="store_true", help="print the changed lines")
    opt.add_argument("--no-split", action="store_true",
                     help="never split a long move in two (only F words change)")


def default_out(part: str) -> Path:
    """Where the new program goes by default: ``PART_opt`` with the part's suffix."""
    source = Path(part)
    return source.with_name(f"{source.stem}_opt{source.suffix}")


def optimize_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym optimize``: the new program, the tables, the diff."""
    source = Path(args.part)
    try:
        text = source.read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"{source}: {exc.strerror or exc}") from None
    out = Path(args.out) if args.out else default_out(args.part)
    if out.resolve() == source.resolve():
        raise ValueError(f"--out {out} is the part itself: the given program is kept; write "
                         "the new one elsewhere")
    max_feed = None if args.max_feed is None else args.max_feed * 1e-3 / 60.0
    try:
        before = feed_moves(from_gcode(text))
        gains = None if args.no_ccc else "machine"
        result = optimize_part(text, args.plant, args.tolerance, max_feed=max_feed,
                               best_effort=args.best_effort, ccc_gains=gains,
                               robust=args.robust, seed=args.seed, split=not args.no_split)
    except GcodeError as exc:
        raise ValueError(f"{source}: {exc}") from None
    write_text(out, result.text)
    print(_tables(result, before), end="")
    if args.robust:
        print(_fresh_check(result.text, args, gains))
    report = out.with_name(f"{out.stem}_report.png")
    save_figure(part_figure(result, args.plant, gains), report)
    if args.diff:
        print("\n".join(_changed(text, result.text, source.name, out.name)))
    print(f"program written to {out}, its plot to {report}")
    return 0


def _tables(r: OptimizedPart, before: dict[int, float]) -> str:
    # the before/after table and the per-block table (Markdown)
    robust = "worst_machine_error" in r.after
    lines = ["| | cycle time (s) | max |contour error| (um) |"
             + (" on the worst machine (um) |" if robust else ""),
             "|---|---|---|" + ("---|" if robust else "")]
    for label, run in (("given", r.before), ("optimised", r.after)):
        worst = f" {run['worst_machine_error'] * 1e6:.3g} |" if robust else ""
        lines.append(f"| {label} | {run['cycle_time']:.3f} | "
                     f"{run['max_contour_error'] * 1e6:.3g} |{worst}")
    where = (f"peak error there, worst machine + {SPREAD:g} sd (um)" if robust
             else "peak error there (um)")
    lines += ["", f"| line | old F (mm/min) | new F (mm/min) | {where} |",
              "|---|---|---|---|"]
    for line, peak in r.block_peak.items():
        flag = " (too tight: slowest feed)" if line in r.too_tight else ""
        source = r.source_lines.get(line, line)
        split = f" (line {source}, split)" if _is_split(r, line) else ""
        lines.append(f"| {line}{split} | {before[source] * 6e4:.6g} | "
                     f"{r.feeds[line] * 6e4:.6g} | {peak * 1e6:.2f}{flag} |")
    return "\n".join(lines) + "\n"


def _is_split(r: OptimizedPart, line: int) -> bool:
    # the second half of a split move keeps its line's text but not its number
    source = r.source_lines.get(line, line)
    return sum(1 for v in r.source_lines.values() if v == source) > 1


def _fresh_check(text: str, args: argparse.Namespace, gains: Any) -> str:
    """The new program run on ``--robust`` machines it was not optimised on: what held."""
    fresh = random_machines(args.plant, args.robust, args.seed + 1)
    peaks = peaks_on_machines(text, args.plant, fresh, ccc_gains=gains)
    held = int(np.sum(peaks <= args.tolerance))
    return (f"on {len(fresh)} fresh machines (seed {args.seed + 1}): the tolerance holds on "
            f"{held} of {len(fresh)}, peak errors {np.min(peaks) * 1e6:.3g}-"
            f"{np.max(peaks) * 1e6:.3g} um")


def _changed(old: str, new: str, old_name: str, new_name: str) -> list[str]:
    return [line.rstrip("\n") for line in difflib.unified_diff(
        old.splitlines(), new.splitlines(), old_name, new_name, lineterm="", n=0)]


__all__ = ["add_optimize_parser", "default_out", "optimize_command", "tolerance"]
