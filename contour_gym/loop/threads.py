"""A batch's members on threads: contiguous parts of the batch, one compiled call each.

The servo loop's and the env's kernels run members ``lo:hi`` on the scratch of one part and
hold no GIL (:func:`contour_gym.loop.kernel.run_ticks`), so the parts of a batch run at once on
threads. A member's results do not depend on its part: the same seed gives the same numbers,
bit for bit, for any number of threads. The threads come from one pool shared by every loop
(grown when a loop asks for more); the calling thread runs the first part itself.

Where a second thread starts to pay depends on the work per member and call, so a batch left
to the default threads is timed on both and keeps the faster (:class:`ThreadChoice`).
"""

from __future__ import annotations

import os
import statistics
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")
Part = tuple[int, int, int]  # (lo, hi, part): members lo:hi on scratch ``part``

# members per thread below which a batch runs on one thread by default; from twice this, the
# default's threads are tried against one thread and the faster kept (ThreadChoice): where
# two threads start to pay differs by machine (docs/measurements.md, "Threads per batch")
MIN_MEMBERS_PER_THREAD = 16

THREADS_VARIABLE = "CONTOUR_GYM_THREADS"
TRIALS = 5  # timed calls of each choice before ThreadChoice keeps one
RECHECK = 256  # calls after which ThreadChoice tries both again
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


class ThreadChoice:
    """Parts of a batch chosen by timing: one thread, or the default's threads, the faster.

    Two threads pay from 80 members of 000's machine in the CCC env, from under 48 of 002's
    (docs/parallel.md), so a fixed count of members per thread loses on some envs. A batch
    whose threads were left to the default, with more than one, is run alternately on one
    thread and on all of them; after :data:`TRIALS` timed calls of each (the first call aside:
    it may load the kernel), it keeps the one with the fewer seconds per tick (medians), and
    tries both again every :data:`RECHECK` calls: a run's first calls (members getting up to
    speed) may not cost what its later ones do. The numbers do not depend on it: a member's
    results do not depend on its part.

    Args:
        parts: The default's parts (:func:`split`), more than one.

    Attributes:
        kept: The parts chosen (None while on trial).
    """

    def __init__(self, parts: tuple[Part, ...]) -> None:
        self.many = parts
        self.one = split(parts[-1][1], 1)
        self.kept: tuple[Part, ...] | None = None
        self._seconds: dict[int, list[float]] = {1: [], len(parts): []}
        self._calls = 0  # since the trials began (or since kept)

    def parts(self) -> tuple[Part, ...]:
        """The parts the next call runs on (on trial: all of them first, then one and all)."""
        if self.kept is not None:
            return self.kept
        return self.one if self._calls % 2 else self.many

    def record(self, parts: tuple[Part, ...], seconds: float, ticks: int) -> None:
        """Note a call on ``parts`` that ran ``ticks`` ticks in ``seconds``."""
        self._calls += 1
        if self.kept is not None:
            if self._calls >= RECHECK:
                self.kept, self._calls = None, 0
                for times in self._seconds.values():
                    times.clear()
            return
        if self._calls == 1 or ticks < 1:
            return
        self._seconds[len(parts)].append(seconds / ticks)
        if min(len(v) for v in self._seconds.values()) < TRIALS:
            return
        one = statistics.median(self._seconds[1])
        many = statistics.median(self._seconds[len(self.many)])
        self.kept, self._calls = (self.one if one <= many else self.many), 0
