"""A batch's members on threads: contiguous parts of the batch, one compiled call each.

The servo loop's and the env's kernels run members ``lo:hi`` on the scratch of one part and
hold no GIL (:func:`contour_gym._loopkernel.run_ticks`), so the parts of a batch run at once on
threads. A member's results do not depend on its part: the same seed gives the same numbers,
bit for bit, for any number of threads. The threads come from one pool shared by every loop
(grown when a loop asks for more); the calling thread runs the first part itself.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")
Part = tuple[int, int, int]  # (lo, hi, part): members lo:hi on scratch ``part``

# members per thread below which a batch runs on one thread by default: measured with
# benchmarks/scaling.py (vector env rows, CCC-v1, 10 ticks a step) on a 2-core machine, two
# threads against one: 0.61x at B = 16, 0.89x at 32, 1.16x at 64, 1.44x at 128, 1.84x at 1024
# (the serial Python of a step and a thread hand-off weigh less as the batch grows)
MIN_MEMBERS_PER_THREAD = 32

THREADS_VARIABLE = "CONTOUR_GYM_THREADS"
_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_pool_size = 0


def available_cpus() -> int:
    """CPUs this process may run on (its affinity where the OS tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def default_threads(batch: int) -> int:
    """Threads a batch of ``batch`` members runs on by default: every CPU, when it pays.

    One thread per :data:`MIN_MEMBERS_PER_THREAD` members at most, never more than the CPUs
    this process may use, nor than the environment variable ``CONTOUR_GYM_THREADS`` says (a
    worker process of :mod:`agents.parallel` sets it to 1: its cores are the other workers').
    """
    cap = available_cpus()
    given = os.environ.get(THREADS_VARIABLE, "").strip()
    if given.isdigit() and int(given) >= 1:
        cap = min(cap, int(given))
    return max(1, min(cap, batch // MIN_MEMBERS_PER_THREAD))


def check_threads(threads: int | None, batch: int) -> int:
    """The threads a batch runs on: ``threads`` (at most one per member), None: the default.

    Raises:
        ValueError: for ``threads`` that is not a positive int.
    """
    if threads is None:
        return default_threads(batch)
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"num_threads must be a positive int or None, got {threads!r}")
    return min(threads, batch)


def split(batch: int, threads: int) -> tuple[Part, ...]:
    """``threads`` contiguous parts of ``batch`` members, as even as can be (sizes differ by 1)."""
    base, extra = divmod(batch, threads)
    parts, lo = [], 0
    for j in range(threads):
        hi = lo + base + (j < extra)
        parts.append((lo, hi, j))
        lo = hi
    return tuple(parts)


def _executor(workers: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _lock:
        if _pool is None or _pool_size < workers:
            old, _pool, _pool_size = _pool, ThreadPoolExecutor(workers, "contour-gym"), workers
            if old is not None:
                old.shutdown(wait=False)
        return _pool


def run_parts(call: Callable[[int, int, int], T], parts: tuple[Part, ...]) -> list[T]:
    """``call(lo, hi, part)`` for every part, the first on this thread; results in part order.

    Every part runs to its end before an error of any part is raised.
    """
    if len(parts) == 1:
        return [call(*parts[0])]
    futures = [_executor(len(parts) - 1).submit(call, *p) for p in parts[1:]]
    first: list[T] = []
    error: BaseException | None = None
    try:
        first.append(call(*parts[0]))
    except BaseException as exc:  # the others finish first: they write the same blobs
        error = exc
    rest = []
    for future in futures:
        try:
            rest.append(future.result())
        except BaseException as exc:
            error = error or exc
    if error is not None:
        raise error
    return first + rest
