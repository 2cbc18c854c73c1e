"""What a first run shows and counts while numba compiles: a progress line, and a census.

:func:`compiling` shows a progress line while a block compiles kernels in this process (a
kernel specialised to a user's component; the built-ins' kernels compile in worker processes,
:mod:`contour_gym.jit.precompile`). :func:`census` counts the typed IR numba compiled in this
process: ``tests/test_compile_budget.py`` holds a first run's count to a budget.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass

from numba.core import event

OWN_KERNEL_SECONDS = 20.0
"""About how long one kernel compiles in-process on a 2-core machine, for the progress line: the
servo loop's kernel of a fresh-cache ``contour-gym simulate`` (the rest of its first run builds
the path's tables; docs/measurements.md)."""


class Line:
    """A tqdm line on stderr, redrawn every half second on a terminal (a log gets changes only).

    Args:
        desc: What it shows first.
        bar_format: tqdm's format.
        total: Steps to count (None: none).
    """

    def __init__(self, desc: str, bar_format: str, total: int | None = None) -> None:
        from tqdm.auto import tqdm

        self.bar = tqdm(total=total, file=sys.stderr, desc=desc, bar_format=bar_format)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._tick, daemon=True)
        self.thread.start()

    def _tick(self) -> None:
        while not self.stop.wait(0.5):
            if sys.stderr.isatty():
                self.bar.refresh()

    def show(self, text: str, refresh: bool = False) -> None:
        """Set the text after the time."""
        self.bar.set_postfix_str(text, refresh=refresh)

    def close(self, text: str | None = None) -> None:
        """Stop redrawing; show ``text`` last."""
        self.stop.set()
        self.thread.join()
        if text is not None:
            self.show(text)
        self.bar.close()


class _Progress(event.Listener):
    """A progress line while numba compiles: what, how long to expect, the time so far."""

    def __init__(self, label: str) -> None:
        desc = (f"contour-gym: compiling {label} "
                f"(first run only, about {OWN_KERNEL_SECONDS:.0f} s on 2 cores)")
        self.line = Line(desc, "{desc} [{elapsed}] {postfix}")

    def on_start(self, ev: event.Event) -> None:
        func = getattr(ev.data.get("dispatcher"), "py_func", None)
        self.line.show(f"now: {getattr(func, '__qualname__', '?')}")

    def on_end(self, ev: event.Event) -> None:
        pass


@contextlib.contextmanager
def compiling(label: str, show: bool = True) -> Iterator[None]:
    """Show a progress line while the block compiles kernels in this process (if ``show``).

    Used for kernels specialised to a user's component (the built-ins' kernels compile in
    worker processes: :mod:`contour_gym.jit.precompile`).
    """
    if not show:
        yield
        return
    progress = _Progress(label)
    try:
        with event.install_listener("numba:compile", progress):
            yield
    finally:
        progress.line.close("done")


@dataclass(frozen=True)
class Census:
    """What numba compiled in this process: a measure of a first run's compile work.

    Attributes:
        functions: Compiled signatures (a function compiled for two signatures counts twice).
        statements: Statements of their typed IR, numba-inlined code included: a number that
            does not depend on the machine or its load, and grows with the compile's time.
    """

    functions: int
    statements: int


def census() -> Census:
    """Count what numba compiled in this process (not what it loaded from its cache)."""
    import gc

    from numba.core.dispatcher import Dispatcher

    functions = statements = 0
    for obj in gc.get_objects():
        if not isinstance(obj, Dispatcher):
            continue
        for result in obj.overloads.values():
            annotation = getattr(result, "type_annotation", None)
            if annotation is None:  # loaded from the cache
                continue
            functions += 1
            statements += sum(len(block.body) for block in annotation.blocks.values())
    return Census(functions, statements)
