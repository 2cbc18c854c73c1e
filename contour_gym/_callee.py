"""Functions only compiled code calls: compiled without the entry points Python would call.

numba compiles every ``@numba.njit`` function with a CPython wrapper (unboxing each argument,
boxing the result) and a C wrapper beside the function itself, and makes machine code of all
three, although a function only a kernel calls never runs through them: the kernel links the
function's own code and LLVM inlines it there. :func:`callee` compiles a function without them
(numba's ``no_cpython_wrapper`` and ``no_cfunc_wrapper``): the same code where compiled code
calls it, less for numba and LLVM to make (a fresh-cache ``contour-gym simulate`` compiles 53
such functions; docs/measurements.md). Called from Python, such a function would jump to an
entry point that does not exist, so :class:`Callee` runs such a call through a small compiled
function of its own.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba
from numba.core.registry import CPUDispatcher

_NO_ENTRY = {"nopython": True, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}


class Callee(CPUDispatcher):
    """A numba dispatcher compiled without Python's entry point; compiled code calls it.

    Called from Python, it runs through a small compiled function that calls it (compiled on
    the first such call): the same compiled code, at the cost of one more compile.
    """

    _entry: Any = None

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        if kwargs:
            raise TypeError(f"{self.py_func.__qualname__} takes positional arguments from "
                            f"Python (got {sorted(kwargs)})")
        if self._entry is None:
            self._entry = _entry_for(self)
        return self._entry(*args)


def _entry_for(dispatcher: Callee) -> Any:
    """A ``@numba.njit`` function that calls ``dispatcher`` with its arguments."""

    def entry(*args):  # type: ignore[no-untyped-def]
        return dispatcher(*args)

    return numba.njit(entry)


def callee(func: Callable[..., Any] | None = None, **options: Any) -> Any:
    """``@numba.njit`` for a function that only compiled code calls (no Python entry point).

    Takes numba's options (``forceinline=True``, ...), not ``cache``: a cached function is
    machine code a caller cannot inline, and has callers in Python.

    >>> @callee
    ... def twice(x):
    ...     return 2 * x
    >>> numba.njit(lambda x: twice(x) + 1)(20)
    41
    >>> twice(20)  # from Python: through a compiled entry of its own
    40
    """
    if "cache" in options:
        raise ValueError(f"callee takes no cache option (got cache={options['cache']!r})")

    def wrap(f: Callable[..., Any]) -> Any:
        if numba.config.DISABLE_JIT:  # type: ignore[attr-defined]
            return f
        return Callee(py_func=f, locals={}, targetoptions={**options, **_NO_ENTRY})

    return wrap if func is None else wrap(func)
