"""Units of work on every core, or on a Ray cluster: one interface for bench, tune and train.

A command cuts its work into independent *units* (a bench cell, a training run, a slice of a
tuning population), each a picklable call ``fn(item)`` whose result depends on ``item`` alone.
:func:`runner` gives the place they run:

- ``workers=1``: in this process, one after another (what every command did before);
- ``workers=N > 1``: this process and ``N - 1`` worker processes on this machine
  (forked while no thread but the main one runs and torch is not imported, else spawned:
  :func:`start_method`; one torch and BLAS thread each);
- ``ray=ADDRESS``: Ray tasks on a cluster (``"auto"``: the cluster this machine belongs to;
  ``"local"``: start a local one with ``workers`` CPUs; ``"HOST:PORT"``: that head). A task
  whose worker or node dies is retried elsewhere (:data:`RAY_RETRIES`); a unit's own
  exception is not retried (it would fail again), it is raised.

Results arrive as units finish (:meth:`Runner.map` yields ``(index, result)``), so a command
saves each one at once (its run folder resumes after an interruption); they equal a serial
run's bit for bit, because each unit seeds itself from its own item.

Ray is an optional extra (``pip install "contour-gym[ray]"``); without it ``ray=...`` raises
:class:`ValueError` saying how to install it.
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import ctypes
import functools
import gc
import importlib
import multiprocessing
import os
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import (
    FIRST_COMPLETED,
    Executor,
    Future,
    ProcessPoolExecutor,
    ThreadPoolExecutor,
    wait,
)
from typing import Any, TypeVar

from agents import MKL_MODE
from contour_gym.loop.threads import THREADS_VARIABLE, available_cpus

T = TypeVar("T")
R = TypeVar("R")

RAY_RETRIES = 3  # a unit whose Ray worker or node died runs again up to this many times
RAY_HINT = 'Ray is not installed: pip install "contour-gym[ray]" (or pip install "ray[tune]")'
_PR_SET_PDEATHSIG = 1  # linux/prctl.h
_SINGLE_THREADED = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                    THREADS_VARIABLE: "1"}


def _worker_environment() -> dict[str, str]:
    # what a Ray worker runs with: one thread, and MKL's mode as this process has it (agents)
    mode = {MKL_MODE: os.environ[MKL_MODE]} if MKL_MODE in os.environ else {}
    return {**_SINGLE_THREADED, **mode}


WORKERS_PER_CPU = 2  # worker processes on this machine at most, per CPU it may use


def resolve_workers(workers: int | None) -> int:
    """``workers`` checked (None: every CPU this process may use).

    Raises:
        ValueError: for anything but a positive int or None, or more than
            :data:`WORKERS_PER_CPU` per CPU this process may use (each worker is a process
            of its own; more of them than cores only share the cores).
    """
    if workers is None:
        return available_cpus()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be a positive int, got {workers!r}")
    cpus = available_cpus()
    if workers > WORKERS_PER_CPU * cpus:
        raise ValueError(f"workers {workers} is more than {WORKERS_PER_CPU} per CPU of this "
                         f"machine ({cpus} CPUs: at most {WORKERS_PER_CPU * cpus}): lower "
                         "--workers")
    return workers


class Runner:
    """Where units run: in this process (this class), or :class:`Processes`, :class:`RayRunner`.

    Attributes:
        workers: Units that run at once.
        shares_files: Whether the units see this machine's files (a unit may write a run
            folder's files itself).
    """

    workers = 1
    shares_files = True

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[int, R]]:
        """``(i, fn(items[i]))`` for every item, as each finishes (here: in order).

        The first unit that raises stops the run: the error is raised once the units already
        running have finished (their results are yielded first).
        """
        for i, item in enumerate(items):
            yield i, fn(item)

    def warm(self, *modules: str) -> None:
        """Start the workers now, each importing ``modules``: their start overlaps the caller's.

        A no-op here (this process imports what it uses when it uses it).
        """

    def close(self) -> None:
        """Release the workers (a no-op here)."""

    def __enter__(self) -> Runner:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def describe(self) -> str:
        """Where the units run, in a few words."""
        return "this process"


def _torch_threads(n: int | None) -> int | None:
    # set torch's intra-op threads to n if torch is imported (None: leave them); the old count
    torch = sys.modules.get("torch")
    if torch is None or n is None:
        return None
    old = int(torch.get_num_threads())
    torch.set_num_threads(n)
    return old


def _one_thread() -> Callable[[], None]:
    """This process's BLAS (numpy's, scipy's OpenBLAS) and torch on one thread; the undo.

    For a process that is one of several workers: the cores are the workers'. The variables of
    ``_SINGLE_THREADED`` reach only libraries loaded after they are set, and a spawned worker
    has loaded numpy's OpenBLAS before its initializer runs (it imports the parent's main
    module first), so the limit is set at run time (``threadpoolctl``): OpenBLAS threads
    spinning between calls would take the other core from the other worker.
    """
    from threadpoolctl import threadpool_limits

    section = [_torch_threads(1)]  # torch's threads before (None: not imported yet)
    limits = threadpool_limits(1)
    _SECTIONS.append(section)

    def undo() -> None:
        _SECTIONS.remove(section)
        limits.restore_original_limits()
        _torch_threads(section[0])

    return undo


# this process's one-thread sections (:func:`_one_thread`), each with torch's thread count
# from before it (None: torch was not imported when it began)
_SECTIONS: list[list[int | None]] = []


def limit_new_torch() -> None:
    """Put torch on one thread if it was imported inside a unit's one-thread section.

    For code that imports torch on demand (a saved agent reads its model when it first acts):
    torch loaded after :func:`_one_thread` began would run on every core beside the other
    units; the section's end gives torch its own count back. A no-op outside a section or
    without torch.
    """
    if "torch" not in sys.modules:
        return
    for section in _SECTIONS:
        if section[0] is None:
            section[0] = _torch_threads(1)


@functools.cache  # once per process
def exit_quickly() -> None:
    """Skip the interpreter's last garbage collection when this process exits.

    For a command's process and its workers only: at exit, after the other exit handlers,
    everything left is frozen (:func:`gc.freeze`), so the final collection does not walk
    torch's, numba's and matplotlib's objects; the memory goes back to the system as the
    process ends: ``contour-gym bench`` (default suite, warm, one worker) ends 0.18 s after its
    command returns, where the collection takes 1.3-1.45 s. What a command writes is closed
    before it returns (:mod:`agents._files`), so nothing waits on a collection.
    """
    # exit handlers run last registered first: this one after those the command registers
    atexit.register(gc.freeze)


def start_method() -> str:
    """How worker processes start: ``"fork"`` while that is safe, else ``"spawn"``.

    A forked worker begins with what this process has imported (agents, numba's kernels
    read so far): none of a spawned worker's new interpreter and imports. Forking is safe
    while this process runs no thread of its own but this one (a lock another thread held
    would stay held in the worker: a background compile, tqdm's monitor, a unit thread) and
    has not imported torch (whose OpenMP pool does not survive a fork); numpy's OpenBLAS
    threads stop and restart around a fork by themselves. Linux only (macOS: spawn, as its
    system libraries ask). The default bench suite on two workers takes 8.85 s forked against
    9.50 s spawned (medians of four).
    """
    safe = threading.active_count() == 1 and "torch" not in sys.modules
    return "fork" if safe and sys.platform.startswith("linux") else "spawn"


def die_with_parent(parent: int) -> None:
    """End this worker process when process ``parent`` ends (Linux; elsewhere nothing).

    A pool's worker waits for work from its parent; if the parent is killed (by the kernel
    out of memory, or ``kill -9``) it would wait for ever. The kernel sends it SIGTERM when its
    parent's thread that started it ends (``prctl(PR_SET_PDEATHSIG)``: a pool is started and used
    by one thread); a parent gone before that is checked.
    """
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
    except (OSError, AttributeError):  # no libc prctl: the worker lives as before
        return
    if os.getppid() != parent:  # the parent ended before the request
        os._exit(1)


def _init_worker(*modules: str, filters: list[Any] | None = None, parent: int = 0) -> None:
    # a worker process: one thread for torch and BLAS (the cores are the workers'), no
    # background compiles (contour_gym.jit.tiers: the parent compiled up front); ``modules``
    # imported at once; the parent's warning filters (a command's own, e.g. the CLI's); it
    # ends with its parent
    if parent:
        die_with_parent(parent)
    if filters is not None:
        warnings.resetwarnings()
        for action, message, category, module, lineno in reversed(filters):
            warnings.filterwarnings(action, getattr(message, "pattern", message) or "",
                                    category, getattr(module, "pattern", module) or "",
                                    lineno)
    os.environ.update(_SINGLE_THREADED)
    os.environ.setdefault("CONTOUR_GYM_BACKGROUND", "0")
    exit_quickly()
    for name in modules:
        importlib.import_module(name)
    _one_thread()  # for the worker's life (torch, imported by a unit that needs it: one thread)


class Processes(Runner):
    """``workers`` at once: this process (on a thread) and ``workers - 1`` worker processes.

    This process takes units at once, while the workers start (:func:`start_method`: forked,
    with this process's imports, or spawned, each a new interpreter that imports what the
    units need: 2-4 s for a bench scenario's); the workers take units
    once they have started, and each slot takes the next unit when it is free. A run whose
    units are all done before the workers have started stops them instead of waiting for
    them, so a small run is no slower on two workers than on one.
    """

    wait_for_workers = False  # True: map waits for the workers to start (tests use them)

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None
        self._modules: tuple[str, ...] = ()
        self._started: Future[Any] | None = None  # done once the workers have started

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            context = multiprocessing.get_context(start_method())
            start = functools.partial(_init_worker, filters=list(warnings.filters),
                                      parent=os.getpid())
            self._pool = ProcessPoolExecutor(self.workers - 1, mp_context=context,
                                             initializer=start, initargs=self._modules)
        return self._pool

    def warm(self, *modules: str) -> None:
        """Start the worker processes now, each importing ``modules`` as it starts."""
        if self._pool is None:
            self._modules = modules
            # a spawn pool starts every worker on its first task; done once they are up
            self._started = self._executor().submit(int)

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[int, R]]:
        """As :meth:`Runner.map`: results as they finish, on this process and the workers."""
        if not items:
            return
        todo = collections.deque(enumerate(items))
        running: dict[Future[R], tuple[int, Executor]] = {}

        def submit(where: Executor) -> None:
            i, item = todo.popleft()
            running[where.submit(fn, item)] = (i, where)

        self.warm()
        starting = self._started  # the workers take units once they are up
        if self.wait_for_workers and starting is not None:
            wait([starting])
        here = ThreadPoolExecutor(1, "contour-gym-unit")
        undo = _one_thread()  # one core per unit here too (as in the workers)
        submit(here)  # this process starts at once
        error: BaseException | None = None
        try:
            while running and error is None:
                watch = set(running) if starting is None else {*running, starting}
                done, _ = wait(watch, return_when=FIRST_COMPLETED)
                if starting is not None and starting in done:
                    error = starting.exception()
                    for _ in range(self.workers - 1):
                        if todo and error is None:
                            submit(self._executor())
                    done.discard(starting)
                    starting = None
                for future in sorted(done, key=lambda f: running[f][0]):
                    i, where = running.pop(future)
                    exc = future.exception()
                    if exc is not None:
                        error = error or exc
                        continue
                    if todo and error is None:
                        submit(where)
                    yield i, future.result()
        finally:
            for future in running:
                future.cancel()
            here.shutdown(wait=True)  # a unit running here finishes first
            undo()
        if error is not None:
            raise error

    def close(self) -> None:
        """Stop the worker processes (at once if they are still starting: they ran nothing)."""
        if self._pool is not None:
            if self._started is not None and not self._started.done():
                for process in list(getattr(self._pool, "_processes", {}).values()):
                    process.terminate()
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool, self._started = None, None

    def describe(self) -> str:
        """Where the units run, in a few words."""
        return f"this process and {self.workers - 1} worker process(es)"


class RayRunner(Runner):
    """Units as Ray tasks (one CPU each) on the cluster at ``address``.

    Args:
        address: ``"auto"``, ``"HOST:PORT"`` of a running cluster's head (``ray://...`` for
            Ray Client), or ``"local"``/None: start a local cluster of ``workers`` CPUs (on
            127.0.0.1, stopped by :meth:`close`).
        workers: CPUs of a local cluster (None: every CPU); ignored for a running cluster.

    Raises:
        ValueError: when Ray is not installed (saying how to install it).
    """

    def __init__(self, address: str | None, workers: int | None = None) -> None:
        ray = import_ray()
        self._started = not ray.is_initialized()
        if self._started:
            if address in (None, "local"):
                loopback_only(ray)
                ray.init(num_cpus=resolve_workers(workers), include_dashboard=False,
                         log_to_driver=False, runtime_env={"env_vars": _worker_environment()})
            else:
                ray.init(address=address, log_to_driver=False,
                         runtime_env={"env_vars": _worker_environment()})
        self.address = address or "local"
        self.shares_files = False  # nodes may be other machines
        self.workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._ray = ray

    def map(self, fn: Callable[[T], R], items: Sequence[T]) -> Iterator[tuple[int, R]]:
        """As :meth:`Runner.map`, each unit a Ray task (retried if its worker or node dies)."""
        ray = self._ray
        remote = ray.remote(num_cpus=1, max_retries=RAY_RETRIES, retry_exceptions=False)(
            _call)
        refs = {remote.remote(fn, item): i for i, item in enumerate(items)}
        pending, error = list(refs), None
        try:
            while pending and error is None:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    try:
                        yield refs[ref], ray.get(ref)
                    except ray.exceptions.RayTaskError as exc:
                        error = error or exc.as_instanceof_cause()
        finally:
            for ref in pending:
                ray.cancel(ref)
        if error is not None:
            raise error

    def close(self) -> None:
        """Disconnect (and stop the cluster if this runner started it)."""
        if self._started:
            self._ray.shutdown()
            self._started = False

    def describe(self) -> str:
        """Where the units run, in a few words."""
        return f"Ray cluster {self.address} ({self.workers} CPUs)"


def _call(fn: Callable[[T], R], item: T) -> R:
    # a Ray task: the unit in a worker that threads torch and BLAS once
    _init_worker()
    return fn(item)


def import_ray() -> Any:
    """The ``ray`` module.

    Raises:
        ValueError: when Ray is not installed, saying how to install it.
    """
    try:
        import ray
    except ImportError as exc:
        raise ValueError(RAY_HINT) from exc
    return ray


def loopback_only(ray: Any) -> None:
    """Make the Ray clusters this process starts listen on 127.0.0.1 only.

    Ray takes a node's address from the network unless told that clusters are off
    (``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``, read at import: set here for this process and the
    processes it starts); a node then binds every server to 127.0.0.1 (Ray 2.60: checked with
    ``ss -ltnp`` on a two-node :func:`local_cluster`).
    """
    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    ray._private.ray_constants.ENABLE_RAY_CLUSTER = False


@contextlib.contextmanager
def local_cluster(nodes: int = 2, cpus_per_node: int = 1, **head: Any) -> Iterator[Any]:
    """A Ray cluster of ``nodes`` nodes on this machine, on 127.0.0.1 only, for its block.

    Each node is a raylet of its own (the head also runs the GCS), as separate machines'
    would be; :meth:`ray.cluster_utils.Cluster.remove_node` kills one (a node dying mid-run).
    Yields the :class:`ray.cluster_utils.Cluster` (``.address`` is the head's); stopped at
    the block's end.

    Args:
        nodes: Nodes, the head included.
        cpus_per_node: CPUs each node offers.
        **head: More arguments of the head node (e.g. ``_system_config``).

    Raises:
        ValueError: when Ray is not installed.
    """
    ray = import_ray()
    loopback_only(ray)
    from ray.cluster_utils import Cluster

    cluster = Cluster(initialize_head=True, head_node_args={
        "num_cpus": cpus_per_node, "include_dashboard": False, **head})
    try:
        for _ in range(nodes - 1):
            cluster.add_node(num_cpus=cpus_per_node)
        cluster.wait_for_nodes()
        yield cluster
    finally:
        if ray.is_initialized():
            ray.shutdown()
        cluster.shutdown()


def runner(workers: int | None = None, ray: str | None = None) -> Runner:
    """Where a command's units run: ``ray`` set -> :class:`RayRunner`, else by ``workers``.

    Args:
        workers: Worker processes on this machine (None: every CPU; 1: this process).
        ray: A Ray address (``"auto"``, ``"HOST:PORT"``, ``"local"``: see :class:`RayRunner`).

    Raises:
        ValueError: for a bad ``workers``, or ``ray`` without Ray installed.
    """
    n = resolve_workers(workers)
    if ray is not None:
        return RayRunner(ray, n if workers is not None else None)
    return Runner() if n == 1 else Processes(n)
