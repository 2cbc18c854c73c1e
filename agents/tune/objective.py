"""The batch objective of a tuning protocol: a whole population per call, on threads.

:class:`PopulationObjective` evaluates a population at once: one batched
:class:`~contour_gym.loop.ServoLoop` per scenario, each candidate one batch member with its
own parameters (the protocol's setter), every member reset from the same episode seed, so a
candidate's fitness depends on its parameters only, never on the other members, the batch
size or the number of threads. The scenario of an env id is the env's own (its machine, path,
estimator, tolerance; ``ideal`` as asked), with the protocol's CCC law and the env's PID CCC
gains as the law's base gains ``kp, ki, kd``, as the reference policy
:class:`~agents.ccc_policies.FuzzyPIDCCC` builds it.

**Failures.** A candidate fails on a scenario when its member does not get in position at the
path end (the loop's divergence test, or not in position ``settle_time`` after the reference
ended), when its largest true contour error exceeds the env's hard limit (``hard_limit``, by
default 100 tolerances: the envs' failure rule), or when its fitness is not finite; it then
gets the penalty of :mod:`agents.tune.fitness`.
"""

from __future__ import annotations

import math
import threading
import time
import weakref
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import ArrayLike, NDArray

import agents.ccc_laws  # noqa: F401  (registers the fuzzy_pid law)
import contour_gym  # noqa: F401  (registers the env ids)
from agents.parallel import RAY_RETRIES, RayRunner, _init_worker
from agents.tune.fitness import (
    FITNESS_TERMS,
    FITNESSES,
    PENALTY_HARD_LIMITS,
    FloatArray,
    combine,
)
from agents.tune.protocols import Protocol, get_protocol
from agents.tune.setters import SETTERS
from contour_gym.api import Scenario
from contour_gym.envs.config import EnvConfig
from contour_gym.envs.core import member_rngs
from contour_gym.files import write_atomically
from contour_gym.limits import check_size
from contour_gym.loop import ServoLoop, member_bytes
from contour_gym.loop.threads import available_cpus
from contour_gym.tasks import TASKS


@dataclass(frozen=True)
class _Case:
    """One scenario of a protocol, built as its env builds it."""

    name: str
    scenario: Scenario
    base_gains: tuple[float, float, float]
    hard_limit: float
    chatter_cap: float = math.inf
    scale: float = 1.0  # the reference point's fitness here (Protocol.relative), else 1


def _loops_of(case: _Case) -> Callable[[int], ServoLoop]:
    """A maker of loops of ``case``'s scenario, by batch size."""
    return lambda batch: case.scenario.loop(batch_size=batch)


def _case(
    name: str, ccc_law: str, ideal: bool, overrides: Mapping[str, Any] | None = None
) -> _Case:
    given = dict(overrides or {})
    env_id, path_seed = given.pop("id", name), given.pop("path_seed", None)
    if env_id not in gym.registry:
        raise ValueError(f"unknown env id {env_id!r} (scenario {name!r})")
    kwargs = {**gym.spec(env_id).kwargs, **given, "ideal": ideal, "ccc_law": ccc_law}
    config = EnvConfig.from_kwargs(kwargs)
    if config.random_paths:
        if not isinstance(path_seed, int) or isinstance(path_seed, bool):
            raise ValueError(f"scenario {name!r} runs a random path: give its int path_seed, "
                             f"got {path_seed!r}")
        rng = member_rngs(path_seed, 1)[0]  # the path env.reset(seed=path_seed) runs
        scenario = config.random_scenario(rng, TASKS.get("ccc"), as_reset=True)
    else:
        scenario = config.scenario()
    preset = scenario.preset
    kp, ki, kd = config.ccc_gains or preset.ccc_gains.as_tuple()
    hard = config.hard_limit_for(preset)
    return _Case(name, scenario, (float(kp), float(ki), float(kd)), float(hard))


MEMO_SIZE = 100_000  # candidates a PopulationObjective remembers (a few hundred bytes each)
RECENT = 400  # recent candidates a PopulationObjective predicts the work of new ones from
OPTIMIZER_ROWS = 16  # (population, parameters) float arrays an optimiser holds at most at once


class Memo:
    """Candidates met before: parameters -> (fitness (S,), failed (S,)), in arrays as they come.

    Up to :data:`MEMO_SIZE` candidates, looked up by their parameters' bytes. The rows are kept
    in growing arrays, so that writing them all (:meth:`PopulationObjective.keep`, after every
    generation) costs one copy, not a stack of every entry: on protocol 003 (400 generations,
    under a profiler) stacking took 2.6 s of the run's 26.6 s on one worker, serial between
    generations; about 1 s of 25 s without the profiler.

    Args:
        d: Parameters per candidate.
        s: Scenarios per candidate.
    """

    def __init__(self, d: int, s: int) -> None:
        self._index: dict[bytes, int] = {}
        self._x, self._fit = np.empty((64, d)), np.empty((64, s))
        self._failed = np.empty((64, s), dtype=bool)

    def __len__(self) -> int:
        return len(self._index)

    def __contains__(self, key: bytes) -> bool:
        return key in self._index

    def __getitem__(self, key: bytes) -> tuple[FloatArray, NDArray[np.bool_]]:
        i = self._index[key]
        return self._fit[i].copy(), self._failed[i].copy()

    def add(self, key: bytes, x: FloatArray, fit: FloatArray, failed: NDArray[np.bool_]) -> None:
        """Remember a candidate (``key``: its parameters ``x``'s bytes), unless full or known."""
        n = len(self._index)
        if n >= MEMO_SIZE or key in self._index:
            return
        if n == len(self._x):  # full: twice the room
            self._x, self._fit, self._failed = (
                np.concatenate([a, np.empty_like(a)]) for a in (self._x, self._fit, self._failed))
        self._x[n], self._fit[n], self._failed[n] = x, fit, failed
        self._index[key] = n

    def arrays(self) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
        """Every candidate's parameters, fitness and failures, in the order they came."""
        n = len(self._index)
        return self._x[:n], self._fit[:n], self._failed[:n]


class PopulationObjective:
    """A protocol's batch objective: ``(n, D)`` search coordinates -> ``(n,)`` fitness, m.

    The scenarios, and slices of the population, run as separate batches on ``workers``
    threads (the servo loop's kernel releases the GIL), the scenario that has taken the most
    time so far first; every candidate's result is the same for any number of workers and in
    any order (its run depends on its own parameters and seed only). For the same reason a
    candidate met before (the same parameters, bit for bit) is not simulated again: its
    result is remembered (up to :data:`MEMO_SIZE` candidates). Optimisers propose repeats:
    in protocol 003 improved ABC re-proposes a food source whenever a perturbation is
    clipped back onto it, 14.5 % of its candidates and 12.8 % of its simulation time.

    Args:
        protocol: The protocol (or its name).
        ideal: Run the scenarios without the rig's encoder, noise and delay.
        workers: Threads (None: the CPUs this process may use; 1: no threads).
        ray: A Ray cluster's address (:class:`agents.parallel.RayRunner`): the candidates run
            on one actor per CPU of the cluster (each an objective of one thread), in slices
            of equal size; an actor whose node dies is started again and its slice retried.
            :meth:`close` releases them.

    Attributes:
        penalty: The fitness of a failed candidate (:mod:`agents.tune.fitness`), m.

    Raises:
        ValueError: for ``workers`` below 1.
    """

    def __init__(
        self, protocol: str | Protocol, ideal: bool = False, workers: int | None = None,
        ray: str | None = None,
    ) -> None:
        self.protocol = get_protocol(protocol)
        self.ideal = bool(ideal)
        self.workers = available_cpus() if workers is None else workers
        if not isinstance(self.workers, int) or self.workers < 1:
            raise ValueError(f"workers must be an int >= 1, got {workers!r}")
        proto = self.protocol
        self.cases = tuple(_case(e, proto.ccc_law, self.ideal, proto.scenario_kwargs.get(e))
                           for e in proto.scenarios)
        terms = FITNESS_TERMS.get(proto.fitness, lambda sc: 1)
        self.penalty = PENALTY_HARD_LIMITS * max(c.hard_limit * terms(c.scenario)
                                                 for c in self.cases)
        self._set = SETTERS[proto.setter]
        self._fitness = FITNESSES[self.protocol.fitness]
        self._loops: dict[int, list[ServoLoop]] = {}  # slice -> each scenario's loop
        self._lock = threading.Lock()
        # per scenario: seconds and member-ticks simulated so far
        self._cost, self._ticks = np.zeros(len(self.cases)), np.zeros(len(self.cases))
        self._recent_x = np.empty((RECENT, len(self.protocol.params)))
        self._recent_ticks = np.empty((RECENT, len(self.cases)))
        self._n_recent = 0  # candidates simulated so far
        self._pool: ThreadPoolExecutor | None = None
        self._memo = Memo(len(self.protocol.params), len(self.cases))
        if proto.chatter_bound is not None or proto.relative:
            self._run_reference()
        self._remote = None if ray is None else RemoteSlices(self.protocol, self.ideal, ray)

    def check_population(self, population: int) -> None:
        """Refuse (ValueError) a population whose generation would not fit in the memory.

        Each candidate is a member of every scenario's loop
        (:func:`contour_gym.loop.member_bytes`) and a row of the optimiser's arrays
        (:data:`OPTIMIZER_ROWS` floats per parameter).
        """
        member = 8.0 * OPTIMIZER_ROWS * len(self.protocol.params)
        member += sum(member_bytes(_loops_of(c)) for c in self.cases)
        check_size(population * member, f"a population of {population} candidates "
                   f"({len(self.cases)} scenario(s) each)", "--population")

    def keep(self, target: Path) -> None:
        """Write every remembered candidate and its results to ``target`` (``.npz``, atomic)."""
        if not len(self._memo):
            return
        x, fit, failed = self._memo.arrays()

        def write(tmp: str) -> None:
            with open(tmp, "wb") as handle:
                np.savez(handle, x=x, fitness=fit, failed=failed)

        write_atomically(target, write)

    def recall(self, source: Path) -> None:
        """Remember the candidates :meth:`keep` wrote (a file of another protocol is ignored)."""
        try:
            with np.load(source) as data:
                x, fit, failed = data["x"], data["fitness"], data["failed"]
        except (OSError, ValueError, KeyError):
            return
        if x.ndim != 2 or x.shape[1] != len(self.protocol.params) or fit.shape[1:] != (
                len(self.cases),):
            return
        for row, f, bad in zip(x, fit, failed, strict=True):
            self._memo.add(np.ascontiguousarray(row, dtype=np.float64).tobytes(), row, f, bad)

    def close(self) -> None:
        """Stop the objective's threads and Ray actors (it still runs, on this thread)."""
        if self._pool is not None:
            self._pool.shutdown(wait=False)
            self._pool = None
        if self._remote is not None:
            self._remote.close()
            self._remote = None

    def _run_reference(self) -> None:
        """Each scenario's chattering cap and fitness scale, from the reference point's run."""
        proto = self.protocol
        ref = proto.reference_row()[None, :]
        cases = []
        for case, m in zip(self.cases, self.metrics(ref), strict=True):
            cap = math.inf if proto.chatter_bound is None else proto.chatter_bound * float(
                m["chattering"][0])
            scale = float(self._fitness(m)[0]) if proto.relative else 1.0
            if not (math.isfinite(scale) and scale > 0.0 and cap >= 0.0):
                raise ValueError(f"protocol {proto.name!r}: the reference point gives fitness "
                                 f"{scale!r} and chattering cap {cap!r} on scenario "
                                 f"{case.name!r}; relative scores need a finite one > 0")
            cases.append(replace(case, chatter_cap=cap, scale=scale))
        self.cases = tuple(cases)
        scales = np.array([c.scale for c in self.cases])
        self.penalty *= float(scales.mean() / scales.min())  # above any relative total

    def __call__(self, z: FloatArray, /) -> FloatArray:
        """Fitness of each row of ``z`` (search coordinates; see :meth:`Protocol.to_params`)."""
        return self.fitness(self.protocol.to_params(z))

    def fitness(self, params: ArrayLike) -> FloatArray:
        """Fitness of each row of ``params`` (the parameters in their own units), m.

        The mean (or, ``worst_case``, the largest) over the scenarios of the protocol's
        fitness (``relative``: over the reference's, times the reference's mean), or
        :attr:`penalty` for a candidate that failed on any scenario.
        """
        per_case, failed = self.evaluate(params)
        scale = np.array([[c.scale] for c in self.cases])
        unit = float(scale.mean())
        total = combine(per_case / scale, failed, self.penalty / unit, self.protocol.worst_case)
        return total * unit

    def evaluate(self, params: ArrayLike) -> tuple[FloatArray, NDArray[np.bool_]]:
        """Run every candidate on every scenario.

        Args:
            params: ``(n, D)`` parameters in their own units, in the protocol's order.

        Returns:
            ``(fitness (S, n), failed (S, n))`` per scenario: the protocol's fitness (m) and
            whether the candidate failed there (it then keeps whatever its run measured).

        Raises:
            ValueError: for a shape other than ``(n, D)`` or a value the law rejects.
        """
        x = np.asarray(params, dtype=np.float64)
        d = len(self.protocol.params)
        if x.ndim != 2 or x.shape[1] != d or x.shape[0] < 1:
            raise ValueError(f"params must have shape (n, {d}), got {x.shape}")
        keys = [row.tobytes() for row in x]
        new: dict[bytes, int] = {}  # a candidate not met before -> its first row here
        for r, key in enumerate(keys):
            if key not in self._memo and key not in new:
                new[key] = r
        results: dict[bytes, tuple[FloatArray, NDArray[np.bool_]]] = {}
        if new:
            simulate = self._simulate if self._remote is None else self._remote
            fit, failed = simulate(x[np.fromiter(new.values(), dtype=np.intp)])
            results = {key: (fit[:, c].copy(), failed[:, c].copy()) for c, key in enumerate(new)}
            for key, r in new.items():
                self._memo.add(key, x[r], *results[key])
        cols = [results[key] if key in results else self._memo[key] for key in keys]
        return (np.stack([c[0] for c in cols], axis=1),
                np.stack([c[1] for c in cols], axis=1))

    def _simulate(self, x: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """:meth:`evaluate` without the memo: every row of ``x`` is simulated."""
        n, n_cases = x.shape[0], len(self.cases)
        fit, failed = np.empty((n_cases, n)), np.empty((n_cases, n), dtype=bool)
        ticks = np.empty((n_cases, n))
        units = self._units(x)

        def run(unit: tuple[int, int, NDArray[np.intp]]) -> None:
            i, j, rows = unit
            loop = self._loops_for(n, j)[i]  # one size per batch: no loop built per slice
            start = time.perf_counter()
            fit[i, rows], failed[i, rows] = self._run(self.cases[i], loop, x[rows])
            ticks[i, rows] = loop.ticks_run[: len(rows)]
            with self._lock:
                self._cost[i] += time.perf_counter() - start
                self._ticks[i] += ticks[i, rows].sum()

        if self.workers == 1 or len(units) == 1:
            for unit in units:
                run(unit)
        else:
            list(self._thread_pool().map(run, units))
        self._recall(x, ticks)
        return fit, failed

    def _units(self, x: FloatArray) -> list[tuple[int, int, NDArray[np.intp]]]:
        """Work units ``(scenario, slice, rows)``, dearest first, slices of equal predicted work.

        A candidate's ticks are predicted from a recent candidate that differs from it in at
        most one parameter (an ABC bee's food source: 77 % of protocol 003's candidates; else
        the scenario's mean): one that fails near tick 100 runs 25 times fewer ticks than
        one that gets in position. Each scenario's candidates are dealt to ``workers``
        slices, dearest first, each to the slice with the least work so far; the units run
        longest first. On protocol 003 the threads idle ~9 %, mostly in each generation's
        serial Python.
        """
        n, k = x.shape[0], min(x.shape[0], self.workers)
        mean = np.maximum(self._ticks / max(self._n_recent, 1), 1.0)  # 1: equal counts
        pred = np.repeat(mean[:, None], n, axis=1)
        m = min(self._n_recent, RECENT)
        if m:
            same = (x[:, None, :] == self._recent_x[None, :m]).sum(axis=2)
            best = same.argmax(axis=1)
            near = same[np.arange(n), best] >= x.shape[1] - 1
            pred[:, near] = self._recent_ticks[best[near]].T
        rate = self._cost / np.maximum(self._ticks, 1.0)  # seconds per member-tick
        units = []
        for i in range(len(self.cases)):
            load = np.zeros(k)
            slices: list[list[int]] = [[] for _ in range(k)]
            for r in np.argsort(-pred[i], kind="stable"):
                j = int(load.argmin())
                slices[j].append(int(r))
                load[j] += pred[i, r]
            units += [(rate[i] * load[j], i, j, np.array(sorted(rows), dtype=np.intp))
                      for j, rows in enumerate(slices) if rows]
        units.sort(key=lambda u: -u[0])
        return [(i, j, rows) for _, i, j, rows in units]

    def _recall(self, x: FloatArray, ticks: FloatArray) -> None:
        """Keep the last :data:`RECENT` candidates and their ticks for :meth:`_units`."""
        for row, t in zip(x, ticks.T, strict=True):
            slot = self._n_recent % RECENT
            self._recent_x[slot], self._recent_ticks[slot] = row, t
            self._n_recent += 1

    def _thread_pool(self) -> ThreadPoolExecutor:
        """The objective's worker threads (started once, shut down with the objective)."""
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=self.workers)
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def metrics(self, params: ArrayLike) -> list[dict[str, FloatArray]]:
        """Every scenario's full loop metrics for each candidate (``(n,)`` arrays, SI)."""
        x = np.atleast_2d(np.asarray(params, dtype=np.float64))
        n = x.shape[0]
        out = []
        for case, loop in zip(self.cases, self._loops_for(n), strict=True):
            self._run(case, loop, x)
            out.append({**{k: v[:n] for k, v in loop.metrics().items()},
                        "failed": loop.failed[:n].astype(float),
                        "finished": loop.done[:n].astype(float)})
        return out

    def _loops_for(self, n: int, part: int = 0) -> list[ServoLoop]:
        """Each scenario's loop for ``n`` candidates of slice ``part`` (one per thread).

        A part's loops hold the most candidates it has been given so far and run as many as
        it has now (:meth:`_run`): the memo and the balanced slices leave batches of any
        size, and building a loop took ~40 ms.
        """
        with self._lock:
            loops = self._loops.get(part)
            if loops is None or loops[0].batch_size < n:
                loops = self._loops[part] = [
                    c.scenario.loop(batch_size=n, ccc_gains=c.base_gains) for c in self.cases
                ]
            return loops

    def _run(
        self, case: _Case, loop: ServoLoop, x: FloatArray
    ) -> tuple[FloatArray, NDArray[np.bool_]]:
        n, size = x.shape[0], loop.batch_size
        if n < size:  # the spare members get the last candidate's values and sit out
            x = np.concatenate([x, np.repeat(x[-1:], size - n, axis=0)])
        self._set(loop, self.protocol.names, x, case.base_gains)
        # every member from the same seed: a candidate's result is its own (loop docstring)
        loop.reset([self.protocol.episode_seed] * size)
        # a member past the hard limit stops on that tick, in the kernel: it fails whatever it
        # does next, and a diverging candidate's ticks are the slowest (its error widens every
        # foot-point search); stopping it there, not at the end of a 256-tick call, took
        # protocol 003 on one thread from 63 s to 34 s
        run = loop.run(stop_above=case.hard_limit, members=np.arange(n) if n < size else None)
        metrics = {k: v[:n] for k, v in run.items()}
        f = self._fitness(metrics)
        failed = (~loop.done[:n] | ~np.isfinite(f)
                  | ~(metrics["max_contour_error"] <= case.hard_limit)
                  | ~(metrics["chattering"] <= case.chatter_cap))
        return f, failed | ~(f < self.penalty)


class RemoteSlices:
    """A population's candidates on a Ray cluster: one actor per CPU, a slice each.

    Each actor holds a one-thread :class:`PopulationObjective` of the protocol (built once);
    a call deals the candidates to the actors in slices of equal size and returns what
    :meth:`PopulationObjective._simulate` returns for all of them, the same numbers as a local
    run (a candidate's run depends on its parameters alone).
    """

    def __init__(self, protocol: Protocol, ideal: bool, address: str) -> None:
        self._cluster = RayRunner(address)
        ray = self._ray = self._cluster._ray
        actor = ray.remote(num_cpus=1, max_restarts=-1, max_task_retries=RAY_RETRIES)(_Slices)
        self._actors = [actor.remote(protocol, ideal) for _ in range(self._cluster.workers)]

    def __call__(self, x: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        """What :meth:`PopulationObjective._simulate` returns for ``x``, run on the actors."""
        slices = [rows for rows in np.array_split(np.arange(x.shape[0]), len(self._actors))
                  if rows.size]
        refs = [a.simulate.remote(x[rows]) for a, rows in zip(self._actors, slices, strict=False)]
        parts = self._ray.get(refs)
        fit = np.concatenate([p[0] for p in parts], axis=1)
        failed = np.concatenate([p[1] for p in parts], axis=1)
        return fit, failed

    def close(self) -> None:
        """Stop the actors (and the cluster, if this started it)."""
        for a in self._actors:
            self._ray.kill(a)
        self._actors = []
        self._cluster.close()


class _Slices:
    # a Ray actor: a one-thread objective of the protocol, simulating the slices it is given
    def __init__(self, protocol: Protocol, ideal: bool) -> None:
        _init_worker()
        self.objective = PopulationObjective(protocol, ideal=ideal, workers=1)

    def simulate(self, x: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
        return self.objective._simulate(x)

