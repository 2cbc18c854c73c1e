"""Faster inlining of ``inline="always"`` functions by numba: one copy, one front end per callee.

numba's ``InlineWorker.inline_ir`` copies the callee's IR block by block, each block with a
fresh ``copy.deepcopy`` memo (numba issue 8989, open in numba 0.68). Every block refers to the
function's one ``ir.Scope``, which holds every variable of the function, so each block's copy
copies the whole scope again: the cost grows with blocks times variables, and nested inline
functions (a kernel's helpers, each dispatching over components) make both large. Measured on
the kernel of every built-in component: 88 of 131 s of a profiled cold compile were spent in
these copies.

:func:`install` makes the blocks of one IR share one memo, so the scope and every variable are
copied once per IR, shared by the copied blocks as the original blocks share them. That is
the copy the per-block loop intends; the compiled code does not change (the test suite checks
results bit for bit). It is installed only when numba's ``inline_ir`` still has the expected
per-block loop, and changes nothing else: any other ``deepcopy`` goes to :mod:`copy` as before.

numba also runs a callee's whole untyped pipeline (bytecode to canonical IR, with the callee's own
inlining) again at every call site it inlines (``InlineWorker.run_untyped_passes``), although the
result depends only on the function and the compile's settings. :func:`install` keeps the
first result per function and settings and inlines it at each call site under a new function
identity (a new unique name for the inlined variables, as a fresh run gives); ``inline_ir``
copies the callee's blocks before it changes them, so the kept IR stays as the pipeline left
it. A function whose settings cannot be keyed runs the pipeline as before. The kept IR holds the
globals a callee read when it was first inlined in the process: a global changed later reaches
its callers in a new process (as numba's cache, which freezes globals too, behaves).
"""

from __future__ import annotations

import copy
import inspect
import threading
from typing import Any

_EXPECTED = "new_block = copy.deepcopy(the_ir.blocks[block_label])"
_EXPECTED_FRONT_END = "callee_ir = self.run_untyped_passes(function)"


class _SharedMemoCopy:
    """Stands in for :mod:`copy` inside ``numba.core.inline_closurecall``.

    Consecutive ``deepcopy(block)`` calls without a memo share one memo while the blocks have
    the same scope and none repeats (a repeat, or another scope, is the next IR's copy).
    """

    def __init__(self, block_type: type) -> None:
        self._block_type = block_type
        self._local = threading.local()

    def deepcopy(self, x: Any, memo: dict[int, Any] | None = None) -> Any:
        if memo is not None or not isinstance(x, self._block_type):
            return copy.deepcopy(x, memo)
        state, scope = self._local, getattr(x, "scope", None)
        shared = getattr(state, "memo", None)
        if shared is None or getattr(state, "scope", None) is not scope or id(x) in shared:
            shared = state.memo = {}
            state.scope = scope
        return copy.deepcopy(x, shared)

    def __getattr__(self, name: str) -> Any:
        return getattr(copy, name)


def _hashable(value: Any) -> Any:
    """``value``, or for numba's ``FastMathOptions`` (a set of flags) its type and flags."""
    flags = getattr(value, "flags", None)
    if type(value).__name__ == "FastMathOptions" and isinstance(flags, set):
        return "FastMathOptions", frozenset(flags)
    return value


def _settings_key(worker: Any, func: Any) -> tuple[Any, ...] | None:
    """What the inliner's untyped pipeline makes of ``func`` depends on, hashable, or None.

    The pipeline runs without SSA whatever the caller's flags say, so ``enable_ssa`` is left out.
    """
    try:
        flags = tuple(sorted((name, _hashable(value)) for name, value
                             in worker.flags._values.items() if name != "enable_ssa"))
        key = (func, id(worker.typingctx), id(worker.targetctx), type(worker.pipeline), flags,
               tuple(sorted(worker.locals.items())))
        hash(key)
    except (AttributeError, TypeError):
        return None
    return key


def _memo_front_end(original: Any) -> Any:
    results: dict[tuple[Any, ...], Any] = {}

    def inline_function(self: Any, caller_ir: Any, block: Any, i: int, function: Any,
                        arg_typs: Any = None) -> Any:
        from numba.core.bytecode import FunctionIdentity

        key = _settings_key(self, function)
        if key is None:
            return original(self, caller_ir, block, i, function, arg_typs)
        if key not in results:
            results[key] = self.run_untyped_passes(function)
        self.flags.enable_ssa = False  # as numba's own front end does, on the caller's flags
        callee_ir = copy.copy(results[key])  # inline_ir copies its blocks before changing them
        callee_ir.func_id = FunctionIdentity.from_function(function)
        return self.inline_ir(caller_ir, block, i, callee_ir, function.__code__.co_freevars,
                              arg_typs=arg_typs)

    inline_function.wrapped = original  # type: ignore[attr-defined]
    return inline_function


def install() -> bool:
    """Install the shared-memo copy and the front end's memo in numba's inliner.

    Returns:
        False if numba's code is not as expected (then nothing is installed).
    """
    try:
        from numba.core import inline_closurecall, ir
    except ImportError:  # pragma: no cover - numba is a dependency
        return False
    worker = inline_closurecall.InlineWorker
    current = getattr(inline_closurecall, "copy", None)
    if isinstance(current, _SharedMemoCopy):
        return True
    if current is not copy or _EXPECTED not in inspect.getsource(worker):
        return False
    if _EXPECTED_FRONT_END not in inspect.getsource(worker.inline_function):
        return False
    setattr(inline_closurecall, "copy", _SharedMemoCopy(ir.Block))  # noqa: B010 (a module)
    worker.inline_function = _memo_front_end(worker.inline_function)  # type: ignore[method-assign]
    return True
