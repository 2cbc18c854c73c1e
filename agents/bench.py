"""The evaluation harness: every policy of a suite on every scenario, as the papers tabulate.

``contour-gym bench [--suite NAME_OR_PATH] [--out DIR]`` (or :func:`run_suite`) reads a suite,
runs each *cell* (a scenario x a policy, all the scenario's seeds as members of one native
vector env), and writes into the run folder a Markdown and a CSV table and, per scenario, the
plots a reader of the papers expects.

The suites and what runs where are :mod:`agents.suites`'s.

**The tables** (``results.md``, ``results.csv``), one row per cell, values the mean over the
scenario's seeds: max, mean and RMS contour error (um, over the cut), the largest axis's max
tracking error (um), cycle time (s; ``inf`` if an episode never got in position), chattering
(total variation of the saturated control command summed over axes, in the machine's control
unit), failures (episodes that did not finish: failed by the env's rule or truncated before
getting in position) and each policy's change of the max contour error (and, for feedrate
scenarios, of the cycle time) against the scenario's baseline, %. The Markdown also lists the
scenarios (env id, settings, seeds).

**The plots** (``plots/``, per scenario, one seed per policy: the scenario's first): the path
and each policy's contour with the error magnified (``magnify``, default the 1-2-5 step that
draws the largest error at 5 % of the path's extent) beside |contour error| against time
(:func:`contour_gym.render.contour_figure`; contour 0 of a two-contour machine), and for
feedrate scenarios the feedrate against path length (:func:`contour_gym.render.feedrate_figure`).

**The run folder** (``--out DIR``; default ``runs/bench/<suite>-<hash>``) holds ``suite.json``
(the suite's name, source, content hash and code digest), ``suite.yaml`` (a copy), one
``cells/<scenario>/<policy>.json`` per finished cell (its episodes' metrics, each with its
seed) and ``.npz`` (the plotted seed's per-tick trace), written at once and atomically (temp
file, then rename), the plots and the tables. A run that stops (Ctrl-C, a crash) resumes
where it stopped when run again with the same folder: finished cells are read back, never
recomputed. The content hash (of the parsed YAML: comments and layout do not count) guards the
folder, with a digest of the code (:func:`agents.suites.code_digest`: every file of
``contour_gym`` and ``agents``): a folder holding a run of a different suite, or one computed by
other code (another version, a changed policy), raises ValueError (pass a new ``--out`` or
delete the folder); the default folder is named by both, so an edited suite or an upgrade
starts a new one.

A bad suite or a run folder of another suite raises ValueError before any cell runs.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
import sys
import tempfile
import time
import warnings
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from operator import methodcaller
from pathlib import Path
from typing import Any

import numpy as np

from agents.bench_plots import scenario_plots
from agents.evaluate import env_arguments, make_vector_env, run_episodes
from agents.generalization import format_value, summary_rows
from agents.generalization import markdown as summary_markdown
from agents.parallel import Runner, runner
from agents.policies import Policy
from agents.suites import PolicySpec, ScenarioSpec, Suite, code_digest, load_suite
from contour_gym.envs.core import FEEDRATE
from contour_gym.files import write_atomically, write_handle_atomically, write_text
from contour_gym.loop import Trace

DEFAULT_RUNS = Path("runs") / "bench"
TRACE_FIELDS = tuple(f.name for f in fields(Trace))  # what a cell's .npz holds
UM = 1e6


# ---------------------------------------------------------------------------------- cells
@dataclass
class Cell:
    """One scenario x policy: its episodes (one per seed) and the plotted seed's trace.

    Attributes:
        scenario: The scenario's name.
        policy: The policy's label.
        episodes: Per seed (in the scenario's order): ``seed``, the episode's metrics
            (:func:`agents.evaluate.run_policy`'s keys, SI) and ``failed``, ``finished``, ...
        trace: The first seed's per-tick :class:`~contour_gym.loop.Trace` (None: not kept).
        wall_time: Seconds the cell took.
        note: Why the cell did not run (skipped), else empty.
    """

    scenario: str
    policy: str
    episodes: list[dict[str, Any]] = field(default_factory=list)
    trace: Trace | None = None
    wall_time: float = 0.0
    note: str = ""

    def mean(self, key: str) -> float:
        """The mean of ``key`` over the episodes (NaN when skipped)."""
        if not self.episodes:
            return math.nan
        return float(np.mean([float(e[key]) for e in self.episodes]))

    @property
    def failures(self) -> int:
        """Episodes that did not finish (failed by the env's rule or truncated)."""
        return sum(bool(e["failed"]) or not bool(e["finished"]) for e in self.episodes)


class EnvPool:
    """The native vector envs of one scenario, shared by the policies needing the same ones."""

    def __init__(self) -> None:
        self._envs: dict[str, Any] = {}

    def get(self, scenario: ScenarioSpec, policy: Policy, count: int, record: bool) -> Any:
        """The env of ``count`` members ``policy`` runs in (built on first use).

        Raises:
            ValueError: see :func:`agents.evaluate.env_arguments`.
        """
        env_id, kwargs = env_arguments(scenario.env_spec(), policy, {})
        key = json.dumps([env_id, kwargs, count, record], sort_keys=True, default=repr)
        if key not in self._envs:
            self._envs[key] = make_vector_env(env_id, policy, num_envs=count, record=record,
                                              **scenario.kwargs)
        return self._envs[key]

    def any_env(self) -> Any | None:
        """One of the envs built so far (None if none)."""
        return next(iter(self._envs.values()), None)

    def close(self) -> None:
        """Close every env."""
        for env in self._envs.values():
            env.close()
        self._envs.clear()


def evaluate_cell(scenario: ScenarioSpec, spec: PolicySpec, envs: EnvPool) -> Cell:
    """Run a policy on a scenario: one episode per seed, the first seed's trace kept.

    Each run of consecutive seeds is one native vector env (member i seeded ``first + i``,
    :func:`agents.evaluate.run_episodes`), taken from ``envs`` (shared with the scenario's
    other policies that need the same env arguments).

    Raises:
        ValueError: whatever building the policy or its env raises.
    """
    start = time.perf_counter()
    policy = spec.build()
    cell = Cell(scenario.name, spec.label)
    for i, (first, count) in enumerate(scenario.seed_blocks()):
        venv = envs.get(scenario, policy, count, record=i == 0)
        out, trace = run_episodes(venv, policy, seed=first, trace_member=0 if i == 0 else None)
        if trace is not None:  # the cell keeps member 0's copy; the pooled env, no record
            venv.unwrapped.task.loop.clear_trace()
        cell.trace = cell.trace or trace
        for b in range(count):
            episode = {key: value[b].item() for key, value in out.items()}
            cell.episodes.append({"seed": first + b, **episode})
    cell.wall_time = time.perf_counter() - start
    return cell


# ------------------------------------------------------------------------- the run folder
class RunFolder:
    """A run's folder: the suite's identity, the cells, the plots and the tables.

    Args:
        root: The folder.
        suite: The suite it holds.

    Raises:
        ValueError: if ``root`` holds a run of a different suite (another content hash), or
            is a folder with other content than a run.
    """

    def __init__(self, root: Path, suite: Suite) -> None:
        self.root, self.suite = root, suite
        marker = root / "suite.json"
        if marker.is_file():
            held = json.loads(marker.read_text(encoding="utf-8"))
            if held.get("hash") != suite.digest:
                raise ValueError(
                    f"{root} holds a run of suite {held.get('name')!r} (hash "
                    f"{str(held.get('hash'))[:12]}), not of {suite.source} (hash "
                    f"{suite.digest[:12]}): pass another --out, or delete {root} to start over"
                )
            if held.get("code") != code_digest():
                raise ValueError(
                    f"{root} holds a run computed by other contour-gym code (code digest "
                    f"{str(held.get('code'))[:12]}, this code's {code_digest()[:12]}): its "
                    f"cells would mix with this code's; pass another --out, or delete {root} "
                    "to start over"
                )
        elif root.exists() and any(root.iterdir()):
            raise ValueError(f"{root} is not empty and holds no bench run (no suite.json): "
                             "pass another --out")

    def start(self) -> None:
        """Write the suite's identity and a copy of its file (those missing)."""
        self.root.mkdir(parents=True, exist_ok=True)
        if not (self.root / "suite.json").is_file():
            identity = {"name": self.suite.name, "source": str(self.suite.source),
                        "hash": self.suite.digest, "code": code_digest()}
            write_text(self.root / "suite.json", json.dumps(identity, indent=1) + "\n")
        if not (self.root / "suite.yaml").is_file():
            write_text(self.root / "suite.yaml", self.suite.text)

    def cell_file(self, scenario: str, policy: str, suffix: str = ".json") -> Path:
        """Where a cell's record (``.json``) or trace (``.npz``) lives."""
        return self.root / "cells" / scenario / f"{policy}{suffix}"

    def done(self, scenario: str, policy: str) -> bool:
        """Whether the cell is complete: its record exists (written last) and it loads.

        A cell whose record or trace cannot be read (a truncated or foreign file) is not
        done: a warning names the file, the cell's files are removed and it is recomputed.
        """
        if not self.cell_file(scenario, policy).is_file():
            return False
        for suffix in (".json", ".npz"):
            target = self.cell_file(scenario, policy, suffix)
            try:
                self._read(target, suffix)
            except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
                warnings.warn(f"{target} cannot be read ({exc}); the cell is computed again",
                              stacklevel=2)
                for stale in (".json", ".npz"):
                    self.cell_file(scenario, policy, stale).unlink(missing_ok=True)
                return False
        return True

    @staticmethod
    def _read(target: Path, suffix: str) -> None:
        # raises if a cell file is unreadable (a missing trace is fine: not every cell has one)
        if suffix == ".json":
            record = json.loads(target.read_text(encoding="utf-8"))
            record["episodes"], record["wall_time"]  # noqa: B018 - their presence is checked
        elif target.is_file():
            with np.load(target) as data:
                for k in TRACE_FIELDS:
                    data[k]  # noqa: B018 - each array is read (a truncated zip fails here)

    def save(self, cell: Cell) -> None:
        """Write the cell's trace, then its record (each atomically)."""
        if cell.trace is not None:
            trace = cell.trace

            def write_npz(tmp: str) -> None:
                with open(tmp, "wb") as fh:
                    np.savez_compressed(fh, **{k: getattr(trace, k) for k in TRACE_FIELDS})

            write_atomically(self.cell_file(cell.scenario, cell.policy, ".npz"), write_npz)
        spec = self.suite.policies[cell.policy]
        scenario = self.suite.scenario(cell.scenario)
        record = {"scenario": cell.scenario, "policy": cell.policy, "target": spec.target,
                  "params": dict(spec.params), "env": scenario.env_spec(),
                  "suite_hash": self.suite.digest, "wall_time": cell.wall_time,
                  "episodes": cell.episodes}
        text = json.dumps(record, indent=1, default=repr)
        write_text(self.cell_file(cell.scenario, cell.policy), text)

    def load(self, scenario: str, policy: str, with_trace: bool = True) -> Cell:
        """A finished cell read back (its trace too, if asked and its file is there)."""
        record = json.loads(self.cell_file(scenario, policy).read_text(encoding="utf-8"))
        trace_file = self.cell_file(scenario, policy, ".npz")
        trace = None
        if with_trace and trace_file.is_file():
            with np.load(trace_file) as data:
                trace = Trace(**{k: data[k] for k in TRACE_FIELDS})
        return Cell(scenario, policy, record["episodes"], trace, record["wall_time"])


# --------------------------------------------------------------------------------- tables
COLUMNS: tuple[tuple[str, str], ...] = (
    ("scenario", "scenario"),
    ("policy", "policy"),
    ("seeds", "seeds"),
    ("max_contour_error_um", "max CE (um)"),
    ("mean_contour_error_um", "mean CE (um)"),
    ("rms_contour_error_um", "RMS CE (um)"),
    ("max_tracking_error_um", "max tracking error (um)"),
    ("cycle_time_s", "cycle time (s)"),
    ("chattering", "chattering (control TV)"),
    ("failures", "failures"),
    ("max_contour_error_vs_baseline_pct", "max CE vs baseline (%)"),
    ("cycle_time_vs_baseline_pct", "cycle time vs baseline (%)"),
    ("note", "note"),
)
"""(CSV name, Markdown header) of the table's columns."""

_METRICS = (  # column -> (episode metric, scale)
    ("max_contour_error_um", "max_contour_error", UM),
    ("mean_contour_error_um", "mean_contour_error", UM),
    ("rms_contour_error_um", "rms_contour_error", UM),
    ("max_tracking_error_um", "peak_tracking_error", UM),
    ("cycle_time_s", "cycle_time", 1.0),
    ("chattering", "chattering", 1.0),
)


def table_rows(suite: Suite, cells: Mapping[tuple[str, str], Cell]) -> list[dict[str, Any]]:
    """One row per scenario x policy (keys: :data:`COLUMNS`' CSV names), in suite order."""
    rows = []
    for sc in suite.scenarios:
        base = cells.get((sc.name, sc.baseline))
        for label in sc.policies:
            cell = cells[(sc.name, label)]
            row: dict[str, Any] = {"scenario": sc.name, "policy": label,
                                   "seeds": len(cell.episodes), "note": cell.note}
            for column, key, scale in _METRICS:
                row[column] = cell.mean(key) * scale
            row["failures"] = cell.failures if cell.episodes else math.nan
            row["max_contour_error_vs_baseline_pct"] = _change(cell, base, "max_contour_error")
            row["cycle_time_vs_baseline_pct"] = (
                _change(cell, base, "cycle_time") if sc.task == FEEDRATE else math.nan
            )
            if label == sc.baseline and not cell.note:
                row["note"] = "baseline"
            rows.append(row)
    return rows


def _change(cell: Cell, base: Cell | None, key: str) -> float:
    """100 (cell - base) / base of the means of ``key``; NaN without a finite baseline."""
    if base is None or not base.episodes or not cell.episodes:
        return math.nan
    b, c = base.mean(key), cell.mean(key)
    if not (math.isfinite(b) and b > 0.0):
        return math.nan
    return 100.0 * (c - b) / b


def markdown_table(suite: Suite, rows: Sequence[Mapping[str, Any]]) -> str:
    """The results as Markdown: the table, then the scenarios it ran."""
    lines = ["| " + " | ".join(h for _, h in COLUMNS) + " |",
             "|" + "---|" * len(COLUMNS)]
    for row in rows:
        cells = []
        for key, _ in COLUMNS:
            value = row[key]
            if key.endswith("_pct") and isinstance(value, float) and math.isfinite(value):
                cells.append(f"{value:+.1f}")
            else:
                cells.append(format_value(value).replace("|", "\\|"))
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", f"Suite `{suite.name}` (hash {suite.digest[:12]}); values are means over "
              "the seeds; CE = contour error.", "",
              "| scenario | env | suite settings | seeds | baseline |", "|---|---|---|---|---|"]
    for sc in suite.scenarios:
        settings = ", ".join(f"{k}={v}" for k, v in sc.kwargs.items()) or "the id's own"
        seeds = ", ".join(str(s) for s in sc.seeds)
        lines.append(f"| {sc.name} | `{sc.env_id}` | {settings} | {seeds} | {sc.baseline} |")
    return "\n".join(lines) + "\n"


def csv_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The results as CSV (full precision; empty where a value does not apply)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([key for key, _ in COLUMNS])
    for row in rows:
        writer.writerow(["" if isinstance(v, float) and math.isnan(v) else v
                         for v in (row[key] for key, _ in COLUMNS)])
    return buf.getvalue()


# ------------------------------------------------------------------------------- progress
class Progress:
    """A progress bar over the cells (tqdm if importable, else a carriage-return line)."""

    def __init__(self, total: int, done: int, enabled: bool = True) -> None:
        self.total, self.done, self.enabled = total, done, enabled
        self._bar: Any = None
        if enabled:
            try:
                from tqdm.auto import tqdm
            except ImportError:
                tqdm = None
            if tqdm is not None:
                self._bar = tqdm(total=total, initial=done, unit="cell", file=sys.stderr,
                                 dynamic_ncols=True)

    def start(self, label: str) -> None:
        """Name the cell being computed."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.set_description_str(label)
        else:
            print(f"\r[{self.done}/{self.total}] {label}\033[K", end="", file=sys.stderr,
                  flush=True)

    def advance(self) -> None:
        """One cell done."""
        self.done += 1
        if self._bar is not None:
            self._bar.update(1)

    def close(self) -> None:
        """End the bar."""
        if self._bar is not None:
            self._bar.close()
        elif self.enabled:
            print(f"\r[{self.done}/{self.total}] done\033[K", file=sys.stderr)


# ------------------------------------------------------------------------------------ run
@dataclass
class BenchResult:
    """What a run produced.

    Attributes:
        out: The run folder.
        rows: The table's rows (:func:`table_rows`).
        markdown: The Markdown table (also ``out/results.md``).
        computed: The cells computed by this call (the others were read back or skipped).
        wall_time: Seconds the call took.
    """

    out: Path
    rows: list[dict[str, Any]]
    markdown: str
    computed: list[tuple[str, str]]
    wall_time: float


def default_out(suite: Suite) -> Path:
    """``runs/bench/<suite>-<12 hex digits>``, named by the suite's hash and the code's digest."""
    both = hashlib.sha256(f"{suite.digest} {code_digest()}".encode()).hexdigest()
    return DEFAULT_RUNS / f"{suite.name}-{both[:12]}"


def plan(suite: Suite) -> dict[tuple[str, str], str]:
    """Every cell of the suite -> why it is skipped ("" if it runs), without running anything.

    A cell is skipped when the policy's env arguments conflict with what the suite sets for
    the scenario (see the module docstring).
    """
    notes = {}
    for sc in suite.scenarios:
        for label in sc.policies:
            policy = suite.policies[label].build()
            try:
                env_arguments(sc.env_spec(), policy, {})
                notes[(sc.name, label)] = ""
            except ValueError as exc:
                notes[(sc.name, label)] = f"skipped: {exc}"
    return notes


def run_suite(
    suite: Suite | str | os.PathLike[str] = "default",
    out: str | os.PathLike[str] | None = None,
    *,
    progress: bool = True,
    workers: int | None = 1,
    ray: str | None = None,
) -> BenchResult:
    """Run a suite (resuming a stopped run in ``out``), write the tables and the plots.

    Args:
        suite: A :class:`Suite`, a shipped suite's name or a YAML path.
        out: The run folder (default :func:`default_out`); an existing run of the same suite
            is resumed (finished cells are read back, not recomputed).
        progress: Show a progress bar on stderr.
        workers: Cells run at once, each in a worker process (None: every CPU; 1: here, one
            after another: :func:`agents.parallel.runner`).
        ray: A Ray cluster's address to run the cells on as Ray tasks (``"auto"``,
            ``"HOST:PORT"``, ``"local"``); a cell whose node dies runs again elsewhere.

    The cells' numbers do not depend on ``workers`` or ``ray``: each cell seeds its own envs.

    Returns:
        The run's :class:`BenchResult`.

    Raises:
        ValueError: for a bad suite, ``out`` holding a run of another suite, a bad
            ``workers`` or ``ray`` without Ray installed, before any cell runs.
    """
    start = time.perf_counter()
    with runner(workers, ray) as where:
        where.warm("agents.bench")  # workers start now: their imports overlap the suite's
        if not isinstance(suite, Suite):
            suite = load_suite(suite)
        folder = RunFolder(Path(out) if out is not None else default_out(suite), suite)
        notes = plan(suite)
        folder.start()
        pending = [key for key, note in notes.items() if not note and not folder.done(*key)]
        bar = Progress(len(notes), len(notes) - len(pending), progress)
        try:
            computed, drawn = _run_cells(suite, pending, where, folder, bar)
        finally:
            bar.close()
            close_worker_envs()
        computed.sort(key=list(notes).index)  # the suite's order, wherever they ran
        _draw_the_rest(suite, folder, where, {key[0] for key in computed}, drawn)
    cells = {key: Cell(*key, note=note) if note else folder.load(*key, with_trace=False)
             for key, note in notes.items()}
    rows = table_rows(suite, cells)
    markdown = markdown_table(suite, rows)
    if suite.summary == "paths":
        markdown += "\n## Per path, by machine\n\n" + summary_markdown(summary_rows(suite, cells))
    write_text(folder.root / "results.md", markdown)
    write_text(folder.root / "results.csv", csv_table(rows))
    return BenchResult(folder.root, rows, markdown, computed, time.perf_counter() - start)


def _draw_the_rest(suite: Suite, folder: RunFolder, where: Runner, fresh: set[str],
                   drawn: set[str]) -> None:
    """Draw the plots the cells' units did not draw (``drawn``: the scenarios they drew).

    Those of the scenarios read back (when a plot file is missing), and on a Ray cluster
    those of a scenario whose unit ran only some of its cells (the rest were read back here).
    """
    units = [(suite, sc.name, folder.root, sc.name in fresh) for sc in suite.scenarios
             if sc.name not in drawn]
    for _ in (where if where.shares_files else Runner()).map(draw_scenario, units):
        pass


def _run_cells(
    suite: Suite, pending: list[tuple[str, str]], where: Runner, folder: RunFolder,
    bar: Progress,
) -> tuple[list[tuple[str, str]], set[str]]:
    """Run the pending cells on ``where``, each saved as it arrives.

    A unit is a scenario's pending cells (they share its envs and compiled kernels: one
    process loads them); on several workers, the scenarios with the most episodes first.

    Returns:
        The cells computed, and the scenarios whose plots their units drew.
    """
    computed: list[tuple[str, str]] = []
    drawn: set[str] = set()
    root = folder.root if where.shares_files else None  # workers save their cells
    todo: dict[str, list[str]] = {}
    for scenario, label in pending:
        todo.setdefault(scenario, []).append(label)
    seeds = {sc.name: len(sc.seeds) for sc in suite.scenarios}
    serial = where.workers == 1  # in the suite's order; in parallel, the dearest first
    order = list(todo) if serial else sorted(todo, key=lambda n: -len(todo[n]) * seeds[n])
    bar.start(order[0] if serial and order else where.describe())
    units = [(suite, name, tuple(todo[name]), root) for name in order]
    for i, (cells, plots) in where.map(run_scenario, units):
        for cell in cells:
            if root is None:
                folder.save(cell)
            computed.append((cell.scenario, cell.policy))
            bar.advance()
        for name, png in plots.items():  # drawn on a node that may not see these files
            write_handle_atomically(folder.root / "plots" / name, methodcaller("write", png))
        if root is not None or plots:
            drawn.add(order[i])
        if serial and i + 1 < len(order):
            bar.start(order[i + 1])
    return computed, drawn


# the envs of the scenarios a process ran cells of last (a worker process, or this one), so
# that the policies of a scenario share them as they do run one after another
_WORKER_ENVS: dict[tuple[str, str], EnvPool] = {}
_KEEP_SCENARIOS = 2


def worker_envs(suite: Suite, scenario: str) -> EnvPool:
    """This process's :class:`EnvPool` of ``scenario`` (the last few scenarios' are kept)."""
    key = (suite.digest, scenario)
    if key not in _WORKER_ENVS:
        while len(_WORKER_ENVS) >= _KEEP_SCENARIOS:
            _WORKER_ENVS.pop(next(iter(_WORKER_ENVS))).close()
        _WORKER_ENVS[key] = EnvPool()
    return _WORKER_ENVS[key]


def close_worker_envs() -> None:
    """Close the envs :func:`worker_envs` keeps in this process."""
    while _WORKER_ENVS:
        _WORKER_ENVS.popitem()[1].close()


def run_scenario(
    unit: tuple[Suite, str, tuple[str, ...], Path | None],
) -> tuple[list[Cell], dict[str, bytes]]:
    """A unit of a bench run: cells ``labels`` of a suite's scenario (any process).

    With a run folder's ``root`` (a worker on this machine) the cells are saved there, the
    scenario's plots drawn, and the cells returned without their traces (no trace crosses
    processes). Without (a node that may not see the folder) the cells are returned whole
    and, when they are all of the scenario's, its plots too, as PNG files' bytes by name.

    Raises:
        ValueError: whatever building a policy or its env raises.
    """
    suite, scenario, labels, root = unit
    cells = [run_cell((suite, (scenario, label), root)) for label in labels]
    sc = suite.scenario(scenario)
    if root is None:
        return cells, _png_files(sc, cells, worker_envs(suite, scenario))
    folder = RunFolder(root, suite)  # the plots drawn here, with the traces in hand
    drawn = {(sc.name, c.policy): c for c in cells}
    drawn.update({(sc.name, label): folder.load(sc.name, label) for label in sc.policies
                  if label not in labels and folder.done(sc.name, label)})
    _plots(sc, drawn, folder, worker_envs(suite, scenario), fresh=True)
    for cell in cells:
        cell.trace = None
    return cells, {}


def _png_files(sc: ScenarioSpec, cells: list[Cell], envs: EnvPool) -> dict[str, bytes]:
    # a scenario's plots as PNG bytes by file name, when ``cells`` are all of its policies'
    by_label = {c.policy: c.trace for c in cells if c.trace is not None}
    env = envs.any_env()
    if set(by_label) != set(sc.policies) or env is None:
        return {}
    traces = {label: by_label[label] for label in sc.policies}  # as drawn here: suite order
    with tempfile.TemporaryDirectory() as tmp:
        return {f.name: f.read_bytes() for f in scenario_plots(sc, traces, env, Path(tmp))}


def run_cell(unit: tuple[Suite, tuple[str, str], Path | None]) -> Cell:
    """The cell ``(scenario, policy)`` of a suite (any process), saved in ``root`` if given.

    Raises:
        ValueError: whatever building the policy or its env raises.
    """
    suite, (scenario, label), root = unit
    sc = suite.scenario(scenario)
    cell = evaluate_cell(sc, suite.policies[label], worker_envs(suite, scenario))
    if root is not None:  # at once: an interrupted run keeps it
        RunFolder(root, suite).save(cell)
    return cell


def draw_scenario(unit: tuple[Suite, str, Path, bool]) -> None:
    """A unit of a bench run: a scenario's plots from its saved cells (any process).

    Drawn when a cell of it ran now (``fresh``) or a plot file is missing.
    """
    suite, scenario, root, fresh = unit
    sc = suite.scenario(scenario)
    if not fresh and all((root / "plots" / n).is_file() for n in _plot_names(sc)):
        return
    folder = RunFolder(root, suite)
    cells = {(sc.name, label): folder.load(sc.name, label) for label in sc.policies
             if folder.done(sc.name, label)}
    envs = EnvPool()
    try:
        _plots(sc, cells, folder, envs, fresh)
    finally:
        envs.close()


def _plot_names(sc: ScenarioSpec) -> list[str]:
    # a scenario's plot files
    return [f"{sc.name}_contour.png"] + [f"{sc.name}_feedrate.png"] * (sc.task == FEEDRATE)


def _plots(
    sc: ScenarioSpec, cells: Mapping[tuple[str, str], Cell], folder: RunFolder, envs: EnvPool,
    fresh: bool,
) -> None:
    """Draw a scenario's plots when a cell of it ran now or a plot file is missing."""
    plots = folder.root / "plots"
    if not fresh and all((plots / n).is_file() for n in _plot_names(sc)):
        return
    traces = {label: cell.trace for label in sc.policies
              if (cell := cells.get((sc.name, label))) is not None and cell.trace is not None}
    if not traces:
        return
    env = envs.any_env()
    if env is None:  # every cell was read back: an env of the scenario for its geometry
        policy = next(folder.suite.policies[label].build() for label in traces)
        env = envs.get(sc, policy, 1, record=False)
    scenario_plots(sc, traces, env, plots)
