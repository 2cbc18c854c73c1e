"""Tuning runs: :func:`tune` runs a protocol with an optimiser and writes its run folder.

:func:`tune` runs a protocol of :data:`~agents.tune.protocols.PROTOCOLS` with any optimiser of
:mod:`agents.optim` (``contour-gym tune PROTOCOL`` on the command line); :func:`compare` runs
several optimisers over several seeds.

**Run folder** (``out``): ``result.json`` (best parameters by name, best fitness, the
settings, seed, optimiser, wall time and the best-so-far fitness after every generation),
written atomically after every generation (``"status": "running"``, the history so far),
once more at the end (``"complete"``; ``"interrupted"`` on Ctrl-C and ``"failed"`` on an
error, then re-raised); ``evaluations.npz`` (every candidate evaluated so far and its
per-scenario results, written with it); ``convergence.png``; and for the PSO family
``schedules.png`` (:mod:`agents.tune.plots`).

**Resuming.** A run that stopped (Ctrl-C, a crash, a cluster node lost) continues when run
again with the same folder and settings (and no ``overwrite``): the optimiser starts again
from its seed, but every candidate the stopped run evaluated is read from
``evaluations.npz`` instead of simulated, so it replays those generations in moments and goes
on; the result equals an uninterrupted run's. ``overwrite`` simulates every candidate again.
"""

from __future__ import annotations

import json
import math
import os
import shlex
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agents.optim import OPTIMIZERS, OptimResult, minimize, options_of
from agents.optim._base import make_rng, positive_int
from agents.optim.pso import schedules
from agents.tune.fitness import FloatArray
from agents.tune.objective import PopulationObjective
from agents.tune.plots import write_plots
from agents.tune.protocols import Protocol, get_protocol
from agents.tune.result import TuneResult
from contour_gym.files import write_text
from contour_gym.params import choice

PSO_FAMILY = ("pso", "improved_pso")
EVALUATIONS = "evaluations.npz"  # a run folder's evaluated candidates (a stopped run resumes)


class _Monitor:
    """Wraps the objective: counts generations, keeps the best so far, reports each generation.

    Every optimiser evaluates exactly ``population`` candidates per generation (in one or
    several calls), so generation ``k`` ends when ``population * (k + 1)`` candidates are done;
    the best so far is kept as :class:`agents.optim._base.Problem` keeps it (first strict
    minimum; non-finite values count as ``inf``), so the history equals the optimiser's.
    """

    def __init__(
        self, objective: PopulationObjective, population: int,
        on_generation: Callable[[_Monitor], None], bar: Any,
    ) -> None:
        self.objective, self.population = objective, population
        self.on_generation, self.bar = on_generation, bar
        self.nfev, self.best_f = 0, math.inf
        self.best_z: FloatArray | None = None
        self.history: list[float] = []

    def __call__(self, z: FloatArray, /) -> FloatArray:
        f = self.objective(z)
        for row, value in zip(z, f, strict=True):
            v = float(value) if math.isfinite(value) else math.inf
            if self.best_z is None or v < self.best_f:
                self.best_f, self.best_z = v, np.array(row)
            self.nfev += 1
            if self.nfev % self.population == 0 and self.nfev > self.population:
                self.history.append(self.best_f)
                self.on_generation(self)
        if self.bar is not None:
            self.bar.update(len(f))
            self.bar.set_postfix_str(f"best {self.best_f * 1e6:.4g} um", refresh=False)
        return f


def tune(
    protocol: str | Protocol,
    optimizer: str | None = None,
    *,
    seed: int = 0,
    population: int | None = None,
    iterations: int | None = None,
    ideal: bool = False,
    out: str | os.PathLike[str] | None = None,
    progress: bool = True,
    options: Mapping[str, Any] | None = None,
    command: str | None = None,
    workers: int | None = None,
    overwrite: bool = False,
    ray: str | None = None,
) -> TuneResult:
    """Run a tuning protocol with an optimiser.

    Args:
        protocol: A :data:`~agents.tune.protocols.PROTOCOLS` name or a :class:`Protocol`.
        optimizer: A key of :data:`agents.optim.OPTIMIZERS` (None: the protocol's).
        seed: The optimiser's seed (the episodes use the protocol's ``episode_seed``).
        population: Candidates per generation (None: the protocol's).
        iterations: Generations after the initial one (None: the protocol's).
        ideal: Run the scenarios without the rig's encoder, noise and delay.
        out: Run folder for ``result.json`` and the plots (module docstring); None writes
            nothing.
        progress: Show a progress bar (tqdm, on stderr).
        options: The optimiser's own options (None: the protocol's for its own optimiser,
            else none).
        command: The command line to record in ``result.json`` (None: the equivalent
            ``contour-gym tune`` command).
        workers: Threads running the population (:class:`PopulationObjective`; None: every
            CPU). The result does not depend on it.
        overwrite: Replace a finished result in ``out`` (else refused: :func:`check_run_folder`).
        ray: A Ray cluster's address: each generation's candidates spread over its CPUs
            (:class:`~agents.tune.objective.PopulationObjective`; the same result).

    Returns:
        The :class:`TuneResult`.

    Raises:
        ValueError: for an unknown protocol or optimiser (listing the accepted names), or a
            bad budget, seed or option (naming it).
    """
    proto = get_protocol(protocol)
    name, options = _optimizer_options(proto, optimizer, options)
    m = proto.population if population is None else population
    t = proto.iterations if iterations is None else iterations
    folder = _run_folder(m, t, seed, out, overwrite)
    settings = _settings(proto, name, options, m, t, ideal,
                         command or _command(proto.name, name, seed, m, t, ideal, out))
    objective = _objective(proto, m, ideal, workers, ray)
    settings["penalty"] = objective.penalty
    run = _Run(proto, name, seed, settings, folder)
    run.recall(objective, replay=not overwrite)
    try:
        return run.finish(run.search(objective, m, t, options, progress), objective)
    finally:
        objective.close()


def _objective(
    proto: Protocol, population: int, ideal: bool, workers: int | None, ray: str | None
) -> PopulationObjective:
    """The protocol's objective, its population checked against the memory."""
    objective = PopulationObjective(proto, ideal=ideal, workers=workers, ray=ray)
    try:
        objective.check_population(population)
    except ValueError:
        objective.close()
        raise
    return objective


def _run_folder(
    population: Any, iterations: Any, seed: Any, out: str | os.PathLike[str] | None,
    overwrite: bool,
) -> Path | None:
    """The run folder (None: write nothing), checked with the budget before anything runs."""
    _check_budget(population, iterations, seed)
    folder = None if out is None else Path(out)
    if folder is not None:
        check_run_folder(folder, overwrite)
    return folder


def _optimizer_options(
    proto: Protocol, optimizer: str | None, options: Mapping[str, Any] | None
) -> tuple[str, Mapping[str, Any]]:
    """The optimiser's name and options (None: the protocol's for its own optimiser, else none).

    Raises:
        ValueError: for an unknown optimiser or option, listing the accepted ones; for
            ``x0``, whose start point is the protocol's (``start_at_reference``).
    """
    name = choice(optimizer or proto.optimizer, "optimizer", OPTIMIZERS)
    if options is None:
        options = proto.optimizer_options if name == proto.optimizer else {}
    if "x0" in options:
        raise ValueError("x0 is not a tuning option: a protocol starts at its untuned law "
                         "with start_at_reference=True")
    accepted = [o for o in options_of(name) if o != "x0"]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise ValueError(f"unknown option(s) {', '.join(unknown)} for {name!r}; accepted: "
                         f"{', '.join(accepted)}")
    return name, options


def _settings(
    proto: Protocol, name: str, options: Mapping[str, Any], m: int, t: int, ideal: bool,
    command: str,
) -> dict[str, Any]:
    """The run's settings for ``result.json``; the PSO family's schedules checked and recorded."""
    settings: dict[str, Any] = {
        "population": m, "iterations": t, "ideal": bool(ideal), "scenarios": list(proto.scenarios),
        "fitness": proto.fitness, "ccc_law": proto.ccc_law, "episode_seed": proto.episode_seed,
        "setter": proto.setter, "scenario_kwargs": {k: dict(v) for k, v in
                                                    proto.scenario_kwargs.items()},
        "bounds": {p.name: [p.low, p.high] for p in proto.params},
        "log_scaled": [p.name for p in proto.params if p.log],
        "optimizer_options": dict(options),
        "start_at_reference": proto.start_at_reference,
        "command": command,
    }
    if name in PSO_FAMILY:  # checks the budget too, before any simulation
        settings["schedules"] = schedules(name, t, **options).tolist()
    return settings


class _Run:
    """One search in progress: its clock, and ``result.json`` after every generation."""

    def __init__(
        self, proto: Protocol, name: str, seed: int, settings: dict[str, Any],
        folder: Path | None,
    ) -> None:
        self.proto, self.name, self.seed = proto, name, seed
        self.settings, self.folder = settings, folder
        self.start = time.perf_counter()

    def elapsed(self) -> float:
        """Seconds since the search started."""
        return time.perf_counter() - self.start

    def recall(self, objective: PopulationObjective, replay: bool = True) -> None:
        """Give ``objective`` the candidates an unfinished run of the same settings evaluated.

        The optimiser then replays that run's generations from its seed without simulating
        them (every candidate's result is remembered), and goes on where it stopped. Not with
        ``replay`` False (``overwrite``: computed again, e.g. after a code change).
        """
        if not replay or self.folder is None or not (self.folder / EVALUATIONS).is_file():
            return
        try:
            before = json.loads((self.folder / "result.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return
        same = {k: v for k, v in before.get("settings", {}).items() if k != "command"}
        if (before.get("seed"), before.get("optimizer")) == (self.seed, self.name) and same == {
                k: v for k, v in json.loads(json.dumps(self.settings)).items()
                if k != "command"}:
            objective.recall(self.folder / EVALUATIONS)

    def save(self, mon: _Monitor, status: str = "running") -> None:
        """Write the partial ``result.json`` and the evaluations so far (with a run folder)."""
        if self.folder is not None:
            mon.objective.keep(self.folder / EVALUATIONS)
            data = _partial_json(self.proto, self.name, self.seed, self.settings, mon,
                                 self.elapsed(), status)
            _write_json(self.folder / "result.json", data)

    def starts(self) -> dict[str, Any]:
        """The optimiser's ``x0``: the reference point, if the protocol starts at it."""
        return {"x0": self.proto.reference_start()} if self.proto.start_at_reference else {}

    def search(
        self, objective: PopulationObjective, m: int, t: int, options: Mapping[str, Any],
        progress: bool,
    ) -> OptimResult:
        """Run the optimiser; on Ctrl-C or an error save the history so far, then re-raise."""
        from tqdm.auto import tqdm

        bar = tqdm(total=m * (t + 1), desc=f"tune {self.proto.name} ({self.name})", unit="cand",
                   disable=not progress, dynamic_ncols=True)
        monitor = _Monitor(objective, m, self.save, bar)
        try:
            return minimize(self.name, monitor, self.proto.search_bounds, population=m,
                            iterations=t, seed=self.seed, **options, **self.starts())
        except KeyboardInterrupt:
            self.save(monitor, "interrupted")
            raise
        except BaseException:
            self.save(monitor, "failed")
            raise
        finally:
            bar.close()

    def finish(self, res: OptimResult, objective: PopulationObjective) -> TuneResult:
        """The :class:`TuneResult`, written to the run folder with its plots."""
        result = _result(self.proto, res, objective, self.seed, self.settings, self.elapsed(),
                         self.folder)
        if self.folder is not None:
            _write_json(self.folder / "result.json", result.to_json())
            write_plots(result, self.folder)
        return result


def _result(
    proto: Protocol, res: OptimResult, objective: PopulationObjective, seed: int,
    settings: dict[str, Any], wall: float, folder: Path | None,
) -> TuneResult:
    best = proto.to_params(res.x)
    per_case, failed = objective.evaluate(best)
    per = {c.name: float(objective.penalty if failed[i, 0] else per_case[i, 0])
           for i, c in enumerate(objective.cases)}
    return TuneResult(
        protocol=proto.name, optimizer=res.name, seed=int(seed),
        params={n: float(v) for n, v in zip(proto.names, best[0], strict=True)},
        fitness=float(res.fun), history=[float(h) for h in res.history], per_scenario=per,
        nfev=int(res.nfev), wall_time=float(wall), settings=settings, out=folder,
    )


def _partial_json(
    proto: Protocol, name: str, seed: int, settings: dict[str, Any], mon: _Monitor, wall: float,
    status: str,
) -> dict[str, Any]:
    params = None
    if mon.best_z is not None:
        best = proto.to_params(mon.best_z)[0]
        params = {n: float(v) for n, v in zip(proto.names, best, strict=True)}
    return {
        "status": status, "protocol": proto.name, "optimizer": name, "seed": int(seed),
        "params": params, "fitness": mon.best_f if math.isfinite(mon.best_f) else None,
        "fitness_unit": "m", "nfev": mon.nfev, "wall_time_s": wall, "settings": settings,
        "generations": len(mon.history), "history": list(mon.history),
    }


def _command(
    proto: str, optimizer: str, seed: int, m: int, t: int, ideal: bool,
    out: str | os.PathLike[str] | None,
) -> str:
    args = ["contour-gym", "tune", proto, "--optimizer", optimizer, "--seed", str(seed),
            "--population", str(m), "--iterations", str(t)]
    if ideal:
        args.append("--ideal")
    if out is not None:
        args += ["--out", os.fspath(out)]
    return shlex.join(args)


def _check_budget(population: Any, iterations: Any, seed: Any) -> None:
    # before anything runs or is written: a bad budget must not touch a run folder
    positive_int(population, "population")
    positive_int(iterations, "iterations")
    make_rng(seed)


def check_run_folder(folder: Path, overwrite: bool) -> None:
    """Refuse a run folder that is a file or holds a finished result (unless ``overwrite``).

    An unfinished result (``"status"`` running, interrupted or failed) is resumed: the run
    replays its evaluations (module docstring) when the settings are the same, else restarts.

    Raises:
        ValueError: naming the folder or file, and how to go on.
    """
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--out {folder} is a file, not a folder")
    target = folder / "result.json"
    if overwrite or not target.exists():
        return
    try:
        status = json.loads(target.read_text(encoding="utf-8")).get("status")
    except (OSError, ValueError, AttributeError) as exc:
        raise ValueError(f"{target} cannot be read ({exc}); pass --overwrite to replace it, "
                         "or choose another --out") from None
    if status == "complete":
        raise ValueError(f"{target} holds a finished tuning result; pass --overwrite to "
                         "replace it, or choose another --out")


def _write_json(target: Path, data: Mapping[str, Any]) -> None:
    """Write ``data`` as JSON, whole or not at all (:func:`contour_gym.files.write_atomically`)."""
    text = json.dumps(data, indent=2) + "\n"
    write_text(target, text)


def compare(
    protocol: str | Protocol, optimizers: Sequence[str], seeds: Sequence[int], **kwargs: Any
) -> dict[str, list[float]]:
    """Best fitness of each optimiser over several seeds (no files, no progress bar).

    Args:
        protocol: A :data:`~agents.tune.protocols.PROTOCOLS` name or a :class:`Protocol`.
        optimizers: Keys of :data:`agents.optim.OPTIMIZERS`.
        seeds: Optimiser seeds.
        **kwargs: More :func:`tune` arguments (``population``, ``iterations``, ``ideal``).

    Returns:
        Optimiser -> best fitness per seed, m.
    """
    return {name: [tune(protocol, name, seed=s, progress=False, **kwargs).fitness for s in seeds]
            for name in optimizers}

