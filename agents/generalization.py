"""Per-path summaries of a bench run: how each policy does on every path of a machine.

A suite with ``summary: paths`` (``configs/suites/generalization.yaml``) runs each policy on
many paths: random-path scenarios with one seed per path, the papers' paths, G-code parts. The
bench's main table averages over a scenario's seeds; this summary treats every (scenario,
seed) as one *path* and groups the paths by machine and task: a scenario named
``000-random`` or ``000-part_2d`` belongs to group ``000`` (its name up to the first ``-``).

For each group and policy: the number of paths, the median and the worst max contour error
over them (um), the paths within the tolerance, the paths on which the policy's max contour
error is worse than the scenario's baseline's on the same path, and the median cycle time.
Feedrate groups also get two per-path oracles: ``best constant_feedrate`` (on each path the
fastest ``constant_feedrate`` policy of the suite that keeps the tolerance there, or where
none does the most accurate) and ``best cnc_lookahead`` (the same over the ``cnc_lookahead``
policies, e.g. at several blending tolerances); a learned feedrate policy is meant to beat
both.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.suites import Suite
from contour_gym.envs.core import FEEDRATE

UM = 1e6
ORACLES = ("constant_feedrate", "cnc_lookahead")  # per-path bests of a feedrate group
PathKey = tuple[str, int]  # (scenario, seed)
CellKey = tuple[str, str]  # (scenario, policy label)


@dataclass(frozen=True)
class PathResult:
    """One policy's episode on one path."""

    max_ce: float  # m
    cycle_time: float  # s (inf: never in position)
    tolerance: float  # m
    failed: bool

    @property
    def within(self) -> bool:
        """Finished without failing and within the tolerance."""
        return not self.failed and math.isfinite(self.cycle_time) and self.max_ce <= self.tolerance

    def worse_than(self, base: PathResult) -> bool:
        """Failed where ``base`` did not, or (both alike) a higher peak contour error.

        A failed episode's peak is its peak until it ended, often below a finished one's: it
        still counts worse than a baseline that finished.
        """
        if self.failed != base.failed:
            return self.failed
        return self.max_ce > base.max_ce


def group_of(scenario: str) -> str:
    """The group of a scenario name: the text before its first ``-`` (the whole name if none)."""
    return scenario.split("-", 1)[0]


def path_results(cells: Mapping[CellKey, Any]) -> dict[CellKey, dict[PathKey, PathResult]]:
    """Per (scenario, policy) cell: each episode as a :class:`PathResult`, keyed by path."""
    out: dict[CellKey, dict[PathKey, PathResult]] = {}
    for (scenario, label), cell in cells.items():
        out[(scenario, label)] = {
            (scenario, int(e["seed"])): PathResult(
                float(e["max_contour_error"]), float(e["cycle_time"]), float(e["tolerance"]),
                bool(e["failed"]) or not bool(e["finished"]))
            for e in cell.episodes
        }
    return out


def summary_rows(suite: Suite, cells: Mapping[tuple[str, str], Any]) -> list[dict[str, Any]]:
    """One row per group, task and policy (and per feedrate oracle), in suite order.

    Args:
        suite: The suite that ran.
        cells: Its cells by (scenario, policy label), as :func:`agents.bench.run_suite` holds
            them (``episodes``: each with ``seed``, ``max_contour_error``, ``cycle_time``,
            ``tolerance``, ``failed``, ``finished``).
    """
    results = path_results(cells)
    rows: list[dict[str, Any]] = []
    for (group, task), scenarios in _groups(suite).items():
        per_policy: dict[str, dict[PathKey, PathResult]] = {}
        worse: dict[str, int] = {}
        for sc in scenarios:
            base = results.get((sc.name, sc.baseline), {})
            for label in sc.policies:
                mine = results.get((sc.name, label), {})
                per_policy.setdefault(label, {}).update(mine)
                worse[label] = worse.get(label, 0) + sum(
                    1 for key, r in mine.items() if key in base and r.worse_than(base[key]))
        if task == FEEDRATE:
            per_policy.update(_oracles(suite, per_policy))
        for label, paths in per_policy.items():
            rows.append(_row(group, task, label, paths, worse.get(label)))
    return rows


def _groups(suite: Suite) -> dict[tuple[str, str], list[Any]]:
    groups: dict[tuple[str, str], list[Any]] = {}
    for sc in suite.scenarios:
        groups.setdefault((group_of(sc.name), sc.task), []).append(sc)
    return groups


def _oracles(
    suite: Suite, per_policy: Mapping[str, Mapping[PathKey, PathResult]]
) -> dict[str, dict[PathKey, PathResult]]:
    """Per path, the fastest policy of each :data:`ORACLES` target within the tolerance."""
    out: dict[str, dict[PathKey, PathResult]] = {}
    for target in ORACLES:
        labels = [label for label in per_policy if suite.policies[label].target == target]
        if len(labels) < 2:
            continue
        best: dict[PathKey, PathResult] = {}
        for key in set().union(*(per_policy[label].keys() for label in labels)):
            tried = [per_policy[label][key] for label in labels if key in per_policy[label]]
            within = [r for r in tried if r.within]
            best[key] = (min(within, key=lambda r: (r.cycle_time, r.max_ce)) if within
                         else min(tried, key=lambda r: (r.max_ce, r.cycle_time)))
        out[f"best {target}"] = best
    return out


def _row(group: str, task: str, label: str, paths: Mapping[PathKey, PathResult],
         worse: int | None) -> dict[str, Any]:
    ce = np.array([r.max_ce for r in paths.values()]) * UM
    times = np.array([r.cycle_time for r in paths.values()])
    return {
        "group": group, "task": task, "policy": label, "paths": len(paths),
        "median_max_ce_um": float(np.median(ce)) if ce.size else math.nan,
        "worst_max_ce_um": float(ce.max()) if ce.size else math.nan,
        "within_tolerance": sum(r.within for r in paths.values()),
        "worse_than_baseline": math.nan if worse is None else worse,
        "failed": sum(r.failed for r in paths.values()),
        "median_cycle_time_s": float(np.median(times)) if times.size else math.nan,
    }


COLUMNS = (
    ("group", "machine"), ("task", "task"), ("policy", "policy"), ("paths", "paths"),
    ("median_max_ce_um", "median max CE um"), ("worst_max_ce_um", "worst max CE um"),
    ("within_tolerance", "within tol"), ("worse_than_baseline", "worse than baseline"),
    ("failed", "failed"), ("median_cycle_time_s", "median cycle s"),
)


def markdown(rows: Sequence[Mapping[str, Any]]) -> str:
    """The summary as a Markdown table with its explanation."""
    lines = ["| " + " | ".join(h for _, h in COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for row in rows:
        lines.append("| " + " | ".join(format_value(row[key]) for key, _ in COLUMNS) + " |")
    lines += ["", "Per path (every scenario x seed of a machine): median and worst over the "
              "paths; within tol, worse than baseline and failed count paths (the baseline is "
              "each scenario's own; a failed episode, its peak counted until it ended, is worse "
              "than a baseline that finished); "
              "`best X`: per path the fastest X policy within the tolerance."]
    return "\n".join(lines) + "\n"


def format_value(value: Any) -> str:
    """A table cell: strings as they are, ints plainly, floats to 4 digits, NaN empty."""
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)):
        return str(value)
    if math.isnan(value):
        return ""
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return f"{value:.4g}"
