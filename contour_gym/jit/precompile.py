"""Compile the built-in kernels up front, in worker processes, with a progress bar.

A *warm-up* is a small run that makes numba compile (and cache) one group of kernels: the
servo loop of the built-in components, the env step on it, and whatever a plugin package
registers. :func:`compile_builtins` runs the warm-ups not yet done in worker processes, as
many at a time as there are workers and their order allows, while the terminal shows what
compiles, how many are left and the time so far; the calling process then loads everything
from numba's cache. A warm-up done is remembered by a
marker file in the cache folder, keyed by the package's kernel digest and the plugins, so the
next run starts at once. Workers are fresh interpreters calling :func:`main` (never forked:
the caller may hold threads and numba's locks; never multiprocessing's spawn: it re-runs the
user's script).
"""

from __future__ import annotations

import hashlib
import importlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO

import numba

from contour_gym import jit
from contour_gym._registry import Registry
from contour_gym.jit.cache import locked
from contour_gym.jit.progress import Line
from contour_gym.jit.stack import on_reserved_stack

IN_WORKER = "CONTOUR_GYM_COMPILE_WORKER"  # set in the workers: they compile in-process
LAST_SECONDS: dict[str, float] = {}  # wall seconds of each warm-up this process ran


@dataclass(frozen=True)
class Warmup:
    """One group of kernels and how to make numba compile them.

    Attributes:
        name: Registry key (letters, digits, ``_``).
        target: ``"module:function"``, a function without arguments that runs the kernels on
            tiny inputs (imported and called in a worker process).
        after: Warm-ups whose kernels this one calls (they run first).
        doc: What it compiles, in a few words (the progress bar shows it).
        seconds: About how long it takes on one core of a 2-core machine (the first-run
            message adds these up as the workers would run them).
    """

    name: str
    target: str
    after: tuple[str, ...] = ()
    doc: str = field(default="", compare=False)
    seconds: float = field(default=10.0, compare=False)


WARMUPS: Registry[Warmup] = Registry("warm-up")


def register_warmup(warmup: Warmup, *, replace: bool = False) -> Warmup:
    """Register a warm-up (see the module docstring); returns it."""
    for dep in warmup.after:
        WARMUPS.get(dep)
    return WARMUPS.register(warmup, replace=replace)


def _marker(name: str) -> Path:
    key = hashlib.sha1(
        "|".join((jit.current_digest(), *jit.builtin_packages(), name)).encode()
    ).hexdigest()[:16]
    return jit.generated_dir() / f"warm_{name}_{key}.done"


def is_done(name: str) -> bool:
    """Whether warm-up ``name`` and its prerequisites are done (their kernels cached)."""
    return name in _ENSURED or not pending([name])


def pending(names: Sequence[str] | None = None) -> list[str]:
    """The warm-ups among ``names`` (default: all) and their prerequisites not yet done."""
    jit.builtin_packages()  # plugins register their warm-ups on import
    todo: list[str] = []

    def visit(name: str) -> None:
        warm = WARMUPS.get(name)
        for dep in warm.after:
            visit(dep)
        if name not in todo and not _marker(name).exists():
            todo.append(name)

    for name in WARMUPS.names() if names is None else names:
        visit(name)
    return todo


def run_warmup(name: str, target: str | None = None) -> float:
    """Run warm-up ``name`` in this process (``target``: its own), mark it done; seconds."""
    start = time.perf_counter()
    module, _, func = (target or WARMUPS.get(name).target).partition(":")
    fn: Callable[[], object] = getattr(importlib.import_module(module), func)
    fn()
    _marker(name).touch()
    return time.perf_counter() - start


def _spawn(name: str, errors: IO[str]) -> subprocess.Popen[str]:
    # a fresh interpreter (never multiprocessing: its spawn re-runs the user's __main__); its
    # error output to a file (a pipe read only at the end could fill and stall the worker)
    env = dict(os.environ, **{IN_WORKER: "1"})
    cache = str(getattr(numba.config, "CACHE_DIR", "") or "")
    if cache:
        env["NUMBA_CACHE_DIR"] = cache
    code = "import sys; from contour_gym.jit.precompile import main; main(*sys.argv[1:])"
    return subprocess.Popen(
        [sys.executable, "-c", code, name, WARMUPS.get(name).target], env=env,
        stdout=subprocess.DEVNULL, stderr=errors, text=True,
    )


def compile_builtins(
    names: Sequence[str] | None = None, workers: int | None = None, progress: bool = True
) -> list[str]:
    """Compile the kernels of the warm-ups ``names`` (default: all) not compiled yet.

    Args:
        names: Warm-up names (:data:`WARMUPS`); their prerequisites are included.
        workers: Worker processes at a time (default: every core).
        progress: Show a progress bar on stderr.

    Returns:
        The warm-ups that were run (empty when everything was compiled before).

    Raises:
        RuntimeError: when a warm-up fails (with its error output).
    """
    if os.environ.get(IN_WORKER):
        return []  # a worker compiles in its own process, by running its warm-up
    if not pending(names):
        return []
    with locked(jit.generated_dir() / "compile.lock"):  # one compiling process per folder
        todo = pending(names)  # another process may have compiled them meanwhile
        if todo:
            _run_all(todo, max(1, workers or os.cpu_count() or 1), progress)
    return todo


def _by_priority(todo: Sequence[str]) -> list[str]:
    # longest chain of work through a warm-up's dependents first (critical path scheduling)
    def chain(name: str) -> float:
        after = [w for w in todo if name in WARMUPS.get(w).after]
        return WARMUPS.get(name).seconds + max(map(chain, after), default=0.0)

    return sorted(todo, key=chain, reverse=True)


def _run_all(todo: list[str], workers: int, progress: bool) -> None:
    bar = _Bar(todo, expected_seconds(todo, workers)) if progress else None
    running: dict[str, subprocess.Popen[str]] = {}
    started: dict[str, float] = {}
    errors: dict[str, IO[str]] = {}
    waiting = _by_priority(todo)
    try:
        while waiting or running:
            for name in [w for w in waiting if _ready(w, waiting, running)]:
                if len(running) >= workers:
                    break
                waiting.remove(name)
                # closed when read, or in the finally clause below
                errors[name] = tempfile.TemporaryFile("w+", encoding="utf-8")  # noqa: SIM115
                running[name] = _spawn(name, errors[name])
                started[name] = time.perf_counter()
                if bar:
                    bar.start(name)
            time.sleep(0.2)
            for name, proc in list(running.items()):
                if proc.poll() is None:
                    continue
                del running[name]
                LAST_SECONDS[name] = time.perf_counter() - started[name]
                with errors.pop(name) as handle:
                    handle.seek(0)
                    err = handle.read()
                if proc.returncode != 0 or not _marker(name).exists():
                    raise RuntimeError(f"compiling the {name!r} kernels failed "
                                       f"(exit code {proc.returncode}):\n{err}")
                if bar:
                    bar.finish(name)
    finally:
        for proc in running.values():
            proc.kill()
        for handle in errors.values():
            handle.close()
        if bar:
            bar.line.close()


def _ready(name: str, waiting: list[str], running: Mapping[str, object]) -> bool:
    return not any(d in waiting or d in running for d in WARMUPS.get(name).after)


def expected_seconds(todo: Sequence[str], workers: int) -> float:
    """Wall time the warm-ups ``todo`` should take on ``workers`` (as :func:`_run_all` runs)."""
    clock, waiting = 0.0, _by_priority(todo)
    running: dict[str, float] = {}  # name -> end time
    while waiting or running:
        for name in [w for w in waiting if _ready(w, waiting, running)]:
            if len(running) >= workers:
                break
            waiting.remove(name)
            running[name] = clock + WARMUPS.get(name).seconds
        if not running:  # pragma: no cover - a cycle (registration forbids unknown deps)
            raise ValueError(f"warm-ups {waiting} wait on each other")
        first = min(running, key=running.__getitem__)
        clock = running.pop(first)
    return clock


_ENSURED: set[str] = set()


def ensure(*names: str) -> None:
    """Compile the warm-ups ``names`` unless done (cheap after the first call per process)."""
    if set(names) <= _ENSURED:
        return
    compile_builtins(names)
    _ENSURED.update(names)


class _Bar:
    """The progress bar: warm-ups done of all, the ones compiling now, the time so far."""

    def __init__(self, todo: list[str], expected: float) -> None:
        self.running: list[str] = []
        about = f"about {expected:.0f} s" if expected < 120 else f"about {expected / 60:.0f} min"
        desc = f"contour-gym: compiling kernels, first run only ({about} on 2 cores)"
        self.line = Line(desc, "{desc}: {n}/{total} groups [{elapsed}] {postfix}", len(todo))

    def start(self, name: str) -> None:
        self.running.append(name)
        self._show()

    def finish(self, name: str) -> None:
        self.running.remove(name)
        self.line.bar.update(1)
        self._show()

    def _show(self) -> None:
        now = ", ".join(WARMUPS.get(n).doc or n for n in self.running)
        self.line.show(f"now: {now}" if now else "", refresh=True)


# --------------------------------------------------------------------------------------
# the package's own warm-ups
# --------------------------------------------------------------------------------------
# seconds: each group alone in a worker process on a 2-core machine (the built-ins' kernels),
# for the progress bar's estimate; the loop then the env step is the longest chain. The
# searches and estimators a kernel calls compile with it, whatever is cached (contour_gym.jit), so
# only the env step waits: it calls the loop's kernels
register_warmup(Warmup("loop", "contour_gym.jit.warmups:servo_loop", doc="servo loop",
                       seconds=41.0))
register_warmup(Warmup("path_api", "contour_gym.jit.warmups:path_api",
                       doc="path searches for plots", seconds=8.0))
register_warmup(Warmup("env", "contour_gym.jit.warmups:env_step", after=("loop",),
                       doc="env step", seconds=20.0))
register_warmup(Warmup("estimators", "contour_gym.jit.warmups:estimators",
                       doc="estimator API", seconds=13.0))
register_warmup(Warmup("axes", "contour_gym.jit.warmups:axes",
                       doc="axis controllers and single-axis plant", seconds=5.0))


def main(name: str, target: str) -> None:
    """A worker's entry point: load the plugins, run warm-up ``name`` (its ``target``)."""
    jit.builtin_packages()  # the plugins' components
    on_reserved_stack(run_warmup, name, target)
