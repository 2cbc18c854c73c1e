"""Running code that compiles below a frame that reserves CPython's data stack.

CPython (3.11 and later) keeps Python frames on a data stack of chunks of 16 KiB and frees a
chunk as soon as the frame that opened it returns. numba's type inference recurses deeply, and
every call that crosses a chunk's end maps and unmaps a chunk: compiling ``contour-gym
simulate``'s kernels made 2.5 million ``mmap``/``munmap`` pairs, 23 of its 90 s spent in the
system. Below a frame that leaves half a MiB free in its chunk, the calls stay within it.
"""

from __future__ import annotations

import types
from collections.abc import Callable
from typing import Any, TypeVar, cast

T = TypeVar("T")

_RESERVED_SLOTS = 1 << 16


def _reserve(call: Callable[..., Any], args: tuple[Any, ...]) -> Any:
    return call(*args)


# The same function with 65 536 unused local slots: its frame takes half a MiB of CPython's data
# stack (3.11+), so the interpreter gives it a chunk of 1 MiB and the calls below it run in the
# other half (:func:`on_reserved_stack`).
_reserve = types.FunctionType(
    _reserve.__code__.replace(
        co_varnames=_reserve.__code__.co_varnames
        + tuple(f"_slot{i}" for i in range(_RESERVED_SLOTS)),
        co_nlocals=_reserve.__code__.co_nlocals + _RESERVED_SLOTS,
    ),
    globals(),
)


def on_reserved_stack(call: Callable[..., T], *args: Any) -> T:
    """``call(*args)``, run below a frame that reserves half a MiB of the interpreter's stack.

    Wrap what may compile (a kernel's first call, a command, a worker's main): numba's
    compiles below it stay within one chunk of the data stack (module docstring). It costs
    about 0.4 ms a call (the frame's slots are cleared and the chunk mapped): not for code
    that runs often.
    """
    return cast("T", _reserve(call, args))
