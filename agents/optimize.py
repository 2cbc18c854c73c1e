"""A part program back with new F words: the shortest cycle within a contour tolerance.

:func:`optimize_part` reads a program, maps it onto a machine (a preset or a machine file, its
axis controllers, estimator and CCC), and searches one feedrate per feed move (block) for the
shortest cycle time whose peak true contour error stays within ``tolerance``. The search is
batch-first: each round runs :data:`LEVELS` members at once, member ``k`` with every block at
the ``k``-th of :data:`LEVELS` evenly spaced feeds between the block's known-good feed (at
first its own F where the given program holds the tolerance there, else :data:`SLOWEST` of its
slowest feed) and its known-bad one (at first the largest feed); a block keeps the highest
level at which its own peak error (the ticks whose foot point is on it, as the loop's metrics
count them) held the tolerance. After :data:`ROUNDS` rounds the known-good feeds are written
into the program, read back and run; where that combination breaks the tolerance (a fast block
carrying its speed into a tight one), the blocks there and the ones before them step down
until it holds. Then a polish raises single blocks (coordinate ascent, many blocks far apart
raised in each member of a round, each raise judged by its neighbourhood's peaks and the kept
ones checked on the whole program) while the program still holds. The result is written with
:func:`contour_gym.paths.rewrite_feeds`, read back and run again (its own F words, no
override): what :class:`OptimizedPart` reports is that run.

Before the rounds, constant overrides of the program's own feeds (every :data:`OVERRIDE_STEP`)
and the curvature limit at several centripetal accelerations and caps run, each written as F
words; the fastest that holds the tolerance everywhere is where every block's known-good feed
starts (so the result is never slower than the best of those). ``method="bisection"`` halves
each block's bracket instead, one member a round (:data:`METHODS`).

Only the feed moves the machine runs get new feeds: a Z-only plunge on an X-Y machine (a wait
timed by its own feed) keeps its F, the tool's plunge feed.

Where one block needs two speeds (a long line into a sharp turn): the straight feed moves
longer than a stop from the largest feed (:func:`_split_lines`) are split in two near their
middle (:func:`contour_gym.paths.split_moves`: on the move and on the program's grid), the
split program is searched the same way, and it is kept where it is faster, the moves whose
halves came out at one feed joined again (``split=False``: only F words change).

With ``robust=N`` every candidate runs on the machine and on N machines drawn around it
(:func:`random_machines`, the envs' domain randomisation) as members of the same loop, and a
block's peak is its worst over them plus :data:`SPREAD` standard deviations: the program then
holds on machines the model only approximates. Every whole program run as written (the repair,
the polish's checks, the result) also runs on :data:`AUDIT` times N machines more, drawn after
them: where one of those breaks the tolerance, its run is recorded and its per-block peaks
count too (the search's N machines alone leave many blocks at the edge of their sample at
once, which a fresh machine breaks more often). :func:`peaks_on_machines` checks a program on
others.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym.api import Scenario, make_scenario
from contour_gym.envs.config import DEFAULT_RANDOMIZATION, draw_plant_scaling
from contour_gym.loop import ServoLoop
from contour_gym.motion import segment_max_curvature
from contour_gym.params import choice, seed_value
from contour_gym.paths import (
    LINE,
    GcodePath,
    feed_grid,
    feed_moves,
    from_gcode,
    rewrite_feeds,
    split_moves,
)
from contour_gym.presets import resolve_preset

Array = NDArray[np.float64]
LEVELS = 8  # members per round: feeds tried per block at once
ROUNDS = 4  # rounds of the search (the bracket narrows LEVELS + 1 times a round)
# the searches: (fractions of each block's bracket tried at once, rounds)
METHODS: dict[str, tuple[tuple[float, ...], int]] = {
    "levels": (tuple(k / LEVELS for k in range(1, LEVELS + 1)), ROUNDS),  # the default
    "bisection": ((0.5,), 12),  # one member a round: the bracket halves 12 times
}
REPAIRS = 12  # rounds of stepping violating blocks down before giving up
STEP_DOWN = 0.85  # a violating block's feed is multiplied by this per repair round
SLOWEST = 0.25  # the slowest feed tried, as a fraction of the program's slowest feed
OVERRIDE_STEP = 0.05  # constant overrides tried for the start, this far apart
MAX_OVERRIDES = 200  # ... or this many, evenly, up to the one that makes every feed the largest
CURVATURE_ACCELS = (0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)  # start a_c, m/s^2
CURVATURE_CAPS = (0.25, 0.5, 0.75, 1.0)  # ... and its caps, of the largest feed
MEMBERS = 64  # members of one loop at most (each recorded whole: the memory it takes)
POLISH = (2.0, 1.5, 1.25, 1.1)  # the factors single blocks are raised by, in turn
POLISH_BLOCKS = 200  # programs of more feed moves skip the polish: its rounds run the whole
# program once per member, recorded (a 1000-block part would pass the 2-minute budget)
GROUPS = 8  # members of a polish round: block j is raised in member j % GROUPS
REACH = 2  # blocks either side of a raised one whose peaks judge the raise
SPREAD = 1.0  # robust: a block's peak counts as its worst over the machines plus this many
# standard deviations of its peaks over them (a program at the edge on every block of N drawn
# machines breaks on a fresh one as often as one block of many is past the sample's worst)
AUDIT = 7  # robust N: whole programs also run on AUDIT * N machines more (their own peaks):
# a program at the edge of M machines breaks on about one fresh machine in M + 1 per block at
# that edge; 15 of 16 fresh machines held 19 times in 20 asks for under 2.3 % (M = 8 N: 128)
VERIFY = 3  # runs of the whole program a polish round may take to find its raises hold


@dataclass(frozen=True)
class OptimizedPart:
    """A program with new F words, and what its run on the machine gave.

    Attributes:
        text: The new program (only F words differ from the one given, and the moves split
            in two: :attr:`source_lines`).
        feeds: Feed move line -> its new feedrate, m/s (as written: the program's decimals).
        before: The given program's run: ``cycle_time`` (s), ``max_contour_error`` (m).
        after: The new program's run, read back from ``text``, the same keys (and with
            ``robust`` machines ``worst_machine_error``, m: the largest peak over them and
            the :data:`AUDIT` machines).
        block_peak: Feed move line -> the peak true contour error of the new run there, m
            (ticks whose foot and reference are on that block; at a stop a tick may count
            for two blocks, so their largest is at least the run's ``max_contour_error``;
            with ``robust`` machines, the worst over them plus :data:`SPREAD` standard
            deviations, or an audit machine's peak where it is larger).
        too_tight: Lines of ``text`` the tolerance cannot be held on even at the slowest feed.
        source_lines: Line of ``text`` -> the line of the given program it comes from (a
            move split in two: both its lines; :func:`~contour_gym.paths.split_moves`).
    """

    text: str
    feeds: dict[int, float]
    before: dict[str, float]
    after: dict[str, float]
    block_peak: dict[int, float]
    too_tight: tuple[int, ...]
    source_lines: dict[int, int] = field(default_factory=dict)


def optimize_part(
    text: str, plant: Any, tolerance: float, *, max_feed: float | None = None,
    best_effort: bool = False, ccc_gains: Any = "machine", robust: int = 0, seed: int = 0,
    method: str = "levels", split: bool = True, **read: Any,
) -> OptimizedPart:
    """New F words for ``text`` on ``plant``: the shortest cycle within ``tolerance``.

    Args:
        text: The part program.
        plant: The machine (a preset name, machine file or plant dict).
        tolerance: The largest true contour error allowed anywhere, m (> 0).
        max_feed: The largest feed to write, m/s (None: the machine's ``max_feedrate``).
        best_effort: Where the tolerance cannot be held even at the slowest feed, run those
            blocks at it and say so (else refuse).
        ccc_gains: The CCC ("machine": the machine's own PID CCC gains; None: no CCC).
        robust: Keep the tolerance on this many machines drawn besides (the env's domain
            randomisation, :func:`random_machines`), not on the machine alone: each block's
            worst peak over them plus :data:`SPREAD` standard deviations of its peaks, and
            every whole program also within it on :data:`AUDIT` times as many more.
        seed: Seed of those machines' draw.
        method: The search (:data:`METHODS`): ``"levels"`` (default: :data:`LEVELS` feeds
            per block at once, :data:`ROUNDS` rounds) or ``"bisection"`` (one, 12 rounds).
        split: Also search the program with its long straight moves split in two
            (:func:`_split_lines`) and keep it where it is faster (its halves of one feed
            joined again).
        **read: :func:`~contour_gym.paths.from_gcode`'s options for this program.

    Returns:
        The :class:`OptimizedPart`.

    Raises:
        ValueError: for a bad tolerance or feed, or (without ``best_effort``) blocks whose
            tolerance no feed holds, naming their lines.
    """
    if not (math.isfinite(tolerance) and tolerance > 0.0):
        raise ValueError(f"tolerance must be positive and finite, got {tolerance!r}")
    choice(method, "method", tuple(METHODS))
    drawn = random_machines(plant, robust * (1 + AUDIT), seed)
    machines, audit = drawn[:robust], drawn[robust:]

    def make(program: str) -> _Search:
        return _Search(program, plant, tolerance, max_feed, ccc_gains, read, machines, audit)

    search = make(text)
    final = _searched(search, method)
    halves = _split_lines(search) if split else []
    if halves:
        final = _with_splits(final, text, halves, make, method, read)
    if final.too_tight and not best_effort:
        where = (f" on {robust} machines more (worst + {SPREAD:g} sd) and {len(audit)} checks"
                 if robust else "")
        given = sorted({final.source_lines.get(line, line) for line in final.too_tight})
        raise ValueError(f"the tolerance of {tolerance * 1e6:g} um cannot be held{where} at the "
                         f"slowest feed ({search.slowest * 6e4:.4g} mm/min) on G-code lines "
                         f"{', '.join(map(str, given))}; give --best-effort to run them there "
                         "anyway")
    return final


def _searched(search: _Search, method: str) -> OptimizedPart:
    """The search's result: the start, ``method``'s rounds, the repair and the polish."""
    start = search.best_start()  # the whole program holds at these feeds (or all 0)
    return search.polished(search.repair(search.run(start, method), start))


def _split_lines(search: _Search) -> list[int]:
    """The straight feed moves worth two feeds: longer than a stop from the largest feed.

    That distance is ``F^2 / (2 a)``, ``a`` the look-ahead's acceleration at the largest feed
    ``F`` (under a time constant ``F T / 2``): a shorter move has no room for two speeds. The
    longest first, while the program stays within :data:`POLISH_BLOCKS` feed moves.
    """
    room = POLISH_BLOCKS - len(search.lines)
    top = search.fastest
    accel = float(search.scenario.interpolator().planning_accels(
        np.array([top]), np.array([False]))[0])
    if room <= 0 or not math.isfinite(accel):
        return []
    path = search.path
    lengths = np.diff(path.table.s0)
    segments: dict[int, list[int]] = {}
    for j, line in enumerate(np.asarray(path.segment_lines).tolist()):
        segments.setdefault(int(line), []).append(j)
    long = [(float(lengths[js[0]]), line) for line, js in segments.items()
            if line in search.lines and len(js) == 1
            and int(path.table.kind[js[0]]) == LINE and lengths[js[0]] > top**2 / (2 * accel)]
    return [line for _, line in sorted(long, reverse=True)[:room]]


def _with_splits(final: OptimizedPart, text: str, halves: list[int],
                 make: Callable[[str], _Search], method: str, read: Mapping[str, Any]
                 ) -> OptimizedPart:
    """``final``, or the program with ``halves`` split searched, where that is faster.

    Moves whose two halves got one feed are joined again: the program is split again with
    only the others, and written and run with the feeds found.
    """
    work, origin = split_moves(text, halves, **read)
    if work == text:
        return final
    split = _searched(make(work), method)
    if (len(split.too_tight), split.after["cycle_time"]) >= (
            len(final.too_tight), final.after["cycle_time"] * (1.0 - 1e-3)):
        return final
    first = _first_halves(origin)
    kept = [origin[j - 1] for j in sorted(first) if split.feeds.get(j) != split.feeds.get(j + 1)]
    found = {(origin[j - 1], j in first): rate for j, rate in split.feeds.items()}
    joined, joined_origin = split_moves(text, kept, **read)
    search, halves_now = make(joined), _first_halves(joined_origin)
    part = search.written(np.array([found[(joined_origin[line - 1], line in halves_now)]
                                    for line in search.lines]))
    if part.too_tight and not split.too_tight:
        part, joined_origin = split, origin
    return replace(part, before=final.before,
                   source_lines={k + 1: line for k, line in enumerate(joined_origin)})


def _first_halves(origin: list[int]) -> set[int]:
    """Lines (1-based) that are the first half of a split move: their next has their origin."""
    return {j + 1 for j in range(len(origin) - 1) if origin[j] == origin[j + 1]}


def random_machines(plant: Any, n: int, seed: int) -> list[dict[str, Array]]:
    """``n`` machines around ``plant`` drawn as the envs' domain randomisation draws them.

    Each is the factors of :meth:`~contour_gym.loop.ServoLoop.set_plant_scaling`
    (:data:`~contour_gym.envs.config.DEFAULT_RANDOMIZATION`: mass, damping and force
    constant within 10 %, friction 0.5-1.5 times, disturbance 0-2 times).
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise ValueError(f"robust must be a whole number of machines >= 0, got {n!r}")
    rng = np.random.default_rng(seed_value(seed))
    axes = resolve_preset(plant).stage.n_axes
    return [draw_plant_scaling(DEFAULT_RANDOMIZATION, axes, rng) for _ in range(n)]


def peaks_on_machines(text: str, plant: Any, machines: list[dict[str, Array]],
                      ccc_gains: Any = "machine", **read: Any) -> Array:
    """The peak true contour error of ``text`` run as written on each of ``machines``, m.

    ``inf`` where a machine did not finish. The check of a program optimised with
    ``robust`` on machines it was not tuned on (a fresh :func:`random_machines` draw).
    """
    scenario = make_scenario(plant, from_gcode(text, **read))
    return _machine_peaks(scenario, scenario.path, machines,  # type: ignore[arg-type]
                          ccc_gains_of(plant, ccc_gains))


def _machine_peaks(scenario: Scenario, path: GcodePath, machines: list[dict[str, Array]],
                   gains: Any) -> Array:
    """``path``'s peak true contour error on each of ``machines`` (unrecorded), m.

    ``inf`` where one did not finish (member 0, the scenario's own machine, left out).
    """
    loop = machine_loop(scenario, [path], machines, gains, record=False)
    error = np.asarray(loop.run()["max_contour_error"], dtype=float)
    return np.where(np.asarray(loop.done, dtype=bool), error, math.inf)[1:]


def counted_ticks(path: GcodePath, trace: Any, b: int, contour: Any) -> tuple[Array, Any]:
    """Member ``b``'s recorded |contour error| per tick and the cutting segment it counts for.

    A tick counts as the loop's metrics count it: its machine's foot point and its reference
    on cutting segments (a segment ending where the foot stands is its own: a rapid's
    arrival cuts nothing); the segment is the foot's, -1 for a tick that does not count.
    """
    rows = np.isfinite(trace.s[b]) & np.all(np.isfinite(trace.x[b]), axis=1)
    offset = np.asarray(contour.offset or np.zeros(len(contour.axes)))
    foot, _ = path.track(trace.x[b][rows][:, list(contour.axes)] - offset, trace.s[b][rows])
    cutting = np.asarray(path.cutting)
    seg, ref = _segment(path, foot), _segment(path, trace.s[b][rows])
    seg = np.where(cutting[seg] & cutting[ref], seg, -1)
    return np.abs(trace.eps[b][rows]).max(axis=1), seg


def _segment(path: GcodePath, s: Array) -> NDArray[np.intp]:
    """The segment an arc length lies on; at a segment's start, the one ending there."""
    seg = np.searchsorted(path.table.s0, s, side="left") - 1
    return np.clip(seg, 0, path.table.n_segments - 1)


def _worst(peaks: Any) -> Any:
    """Peaks over machines (axis 0) as the search counts them.

    The worst plus :data:`SPREAD` standard deviations; the one machine's own where there is one.
    """
    peaks = np.asarray(peaks, dtype=float)
    if len(peaks) == 1:
        return peaks[0]
    return peaks.max(axis=0) + SPREAD * peaks.std(axis=0)


def _dilated(mask: NDArray[np.bool_], reach: int) -> NDArray[np.bool_]:
    """``mask`` with the ``reach`` entries either side of each true one set (same length)."""
    out = mask.copy()
    for k in range(1, reach + 1):
        out[k:] |= mask[:-k]
        out[:-k] |= mask[k:]
    return out


def ccc_gains_of(plant: Any, ccc_gains: Any) -> Any:
    """The CCC gains ``ccc_gains`` names: "machine" for the machine's own, else as given."""
    return resolve_preset(plant).ccc_gains if ccc_gains == "machine" else ccc_gains


def machine_loop(scenario: Scenario, paths: list[GcodePath], machines: list[dict[str, Array]],
                  gains: Any, record: bool) -> ServoLoop:
    """A reset loop running each program on the scenario's machine and each of ``machines``.

    ``machines`` are scale factors; member ``m * len(paths) + b`` runs program ``b`` on
    machine ``m``, machine 0 the scenario's own.
    """
    n = len(paths)
    loop: ServoLoop = scenario.loop(batch_size=n * (1 + len(machines)), ccc_gains=gains,
                                    record=record)
    loop.set_paths(paths * (1 + len(machines)))
    for k, factors in enumerate(machines, start=1):
        loop.set_plant_scaling(np.arange(k * n, (k + 1) * n), **factors)
    loop.reset(0)
    return loop


class _Search:
    """One program on one machine: its blocks, runs of many feed sets at once, the search."""

    def __init__(self, text: str, plant: Any, tolerance: float, max_feed: float | None,
                 ccc_gains: Any, read: Mapping[str, Any], machines: list[dict[str, Array]],
                 audit: list[dict[str, Array]] | None = None) -> None:
        self.tolerance = tolerance
        self.machines = machines
        self.audit = audit or []  # machines whole programs are checked on besides
        self.plant = plant
        self.text = text
        self.read = dict(read)
        preset = resolve_preset(plant)
        top = preset.max_feedrate if max_feed is None else max_feed
        if not (math.isfinite(top) and top > 0.0):
            whose = "the machine's largest feed" if max_feed is None else "max_feed"
            raise ValueError(f"{whose} must be finite and > 0 m/s to optimise against, got "
                             f"{top!r}" + (": give max_feed" if max_feed is None else ""))
        self.fastest = top
        given = self.source = from_gcode(text, **read)
        if not np.any(given.cutting):
            raise ValueError("the program cuts nothing (every move is a rapid, or above the "
                             "cut depth): no feed to optimise")
        # a quarter of the program's slowest feed: slower, the part takes hours and its
        # record gigabytes; a tolerance that needs it is too tight for this machine
        self.slowest = min(SLOWEST * min(feed_moves(given).values()), top)
        self.scenario: Scenario = make_scenario(plant, given)  # maps programs onto the machine
        self.gains = ccc_gains_of(preset, ccc_gains)
        self.path: GcodePath = self.scenario.path  # type: ignore[assignment]
        feed = ~np.asarray(self.path.rapid)
        lines = np.asarray(self.path.segment_lines)
        self.lines = list(dict.fromkeys(int(x) for x in lines[feed]))
        self.block_of = np.array([self.lines.index(int(x)) if f else -1
                                  for x, f in zip(lines, feed, strict=True)])
        results, peaks = self.run_as_written(given)
        self.before, self.given_peaks = results, peaks
        own = feed_moves(given)
        self.given_feeds = np.array([own[line] for line in self.lines])
        units, decimals = feed_grid(text)  # candidates run as they will be written
        self.grid = 60.0 / np.array([units[line - 1] for line in self.lines]) * 10.0**decimals
        # candidates are made on the program as read and mapped onto the machine each time: a
        # 3-D program's Z-only moves become waits on an X-Y machine, timed by their own feeds
        index = {line: i for i, line in enumerate(self.lines)}
        self.source_block = np.array([index.get(int(line), -1) if not rapid else -1 for line, rapid
                                      in zip(given.segment_lines, given.rapid, strict=True)])

    def run_as_written(self, program: GcodePath) -> tuple[dict[str, float], Array]:
        """Run a program as ``contour-gym simulate`` runs it: its metrics and per-block peaks.

        Its own scenario, as the command builds it from the program alone; checked on the
        audit machines too (:meth:`checked`).
        """
        scenario = make_scenario(self.plant, program)
        return self.checked(scenario.path, scenario)  # type: ignore[arg-type]

    def checked(self, path: GcodePath, scenario: Scenario | None = None
                ) -> tuple[dict[str, float], Array]:
        """One whole program's metrics and per-block peaks, on the audit machines as well.

        The peaks are the search's (:meth:`simulate`); the program also runs unrecorded on
        each audit machine, and the ones where it breaks the tolerance (or does not finish)
        run again recorded: each block's peak is the larger of the two.
        """
        own = scenario or make_scenario(self.scenario.preset, path)
        results, peaks = self.simulate([path], own)
        result, peak = results[0], peaks[0]
        if not self.audit:
            return result, peak
        error = _machine_peaks(own, path, self.audit, self.gains)
        result["worst_machine_error"] = max(
            result.get("worst_machine_error", result["max_contour_error"]), float(error.max()))
        broke = [m for m, e in zip(self.audit, error, strict=True) if not e <= self.tolerance]
        if broke:
            _, found = self._run_halving([path], own, broke, spread=False)
            peak = np.maximum(peak, found[0])
        return result, peak

    def with_blocks(self, feeds: Array) -> GcodePath:
        """The program with block ``i`` at ``feeds[i]`` (m/s), mapped onto the machine.

        Each feed as it will be written: rounded down to the program's decimals in its unit
        per minute (:func:`~contour_gym.paths.feed_grid`), never past the largest feed.
        """
        feeds = np.floor(np.minimum(feeds, self.fastest) * self.grid * (1.0 + 1e-12)) / self.grid
        block = self.source_block
        own = np.asarray(self.source.segment_feedrates)
        variant = self.source.with_feedrates(
            np.where(block >= 0, feeds[np.maximum(block, 0)], own))
        return make_scenario(self.scenario.preset, variant).path  # type: ignore[return-value]

    def simulate(self, paths: list[GcodePath], scenario: Scenario | None = None
                 ) -> tuple[list[dict[str, float]], Array]:
        """Run each program once: its metrics and ``(members, blocks)`` peak |contour error|.

        The programs run as members of loops, each as ``contour-gym simulate`` runs it (a
        member's plan follows its own F words, whatever the loop's nominal feed), on the
        machine and the search's machines (:func:`_worst` of their peaks).
        """
        own = scenario or make_scenario(self.scenario.preset, paths[0])
        per = max(1, MEMBERS // (1 + len(self.machines)))  # programs per loop
        out: list[dict[str, float]] = []
        peaks = []
        for first in range(0, len(paths), per):
            results, found = self._run_halving(paths[first:first + per], own, self.machines)
            out += results
            peaks.append(found)
        return out, np.concatenate(peaks)

    def _run_halving(self, paths: list[GcodePath], scenario: Scenario,
                     machines: list[dict[str, Array]], spread: bool = True
                     ) -> tuple[list[dict[str, float]], Array]:
        """:meth:`_run_members`, in halves where the record of all at once is too large.

        Halves of the programs, or of the machines for a single program (its peaks then the
        larger of the halves', which only ``spread=False`` allows).
        """
        try:
            return self._run_members(paths, scenario, machines, spread)
        except ValueError as exc:  # the loop's record memory check (slow candidates)
            if "recording it needs" not in str(exc) or (
                    len(paths) == 1 and (spread or len(machines) <= 1)):
                raise
        if len(paths) == 1:
            half = len(machines) // 2
            parts = [self._run_halving(paths, scenario, part, spread)
                     for part in (machines[:half], machines[half:])]
            return parts[0][0], np.maximum(parts[0][1], parts[1][1])
        half = len(paths) // 2
        first, second = (self._run_halving(part, scenario, machines, spread)
                         for part in (paths[:half], paths[half:]))
        return first[0] + second[0], np.concatenate([first[1], second[1]])

    def _run_members(self, paths: list[GcodePath], scenario: Scenario,
                     machines: list[dict[str, Array]], spread: bool
                     ) -> tuple[list[dict[str, float]], Array]:
        """The programs' metrics on the machine and their per-block peaks on all machines.

        A block's peak over the machines is :func:`_worst` of them (``spread``) or their
        largest.
        """
        loop = machine_loop(scenario, paths, machines, self.gains, record=True)
        metrics = loop.run()
        trace = loop.trace()
        m, n = 1 + len(machines), len(paths)
        peaks = np.stack([self._block_peaks(paths[b % n], trace, b) for b in range(m * n)])
        peaks = peaks.reshape(m, n, -1)
        peaks = _worst(peaks) if spread else peaks.max(axis=0)
        done = np.asarray(loop.done, dtype=bool).reshape(m, n)
        failed = np.logical_not(np.all(done, axis=0))
        worst = np.asarray(metrics["max_contour_error"]).reshape(m, n).max(axis=0)
        out = [{"cycle_time": float(metrics["cycle_time"][b]) if not failed[b] else math.inf,
                "max_contour_error": float(metrics["max_contour_error"][b]),
                **({"worst_machine_error": float(worst[b])} if machines else {})}
               for b in range(n)]
        peaks[failed] = math.inf
        return out, peaks

    def _block_peaks(self, path: GcodePath, trace: Any, b: int) -> Array:
        """Member ``b``'s peak |contour error| per block (``len(self.lines)``)."""
        error, seg = counted_ticks(path, trace, b, self.scenario.preset.stage.contours[0])
        on = seg >= 0
        peaks = np.zeros(len(self.lines))
        np.maximum.at(peaks, self.block_of[seg[on]], error[on])
        return peaks

    def run(self, start: Array, method: str = "levels") -> Array:
        """The known-good feed of every block after ``method``'s rounds, from ``start``."""
        n = len(self.lines)
        # known good to start from: the program's own feeds where its own run holds there, or
        # the best start (:meth:`best_start`), which holds everywhere
        low = np.where(self.given_peaks <= self.tolerance,
                       np.minimum(self.given_feeds, self.fastest), self.slowest)
        low = np.maximum(low, start)
        high = np.full(n, self.fastest)
        fractions, rounds = METHODS[method]
        levels, last = np.asarray(fractions), len(fractions)
        for _ in range(rounds):
            feeds = np.minimum(low + levels[:, None] * (high - low), high)  # (levels, blocks)
            _, peaks = self.simulate([self.with_blocks(f) for f in feeds])
            # a block judged by its own peak: its effect on the block after it is the
            # repair's (with every block at one level, a tight block would hold back the one
            # before it)
            ok = peaks <= self.tolerance
            # the highest level that held (the error is not monotonic in the feed: at a few
            # um the encoder's steps and the CCC make it rise and fall)
            held = ok.any(axis=0)
            top = np.where(held, last - np.argmax(ok[::-1], axis=0), 0)
            fails = top < last
            new_low = np.where(top > 0, feeds[np.maximum(top - 1, 0), np.arange(n)], low)
            high = np.where(fails, feeds[np.minimum(top, last - 1), np.arange(n)], high)
            low = new_low
        return low

    def best_start(self) -> Array:
        """Every block's feed in the fastest start candidate holding the tolerance (or 0).

        The candidates: constant overrides of the program's own feeds, :data:`OVERRIDE_STEP`
        apart (at most :data:`MAX_OVERRIDES` of them) up to the one that puts every block at
        the largest feed; and the curvature limit written as F words, every block at
        ``min(cap * largest, sqrt(a_c / kappa))`` (``kappa`` its largest curvature) for each
        ``a_c`` of :data:`CURVATURE_ACCELS` and ``cap`` of :data:`CURVATURE_CAPS`. Each runs as
        written, keeping only its peak (no record: little memory), in a loop of its own
        highest feed.
        """
        ceiling = self.fastest / float(self.given_feeds.min())
        step = max(OVERRIDE_STEP, ceiling / MAX_OVERRIDES)
        scales = np.arange(1, math.floor(ceiling / step) + 1) * step
        overrides = np.minimum(scales[:, None] * self.given_feeds, self.fastest)
        best, quickest = np.zeros(len(self.lines)), math.inf
        for row in np.vstack([overrides, self._curvature_limits()]):
            path = self.with_blocks(row)
            loop = machine_loop(make_scenario(self.scenario.preset, path), [path], self.machines,
                                 self.gains, record=False)
            metrics = loop.run()
            held = _worst(metrics["max_contour_error"]) <= self.tolerance and loop.done.all()
            if held and metrics["cycle_time"][0] < quickest:
                best, quickest = row, float(metrics["cycle_time"][0])
        return best

    def _curvature_limits(self) -> Array:
        """The curvature limit's feeds per block, one row per (a_c, cap) of the grids."""
        kappa = np.zeros(len(self.lines))
        on = self.block_of >= 0
        np.maximum.at(kappa, self.block_of[on], segment_max_curvature(self.path)[on])
        rows = [np.minimum(cap * self.fastest, np.sqrt(a_c / np.maximum(kappa, 1e-300)))
                for a_c in CURVATURE_ACCELS for cap in CURVATURE_CAPS]
        return np.maximum(np.array(rows), self.slowest)

    def repair(self, feeds: Array, start: Array) -> OptimizedPart:
        """Write ``feeds`` into the program and run it as written, until it holds.

        The blocks that break the tolerance (and the one before each) step down, first to
        ``start`` (the best start that held, :meth:`best_start`), then to the slowest feed, until
        the whole part holds. ``start`` as written is the result where it holds and is
        faster, or where the repair did not make the part hold in :data:`REPAIRS` rounds;
        else the blocks that still break it run at the slowest feed and are ``too_tight``.
        """
        feeds, floor = feeds.copy(), np.maximum(start, self.slowest)
        for _ in range(REPAIRS):
            part = self.written(feeds)
            bad = np.isin(self.lines, part.too_tight)
            if not bad.any():
                break
            if np.all(feeds <= floor):  # every block at the start: down to the slowest
                if np.all(floor <= self.slowest):
                    break
                floor = np.full_like(floor, self.slowest)
            step = bad | np.r_[bad[1:], False]
            if np.all(feeds[step] <= floor[step]):  # at the floor there: its neighbours too
                step = _dilated(step, 1)
            feeds[step] = np.maximum(feeds[step] * STEP_DOWN, floor[step])
        if np.all(start > 0.0):  # the start as written, where it is the better
            first = self.written(start)
            if not first.too_tight and (part.too_tight or first.after["cycle_time"]
                                        < part.after["cycle_time"]):
                return first
        bad = np.isin(self.lines, part.too_tight)
        if np.any(feeds[bad] > self.slowest):  # what still breaks it: at the slowest feed
            feeds[bad] = self.slowest
            part = self.written(feeds)
        return part

    def polished(self, part: OptimizedPart) -> OptimizedPart:
        """``part`` with single blocks raised while the whole program holds (when faster).

        Coordinate ascent, batch-first: for each factor of :data:`POLISH`, member ``g`` of a
        round raises every block ``j`` with ``j % GROUPS == g`` (blocks far enough apart that
        their neighbourhoods do not meet); a raise is kept where the peaks of the block and
        :data:`REACH` blocks either side held, and the kept raises together are checked on
        the whole program (:meth:`_held`). Rounds repeat while they raise something. A
        program of more than :data:`POLISH_BLOCKS` feed moves is returned as it is.
        """
        if part.too_tight or len(self.lines) > POLISH_BLOCKS:
            return part
        feeds = np.array([part.feeds[line] for line in self.lines])
        for factor in POLISH:
            while True:
                kept = self._raise_round(feeds, factor)
                if np.array_equal(kept, feeds):
                    break
                feeds = kept
        final = self.written(feeds)
        faster = final.after["cycle_time"] < part.after["cycle_time"]
        return final if faster and not final.too_tight else part

    def _raise_round(self, feeds: Array, factor: float) -> Array:
        """One polish round: every block that can be raised by ``factor``, tried and kept."""
        n = len(feeds)
        raised = np.minimum(feeds * factor, self.fastest)
        can = raised > feeds * (1.0 + 1e-9)
        group = np.arange(n) % min(n, GROUPS)
        groups = [g for g in range(min(n, GROUPS)) if np.any(can & (group == g))]
        if not groups:
            return feeds
        trials = [np.where(can & (group == g), raised, feeds) for g in groups]
        _, peaks = self.simulate([self.with_blocks(f) for f in trials])
        member = {g: k for k, g in enumerate(groups)}
        near = np.array([can[j] and bool(np.all(
            peaks[member[group[j]], max(0, j - REACH):j + REACH + 1] <= self.tolerance))
            for j in range(n)])
        return self._held(np.where(near, raised, feeds), feeds)

    def _held(self, feeds: Array, base: Array) -> Array:
        """``feeds`` less the raises over ``base`` near where the whole program breaks.

        Up to :data:`VERIFY` runs; ``base`` if the raises still break it then.
        """
        for _ in range(VERIFY):
            if np.array_equal(feeds, base):
                return base
            _, peaks = self.checked(self.with_blocks(feeds))
            bad = peaks > self.tolerance
            if not bad.any():
                return feeds
            near = _dilated(bad, REACH)
            feeds = np.where(near, base, feeds)
        return base

    def written(self, feeds: Array) -> OptimizedPart:
        """``feeds`` written into the program, read back and run as written."""
        text = rewrite_feeds(self.text, dict(zip(self.lines, feeds.tolist(), strict=True)),
                             ceiling=self.fastest, down=True, **self.read)
        final = from_gcode(text, **self.read)
        after, peaks = self.run_as_written(final)
        return OptimizedPart(
            text=text, feeds=feed_moves(final), before=self.before, after=after,
            block_peak=dict(zip(self.lines, peaks.tolist(), strict=True)),
            too_tight=tuple(self.lines[i] for i in np.flatnonzero(peaks > self.tolerance)))


__all__ = ["AUDIT", "LEVELS", "METHODS", "OVERRIDE_STEP", "ROUNDS", "SPREAD", "OptimizedPart",
           "ccc_gains_of", "counted_ticks", "machine_loop", "optimize_part", "peaks_on_machines",
           "random_machines"]
