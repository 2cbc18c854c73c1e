"""The ``contour-gym`` command.

``contour-gym simulate`` runs a preset on its paper's path (or any library path), or a G-code
part file (``--gcode PART.nc``) at the program's own feeds, without and with PID CCC, prints
the metrics side by side (um, s) and writes the plot: for a library path the path and the
magnified contour, for a part its tool path coloured by the contour error.

``contour-gym tune PROTOCOL`` runs a tuning protocol of :mod:`agents.tune` (``000``: paper
000's improved PSO over the fuzzy PID CCC's five factors) with any optimiser of
:mod:`agents.optim` and writes ``result.json`` and the plots into its run folder.

``contour-gym bench [--suite NAME_OR_PATH] [--out DIR]`` scores every policy of a suite on its
scenarios (:mod:`agents.bench`), prints the table and writes it (Markdown, CSV) with the plots
into a run folder that a stopped run resumes from.
"""

from __future__ import annotations

import argparse
import math
import os
import shlex
import signal
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path as FilePath
from typing import TYPE_CHECKING

import numpy as np

from agents._files import check_plot, save_figure
from agents.cli_optimize import add_optimize_parser, default_out, optimize_command
from agents.parallel import exit_quickly
from agents.rl.algorithms import ALGORITHMS
from agents.twin.check import caution, copies_of
from agents.twin.identified import COPIES
from contour_gym import precompile
from contour_gym.api import Scenario, make_scenario, run_trace
from contour_gym.files import output_file, output_folder, write_text
from contour_gym.logs import LENGTH_UNITS, read_log
from contour_gym.loop import REASON_NAMES
from contour_gym.machines import is_machine_file, plant_of, write_machine
from contour_gym.params import choice
from contour_gym.paths import WORK_SYSTEMS, GcodeError, GcodePath, from_gcode
from contour_gym.presets import PRESETS

if TYPE_CHECKING:
    from agents.twin.fit import Identified

DEFAULT_PLANT = "xy_dc_servo"
PART_PLANTS = {2: "xy_servo_coulomb", 3: "xyz_pmlsm"}  # default machine of a part, by its dim

ROWS = (
    ("max_contour_error", "max |contour error| (um)", 1e6),
    ("mean_contour_error", "mean |contour error| (um)", 1e6),
    ("rms_contour_error", "RMS contour error (um)", 1e6),
    ("p_e", "P_e, sum of mean |tracking error| (um)", 1e6),
    ("chattering", "control total variation", 1.0),
    ("cycle_time", "cycle time (s)", 1.0),
)


class InputFileError(Exception):
    """An input file that cannot be run; the message names the file (and the line)."""


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def _count(text: str) -> int:
    """A whole number >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not >= 1")
    return value


def _positive(text: str) -> float:
    value = _finite(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def _plant(text: str) -> str:
    """A preset's name or a machine file's path (contour_gym.machines), as given."""
    if is_machine_file(text) or text in PRESETS.names():
        return text
    raise argparse.ArgumentTypeError(
        f"{text!r} is neither a preset ({', '.join(sorted(PRESETS.names()))}) nor a machine "
        "file (.yaml)")


def _key_value(text: str, form: str) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"expected {form}, got {text!r}")
    return key.strip(), value


def _work_offset(text: str) -> tuple[str, tuple[float, ...]]:
    """``G54=X,Y[,Z]`` (mm) -> ("G54", (x, y[, z])) in m."""
    name, value = _key_value(text, "G54=X,Y[,Z]")
    name = name.upper()
    if name not in WORK_SYSTEMS:
        raise argparse.ArgumentTypeError(f"unknown work offset {name!r}; accepted: "
                                         f"{', '.join(WORK_SYSTEMS)}")
    coords = tuple(_finite(v) * 1e-3 for v in value.split(","))
    if len(coords) not in (2, 3):
        raise argparse.ArgumentTypeError(f"expected X,Y or X,Y,Z (mm), got {value!r}")
    return name, coords


def _tool_length(text: str) -> tuple[int, float]:
    """``H=LENGTH`` (mm) -> (H, length in m)."""
    number, value = _key_value(text, "H=LENGTH")
    if not number.isdigit() or int(number) < 1:
        raise argparse.ArgumentTypeError(f"tool number must be an integer >= 1, got {number!r}")
    return int(number), _finite(value) * 1e-3


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="contour-gym", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    _add_simulate_parser(sub)
    _add_train_parser(sub)
    _add_tune_parser(sub)
    _add_bench_parser(sub)
    _add_identify_parser(sub)
    add_optimize_parser(sub, _plant)
    return parser


def _add_identify_parser(sub: argparse._SubParsersAction) -> None:
    ident = sub.add_parser("identify", help="a twin of your machine from its servo logs, as a "
                           "machine file (--plant MACHINE.yaml then runs on it)")
    ident.add_argument("logs", nargs="+", metavar="LOG",
                       help="servo logs: CSV (time, <axis>_cmd, <axis>_fb[, <axis>_effort]) or "
                       "halsampler output (with --columns and --period)")
    ident.add_argument("--like", required=True, type=_plant, metavar="PRESET|MACHINE.yaml",
                       help="the preset (or a machine file with your controller's gains) whose "
                       "structure and controllers the twin keeps")
    ident.add_argument("--out", required=True, metavar="MACHINE.yaml", help="the machine file")
    ident.add_argument("--length-unit", default="m", choices=list(LENGTH_UNITS),
                       help="the logs' length unit (default m)")
    ident.add_argument("--columns", default=None, metavar="PIN[,PIN...]",
                       help="halsampler: each column's HAL pin, e.g. joint.0.motor-pos-cmd")
    ident.add_argument("--period", type=_positive, default=None, metavar="S",
                       help="halsampler: the sampler's thread period, s")
    ident.add_argument("--joints", default=None, metavar="0=x,1=y",
                       help="halsampler: joint number to axis name (default 0=x,1=y,2=z)")
    ident.add_argument("--ideal", action="store_true",
                       help="replay without encoder, noise or delay (logs of ideal runs)")
    ident.add_argument("--starts", type=_count, default=3, metavar="N",
                       help="least-squares starts (default 3; more take longer and find more "
                       "of the values the logs cannot tell apart)")


def _add_simulate_parser(sub: argparse._SubParsersAction) -> None:
    sim = sub.add_parser("simulate", help="no CCC vs PID CCC on one preset and path or part")
    sim.add_argument(
        "--plant", default=None, type=_plant, metavar="PRESET|MACHINE.yaml",
        help=f"a preset ({', '.join(sorted(PRESETS.names()))}) or a machine file (default: "
        f"{DEFAULT_PLANT}; for a part, {PART_PLANTS[2]} if it is 2-D, {PART_PLANTS[3]} if 3-D)",
    )
    where = sim.add_mutually_exclusive_group()
    where.add_argument("--path", default=None, help="library path name (default: the paper's)")
    where.add_argument("--gcode", default=None, metavar="PART.nc",
                       help="G-code part file, run at its own F words")
    sim.add_argument(
        "--feedrate", type=_positive, default=None,
        help="mm/min (default: the paper's, or a part's own F words, which it replaces)",
    )
    sim.add_argument("--feedrate-override", type=_positive, default=1.0, metavar="FRACTION",
                     help="feed override, fraction of the programmed feeds (default 1)")
    part = sim.add_argument_group("G-code part setup (mm)")
    part.add_argument("--work-offset", type=_work_offset, action="append", default=[],
                      metavar="G54=X,Y[,Z]", help="a work offset's machine position (repeat)")
    part.add_argument("--tool-length", type=_tool_length, action="append", default=[],
                      metavar="H=LENGTH", help="tool length of H number H (repeat)")
    part.add_argument("--cut-z", type=_finite, default=0.0, metavar="Z",
                      help="program Z at or below which a feed move cuts (default 0)")
    part.add_argument("--default-feed", type=_positive, default=None, metavar="MM_PER_MIN",
                      help="feed of the moves before the program's first F word (default: "
                      "such a move is an error)")
    sim.add_argument("--seed", type=int, default=0)
    sim.add_argument("--out", default="contour_gym_simulate.png", help="plot file")
    sim.add_argument("--dpi", type=_positive, default=120.0, help="plot resolution")


def _add_train_parser(sub: argparse._SubParsersAction) -> None:
    train = sub.add_parser("train", help="train a stable-baselines3 agent on the native vector "
                           "env (needs the rl extra; configs/rl/ALGO.yml)")
    train.add_argument("env", nargs="?", default=None, metavar="ENV_ID",
                       help="registered env id with a block in the config, e.g. "
                       "contour_gym/CCC-Circle-v0 (not with --resume)")
    train.add_argument("--algo", default=["ppo"], type=_algorithms, metavar="ALGO[,ALGO...]",
                       help="RL algorithm, or several to train each (agents.rl.algorithms: "
                       f"{', '.join(ALGORITHMS.names())}; sb3-contrib's when installed)")
    train.add_argument("--timesteps", type=int, default=None, metavar="N",
                       help="env steps (default: the config's n_timesteps; with --resume, the "
                       "run's)")
    seeds = train.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=int, default=None, help="the run's seed (default 0)")
    seeds.add_argument("--seeds", type=_seed_list, default=None, metavar="S[,S...]",
                       help="train one run per seed, in parallel")
    train.add_argument("--sweep", action="append", default=[], metavar="KEY=V1[,V2...]",
                       help="train one run per value of a config key (repeat for a grid), "
                       "e.g. learning_rate=1e-4,3e-4; runs go in OUT/KEY=VALUE/")
    _add_parallel_arguments(train, "runs trained at once, in worker processes (Ray Tune "
                            "trials with --ray)")
    _add_plant_argument(train, "train on this machine instead of the id's (a twin from "
                        "contour-gym identify); the run's config records it")
    train.add_argument("--out", default="runs", help="parent folder of the run folder")
    train.add_argument("--resume", default=None, metavar="RUN",
                       help="continue the run folder RUN from its latest checkpoint")
    train.add_argument("--config", default=None, metavar="FILE",
                       help="rl-zoo YAML (default: the shipped configs/rl/ALGO.yml)")
    train.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_tune_parser(sub: argparse._SubParsersAction) -> None:
    tune = sub.add_parser("tune", help="tune a controller's parameters by a protocol "
                          "(agents.tune: 000 = paper 000's improved PSO fuzzy PID CCC)")
    tune.add_argument("protocol", metavar="PROTOCOL", help="tuning protocol name, e.g. 000")
    tune.add_argument("--optimizer", default=None, metavar="NAME",
                      help="optimiser of agents.optim (default: the protocol's)")
    tune.add_argument("--seed", type=int, default=0, help="optimiser seed (default 0)")
    tune.add_argument("--iterations", type=int, default=None, metavar="T",
                      help="generations after the initial one (default: the protocol's)")
    tune.add_argument("--population", type=int, default=None, metavar="M",
                      help="candidates per generation (default: the protocol's)")
    _add_plant_argument(tune, "run the protocol's scenarios on this machine (a twin from "
                        "contour-gym identify) and say how to carry the result to it")
    tune.add_argument("--copies", type=int, default=COPIES, metavar="K",
                      help="on a twin whose logs left values undetermined: tune on it and K "
                      f"copies drawn within their uncertainty (default {COPIES}; 0: it alone)")
    tune.add_argument("--out", default=None, metavar="DIR",
                      help="run folder (default runs/tune/PROTOCOL-OPTIMIZER-seedN[-ideal]"
                      "[-on-MACHINE])")
    tune.add_argument("--ideal", action="store_true",
                      help="no encoder, noise or delay (the papers' pure simulations)")
    _add_parallel_arguments(tune, "threads running the population (with --ray: the "
                            "population spread over the cluster's CPUs)")
    tune.add_argument("--quiet", action="store_true", help="no progress bar")
    tune.add_argument("--overwrite", action="store_true",
                      help="replace a finished result in the run folder")


def _add_plant_argument(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--plant", default=None, type=_plant, metavar="PRESET|MACHINE.yaml",
                        help=what)


def _add_bench_parser(sub: argparse._SubParsersAction) -> None:
    bench = sub.add_parser("bench", help="score every policy of a suite on its scenarios "
                           "(agents.bench): tables and plots in a run folder")
    bench.add_argument("--suite", default="default", metavar="NAME_OR_PATH",
                       help="a shipped suite (configs/suites: default, tiny) or a YAML file "
                       "(default: default)")
    bench.add_argument("--out", default=None, metavar="DIR",
                       help="run folder; an existing run of the same suite resumes (default "
                       "runs/bench/SUITE-HASH)")
    _add_parallel_arguments(bench, "cells run at once, in worker processes")
    bench.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_parallel_arguments(parser: argparse.ArgumentParser, what: str) -> None:
    parser.add_argument("--workers", type=_workers, default=None, metavar="N",
                        help=f"{what} (default: every CPU; 1: one after another; the numbers "
                        "do not depend on it)")
    parser.add_argument("--ray", default=None, metavar="ADDRESS",
                        help="run on a Ray cluster: 'auto' (this machine's cluster), "
                        "HOST:PORT of its head, or 'local' (start one here); needs the ray "
                        "extra: pip install \"contour-gym[ray]\"")


def _algorithms(text: str) -> list[str]:
    names = [t.strip() for t in text.split(",")]
    for name in names:
        if name not in ALGORITHMS.names():
            raise argparse.ArgumentTypeError(
                f"unknown algorithm {name!r}; accepted: {', '.join(ALGORITHMS.names())}")
    return names


def _seed_list(text: str) -> list[int]:
    try:
        return [int(t) for t in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"seeds are integers, e.g. 0,1,2; got {text!r}") from None


def _workers(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text!r}")
    return value


def format_table(columns: dict[str, dict[str, float]]) -> str:
    """Render metrics of several runs as an aligned text table (reporting units)."""
    names = list(columns)
    width = max(len(label) for _, label, _ in ROWS)
    lines = [f"{'metric':<{width}}  " + "  ".join(f"{n:>12}" for n in names)]
    for key, label, scale in ROWS:
        cells = "  ".join(f"{columns[n][key] * scale:>12.4g}" for n in names)
        lines.append(f"{label:<{width}}  {cells}")
    return "\n".join(lines)


def read_part(args: argparse.Namespace) -> GcodePath:
    """Read and parse the ``--gcode`` file with the part setup options.

    Args:
        args: The parsed ``simulate`` arguments (``gcode``, ``work_offset``, ``tool_length``,
            ``cut_z``, ``default_feed``; lengths in mm, feeds in mm/min).

    Returns:
        The part in machine coordinates, before it is mapped onto a machine's axes.

    Raises:
        InputFileError: the file cannot be read or run (``PART.nc: line N: ...``).
    """
    name = args.gcode
    try:
        text = FilePath(name).read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise InputFileError(f"{name}: {exc.strerror or exc}") from None
    with _naming(name):
        part = from_gcode(text, work_offsets=dict(args.work_offset) or None,
                          tool_lengths=dict(args.tool_length) or None, cut_z=args.cut_z * 1e-3,
                          default_feed=None if args.default_feed is None else
                          args.default_feed * 1e-3 / 60.0)
    if not np.any(part.cutting):
        raise InputFileError(f"{name}: nothing to cut: every move is a rapid (G0), or above "
                             f"--cut-z {args.cut_z:g} mm on a 3-D program")
    return part


@contextmanager
def _naming(name: str) -> Iterator[None]:
    """Turn a G-code or value error into an :class:`InputFileError` naming file ``name``."""
    try:
        yield
    except GcodeError as exc:
        raise InputFileError(f"{name}: line {exc.line}: {exc.message}") from None
    except ValueError as exc:
        raise InputFileError(f"{name}: {exc}") from None


def scenario_of(args: argparse.Namespace) -> Scenario:
    """The scenario ``contour-gym simulate`` runs: a preset on a library path or a part.

    A part runs at its own F words (or ``--feedrate``) times ``--feedrate-override``, on
    ``--plant`` or, by default, on :data:`PART_PLANTS`'s machine of its dimension.

    Args:
        args: The parsed ``simulate`` arguments.

    Returns:
        The scenario.

    Raises:
        InputFileError: the ``--gcode`` file cannot be read or run on the machine.
        ValueError: unknown library path, or a bad combination of options.
    """
    feedrate = None if args.feedrate is None else args.feedrate / 60e3
    if args.gcode is None:
        return make_scenario(args.plant or DEFAULT_PLANT, args.path, feedrate,
                             feedrate_override=args.feedrate_override)
    part = read_part(args)
    with _naming(args.gcode):  # mapping onto the machine's axes can reject a line
        return make_scenario(args.plant or PART_PLANTS[part.dim], part, feedrate,
                             feedrate_override=args.feedrate_override)


def _headline(scenario: Scenario, part: str | None) -> str:
    preset, path = scenario.preset, scenario.path
    line = f"plant {preset.name} (paper {preset.paper}), "
    if part is None:
        line += f"path {path.name} ({path.length * 1e3:.1f} mm), "
        line += f"feedrate {scenario.feedrate * 60e3:.0f} mm/min"
    else:
        cutting = np.asarray(getattr(path, "cutting", True), dtype=bool)
        cut = float(np.diff(path.table.s0)[cutting].sum())
        line += f"part {part} ({path.length * 1e3:.1f} mm, {cut * 1e3:.1f} mm cutting), "
        line += f"feeds up to {scenario.feedrate * 60e3:.0f} mm/min"
    if scenario.feed_override != 1.0:
        line += f", feed override {scenario.feed_override:g}"
    return line


def _compile_up_front(args: argparse.Namespace, *groups: str) -> None:
    # the built-ins' kernels a command of many combinations needs, compiled in parallel
    # before it runs (first run). A command of one combination (simulate, tune, train) runs
    # on its own kernel instead, compiled in half the time (contour_gym.jit.tiers)
    precompile(groups, progress=not getattr(args, "quiet", False))


def identify_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym identify``: the machine file, its report, and the fit on stdout."""
    from agents.twin.check import following, nrmse, split_at_rest, verdict
    from agents.twin.fit import identify, random_axes
    from contour_gym.presets import resolve_preset

    logs = [read_log(p, columns=args.columns, period=args.period, joints=args.joints,
                     length_unit=args.length_unit) for p in args.logs]
    if len(logs) > 1:
        fit_logs, held = logs[:-1], logs[-1]
    else:
        first, held = split_at_rest(logs[0])
        fit_logs = [first]
    twin = identify(fit_logs, args.like, ideal=args.ideal, starts=args.starts)
    out = FilePath(args.out)
    plant = {**twin.plant, "name": out.stem}
    held_errors = {a: e for a, e in following(held, plant, ideal=args.ideal).items()
                   if a in twin.nrmse}
    held_nrmse = nrmse(held_errors)
    said = verdict(twin.nrmse, held_nrmse, twin.undetermined(),
                   random_axes(resolve_preset(plant)))
    record = {"logs": list(args.logs), "values": twin.values, "std": twin.std,
              "bias": twin.bias, "undetermined": twin.undetermined(), "fixed": twin.fixed,
              "nrmse_fit": twin.nrmse, "nrmse_held_out": held_nrmse, "verdict": said}
    figure = out.with_name(f"{out.stem}_report.png")
    _identify_plot(figure, (fit_logs[0], following(fit_logs[0], plant, ideal=args.ideal)),
                   (held, held_errors))
    write_machine(out, plant, identified=record)
    report = _identify_report(twin, held_nrmse, said, figure.name)
    write_text(out.with_name(f"{out.stem}_report.md"), report)
    print(report, end="")
    print(f"machine file written to {args.out}; run on it with --plant {args.out}")
    return 0


def _identify_plot(target: FilePath, fitted: tuple, held: tuple) -> None:
    import matplotlib.pyplot as plt

    from agents.twin.check import report_figure

    fig = report_figure(fitted, held)
    try:
        save_figure(fig, target)
    finally:
        plt.close(fig)


def _identify_report(twin: Identified, held: dict[str, float], said: str, figure: str) -> str:
    # the parameter table, the fit and held-out NRMSE per axis, the verdict and the plot
    loose = twin.reasons()
    lines = ["| axis | parameter | value | std | fit's bias (corrected) | determined by the logs |",
             "|---|---|---|---|---|---|"]
    for axis, values in twin.values.items():
        sd, bias = twin.std[axis], twin.bias.get(axis, {})
        lines += [f"| {axis} | {k} | {v:.6g} | {sd[k]:.2g} | {100 * bias.get(k, 0.0):+.2g} % | "
                  f"{'no: ' + loose[axis][k] if k in loose.get(axis, {}) else 'yes'} |"
                  for k, v in values.items()]
    lines += ["", "| axis | NRMSE, fitted | NRMSE, held out |", "|---|---|---|"]
    lines += [f"| {a} | {100 * twin.nrmse[a]:.3g} % | {100 * held[a]:.3g} % |" for a in held]
    lines += ["", *(f"{k}: {why}" for k, why in twin.fixed.items()), f"verdict: {said}", "",
              f"![measured and twin following error]({figure})", ""]
    return "\n".join(lines)


def simulate_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym simulate``."""
    from contour_gym.render import contour_figure, part_figure

    scenario = scenario_of(args)
    columns, traces = {}, {}
    for label, gains in (("no CCC", None), ("PID CCC", scenario.preset.ccc_gains.as_tuple())):
        columns[label], traces[label] = run_trace(scenario, gains, args.seed)
    print(_headline(scenario, args.gcode))
    print(format_table(columns))
    contour = scenario.preset.stage.contours[0]
    axes, offset = contour.axes[:2], (contour.offset or (0.0, 0.0))[:2]
    if args.gcode is None:
        fig = contour_figure(scenario.path, traces, axes=axes, offset=offset)
    else:
        fig = part_figure(scenario.path, traces, axes=axes, offset=offset,
                          title=FilePath(args.gcode).name)
    save_figure(fig, FilePath(args.out), args.dpi)
    print(f"plot written to {args.out}")
    return _report_failures(columns)


def _report_failures(columns: dict[str, dict[str, float]]) -> int:
    # a failed run is said on stderr, with its reason, and exits 1 (its metrics are not a result)
    failed = {k: REASON_NAMES[m["failure_reason"]] for k, m in columns.items() if m["failed"]}
    for label, reason in failed.items():
        print(f"contour-gym: the {label} run failed: {reason}", file=sys.stderr)
    return 1 if failed else 0


def train_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym train``: a run folder; Ctrl-C saves the model and a checkpoint.

    Several seeds, algorithms or swept values (or ``--ray``) train as a sweep
    (:mod:`agents.rl.sweep`), in parallel.
    """
    from agents.rl.sweep import parse_grid, run_trials, trials

    if (args.env is None) == (args.resume is None):
        raise ValueError("give an ENV_ID to train, or --resume RUN to continue a run (not both)")
    if args.resume is not None and args.plant is not None:
        raise ValueError("--resume continues a run on its own machine (its config.yml): "
                         "not with --plant")
    if args.resume is not None and (args.seeds or args.sweep or len(args.algo) > 1 or args.ray):
        raise ValueError("--resume continues one run; run a sweep again to resume it (not "
                         "--resume with --seeds, --sweep, several --algo or --ray)")
    seeds = args.seeds or [0 if args.seed is None else args.seed]
    grid = parse_grid(args.sweep)
    if args.resume is None and (len(seeds) > 1 or len(args.algo) > 1 or grid or args.ray):
        todo = trials(args.env, args.algo, seeds, grid, args.out, args.timesteps, args.config,
                      args.plant)
        print(f"training {len(todo)} run(s) of {args.env}", file=sys.stderr)
        for folder in run_trials(todo, args.workers, args.ray):
            print(f"run written to {folder}")
        for line in caution(args.plant):
            print(line)
        return 0
    args.algo, args.seed = args.algo[0], seeds[0]
    return _train_one(args)


def _train_one(args: argparse.Namespace) -> int:
    from agents.rl.train import run_name, train

    argv = ["contour-gym", "train"] + ([args.env] if args.env else [])
    argv += ["--algo", args.algo, "--seed", str(args.seed), "--out", args.out]
    argv += ["--timesteps", str(args.timesteps)] if args.timesteps is not None else []
    argv += ["--config", args.config] if args.config is not None else []
    argv += ["--plant", args.plant] if args.plant is not None else []
    machine = None if args.plant is None else plant_of(args.plant)[1]
    run = args.resume or os.path.join(args.out, run_name(args.env, args.algo, args.seed, machine))
    try:
        train(args.env, args.algo, args.timesteps, seed=args.seed, out_dir=args.out,
              resume=args.resume, config_file=args.config, progress=not args.quiet,
              command=shlex.join(argv), plant=args.plant)
    except KeyboardInterrupt:
        print(f"contour-gym: interrupted; model and checkpoint saved in {run}; continue with "
              f"contour-gym train --resume {shlex.quote(str(run))}", file=sys.stderr)
        return 130
    print(f"run written to {run} (model.zip, eval.csv, eval.png, checkpoints/, tensorboard/)")
    for line in caution(args.plant):
        print(line)
    return 0


def tune_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym tune``: writes the run folder and prints the best parameters."""
    from agents.optim import OPTIMIZERS
    from agents.tune import get_protocol, tune
    from agents.tune.result import carry_to_machine

    protocol = get_protocol(args.protocol)  # unknown names list the accepted ones
    optimizer = choice(args.optimizer or protocol.optimizer, "optimizer", OPTIMIZERS)
    plant, machine = (None, "") if args.plant is None else plant_of(args.plant)
    out = args.out
    if out is None:
        suffix = ("-ideal" if args.ideal else "") + (f"-on-{machine}" if machine else "")
        out = os.path.join("runs", "tune", f"{protocol.name}-{optimizer}-seed{args.seed}{suffix}")
    copies = copies_of(args.plant, args.copies)
    if plant is not None:
        protocol = protocol.on_plant(plant, machine, copies)
    argv = ["contour-gym", "tune", protocol.name, "--optimizer", optimizer, "--seed",
            str(args.seed)]
    for flag, value in (("--population", args.population), ("--iterations", args.iterations)):
        if value is not None:
            argv += [flag, str(value)]
    argv += ["--ideal"] * args.ideal + (["--plant", args.plant] if plant is not None else [])
    argv += ["--copies", str(args.copies)] if copies else []
    argv += ["--out", out]
    result = tune(protocol, optimizer, seed=args.seed, population=args.population,
                  iterations=args.iterations, ideal=args.ideal, out=out,
                  progress=not args.quiet, command=shlex.join(argv),
                  workers=args.workers, overwrite=args.overwrite, ray=args.ray)
    print(f"protocol {result.protocol}, {result.optimizer}, seed {result.seed}: best fitness "
          f"{result.fitness * 1e6:.6g} um ({result.settings['fitness']}) after "
          f"{result.nfev} candidates in {result.wall_time:.1f} s")
    for name, value in result.params.items():
        print(f"  {name} = {value:.6g}")
    if protocol.start_at_reference and result.params == protocol.reference_point():
        print("  (the start point, the untuned law: no candidate beat it)")
    for env_id, value in result.per_scenario.items():
        print(f"  {env_id}: {value * 1e6:.6g} um")
    if plant is not None:
        print("\n".join(carry_to_machine(result.params, protocol, plant)))
        for line in caution(args.plant, len(copies)):
            print(line)
    print(f"results written to {out}")
    return 0


def bench_command(args: argparse.Namespace) -> int:
    """Run ``contour-gym bench``: prints the table, writes the run folder (resumable)."""
    from agents.bench import run_suite

    _compile_up_front(args, "loop", "env", "path_api")
    result = run_suite(args.suite, args.out, progress=not args.quiet, workers=args.workers,
                       ray=args.ray)
    print(result.markdown, end="")
    print(f"\n{len(result.computed)} cell(s) computed in {result.wall_time:.1f} s; tables and "
          f"plots written to {result.out}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``contour-gym`` command."""
    exit_quickly()
    args = _parser().parse_args(argv)
    command = {"simulate": simulate_command, "train": train_command, "tune": tune_command,
               "bench": bench_command, "identify": identify_command,
               "optimize": optimize_command}[args.command]
    signal.signal(signal.SIGTERM, _interrupted)  # `kill PID` ends as Ctrl-C does: files whole
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            # the -v0 ids stay supported beside -v1 (the shipped agents were trained on them)
            warnings.filterwarnings("ignore", message=r".*contour_gym/\S+-v0 is out of date")
            _check_outputs(args)
            return command(args)
    except KeyboardInterrupt:  # train says what it kept itself (_train_one)
        print(f"contour-gym: interrupted; {KEPT[args.command]}", file=sys.stderr)
        return 130
    except InputFileError as exc:
        print(exc, file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"contour-gym: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # --out on a file, a read-only or full disk: the file and the cause
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"contour-gym: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 1


# what an interrupted command kept, and how to go on
KEPT = {
    "simulate": "nothing was written",
    "bench": "the cells computed so far are kept in the run folder; the same command goes on "
             "from them",
    "tune": "the generations so far are kept in the run folder; the same command resumes "
            "from them",
    "identify": "nothing was written",
    "optimize": "nothing was written",
    "train": "each run's model and checkpoints so far are kept in its folder under --out; "
             "continue one with contour-gym train --resume FOLDER",
}


def _interrupted(signum: int, frame: object) -> None:
    """SIGTERM as Ctrl-C: the command's finally clauses run (no temp file left behind)."""
    raise KeyboardInterrupt


def _check_outputs(args: argparse.Namespace) -> None:
    """Refuse an ``--out`` where nothing may be written, before any work (agents._files)."""
    if args.command == "identify":
        if not is_machine_file(args.out):
            raise ValueError(f"--out {args.out}: a machine file's name ends in .yaml or .yml")
        output_file(args.out, "--out")
        out = FilePath(args.out)
        for suffix in ("_report.md", "_report.png"):  # written beside it
            output_file(str(out.with_name(out.stem + suffix)), "--out's report")
    elif args.command == "optimize":
        output_file(args.out or default_out(args.part), "--out")
    elif args.command == "simulate":
        output_file(args.out, "--out")
        from contour_gym.render import CONTOUR_INCHES, PART_HEIGHT  # matplotlib: when needed

        # before the run: the plot simulate draws is at least this size
        check_plot(CONTOUR_INCHES if args.gcode is None else (PART_HEIGHT,) * 2, args.dpi)
    elif args.out is not None:
        output_folder(args.out, "--out")


def _show_warning(message: Warning | str, *_: object, **__: object) -> None:
    """Print a warning as one line, without the source line that raised it."""
    print(f"contour-gym: warning: {message}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
