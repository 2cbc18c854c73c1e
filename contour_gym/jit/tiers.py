"""Which compiled kernel a run of built-in components uses: its own, or the built-ins' one.

Two kernels can run any combination of built-in components (:func:`contour_gym.jit.bind`):

* the **built-ins' kernel** dispatches every built-in component by a code. It compiles once
  per installation (:mod:`contour_gym.jit.precompile`, ~70 s on 2 cores) and then runs every new
  combination at once;
* the run's **own kernel** is bound to just the components the run uses. It runs ~10 % faster
  (the built-ins' kernel carries every component's code inline: twice the machine code of the
  loop's tick) and compiles in half the time, but there is one per combination.

Both compute the same numbers, bit for bit (``tests/test_compile_once.py``). :func:`choose`
picks, per run:

1. the run's own kernel once it is compiled (and cached);
2. else the built-ins' kernel if that is compiled, while the run's own kernel compiles in a
   background process for the next run of the same combination;
3. else (a fresh installation) the run's own kernel, compiled here (the first result comes
   sooner than the built-ins' kernel could); once it is compiled (:func:`start_pending`), the
   built-ins' kernel compiles in the background for the combinations that follow.

Background compiles are detached, low-priority processes (``nice`` 19). At most one per
warm-up and one of runs' own kernels run at a time (a request while one runs is dropped; the
next run asks again). Set ``CONTOUR_GYM_BACKGROUND=0`` to turn them off.
"""

from __future__ import annotations

import functools
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Protocol

import numba

from contour_gym import jit
from contour_gym.jit import precompile
from contour_gym.jit.cache import locked
from contour_gym.jit.stack import on_reserved_stack

BACKGROUND = "CONTOUR_GYM_BACKGROUND"  # "0": no background compiles
OWN_WORKER = "own"  # IN_WORKER's value in a process compiling a run's own kernel


class CompilesOwn(Protocol):
    """An object whose kernels can be compiled by running it once (a loop, an env task)."""

    def compile_own(self) -> None:
        """Run once on the run's own kernels (in a background worker, after unpickling)."""


def choose(
    own: ModuleType, builtins: Callable[[], ModuleType], warmup: str, owner: CompilesOwn
) -> ModuleType:
    """The kernel module a run uses (module docstring).

    Args:
        own: The run's own kernel module (:func:`jit.specialise` of its components).
        builtins: Makes the built-ins' kernel module (called only if that one is chosen).
        warmup: The warm-up that compiles the built-ins' kernel (``jit.precompile``).
        owner: What to compile in the background when the run's own kernel is not compiled:
            pickled and run once by a worker (:meth:`CompilesOwn.compile_own`).
    """
    worker = os.environ.get(precompile.IN_WORKER)
    if worker == OWN_WORKER or not jit.needs_compile(own):
        return own
    if worker:  # a warm-up worker: it compiles the built-ins' kernel
        return builtins()
    if precompile.is_done(warmup):
        _compile_own_later(owner)
        return builtins()
    _PENDING.add(warmup)  # started once this run's own kernel has compiled (start_pending)
    return own


_PENDING: set[str] = set()  # warm-ups to compile in the background after this run's compile


def start_pending() -> None:
    """Start the background compiles :func:`choose` deferred (after a first call compiled).

    Deferred so that they do not share the cores with the compile a user is waiting for.
    """
    while _PENDING:
        _compile_builtins_later(_PENDING.pop())


def _enabled() -> bool:
    return os.environ.get(BACKGROUND, "1") != "0"


def _compile_builtins_later(warmup: str) -> None:
    if _enabled():
        what = f"the built-in components' kernels ({precompile.WARMUPS.get(warmup).doc})"
        _detach("_builtins_main", warmup, f"builtins_{warmup}", what)


def _compile_own_later(owner: CompilesOwn) -> None:
    if not _enabled() or _busy(_lock("own")):  # busy: not worth pickling the request
        return
    try:
        data = pickle.dumps(owner)
    except Exception:  # noqa: BLE001 - e.g. a Python reward defined in a script: no own kernel
        return
    fd, path = tempfile.mkstemp(suffix=".pkl", dir=jit.generated_dir())
    with os.fdopen(fd, "wb") as handle:
        handle.write(data)
    env = {precompile.IN_WORKER: OWN_WORKER}
    if not _detach("_own_main", path, "own", "this combination's own, faster kernel", env):
        os.unlink(path)


def _detach(
    func: str, arg: str, slot: str, what: str, env: dict[str, str] | None = None
) -> bool:
    """Start ``tiers.func(arg, held)`` in a detached, niced interpreter unless ``slot`` is busy.

    ``held``: whether the process got the slot's lock (two requests may pass the probe at
    once; the one without the lock only cleans up). The process stops by itself once the
    cache folder it compiles into is gone (:func:`_watch`); stderr says what runs and how to
    stop it (``what``: what it compiles).
    """
    lock = _lock(slot)
    if _busy(lock):
        return False
    full = dict(os.environ, **(env or {}))
    cache = str(getattr(numba.config, "CACHE_DIR", "") or "")
    if cache:
        full["NUMBA_CACHE_DIR"] = cache
    script = "\n".join([
        "import os", "os.nice(19)", "from contour_gym.jit import tiers",
        f"tiers._watch({str(jit.generated_dir())!r})",
        f"with tiers.locked({str(lock)!r}, wait=False) as held:",
        f"    tiers.{func}({arg!r}, held)",
    ])
    process = subprocess.Popen(
        [sys.executable, "-c", script], env=full, stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )
    print(f"contour-gym: compiling {what} in the background for the runs that follow "
          f"(pid {process.pid}, low priority; it ends by itself; `kill {process.pid}` stops "
          f"it, {BACKGROUND}=0 turns this off)", file=sys.stderr, flush=True)
    return True


WATCH_SECONDS = 1.0  # how often a background process checks that its cache folder exists


_ENDING = threading.Event()


def _end_group() -> None:
    """End this background process and the compile workers it started.

    A background process leads a session of its own (:func:`_detach`), so its workers are in
    its process group: the group gets SIGTERM (this process's handler, :func:`_watch`, then
    only exits), and this process exits.
    """
    if not _ENDING.is_set() and os.getpgrp() == os.getpid():
        _ENDING.set()
        os.killpg(os.getpid(), signal.SIGTERM)
    os._exit(0)


def _watch(folder: str) -> None:
    """In a background process: end it and its workers when ``folder`` goes, or on SIGTERM.

    ``folder`` holds its compiled code; SIGTERM is ``kill PID``, as the terminal was told.
    """

    def watch() -> None:
        while os.path.isdir(folder):
            time.sleep(WATCH_SECONDS)
        _end_group()

    signal.signal(signal.SIGTERM, lambda signum, frame: _end_group())
    threading.Thread(target=watch, name="contour-gym cache watch", daemon=True).start()


def _lock(slot: str) -> Path:
    return jit.generated_dir() / f"background_{slot}.lock"


def _busy(lock: Path) -> bool:
    # whether a background process holds this slot's lock (a probe that never waits)
    with locked(lock, wait=False) as got:
        return not got


def _builtins_main(warmup: str, held: bool = True) -> None:
    """A background process: compile the built-ins' kernels of ``warmup`` (no progress bar)."""
    if held:
        on_reserved_stack(functools.partial(precompile.compile_builtins, progress=False), [warmup])


def _own_main(path: str, held: bool = True) -> None:
    """A background process: unpickle a loop or env task and run it once on its own kernels.

    The request file is removed whether or not this process holds the slot.
    """
    try:
        if not held:
            return
        with open(path, "rb") as handle:
            owner = pickle.load(handle)
    finally:
        os.unlink(path)
    on_reserved_stack(owner.compile_own)
