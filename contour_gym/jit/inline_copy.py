"""A faster copy of numba's callee IR when it inlines ``inline="always"`` functions.

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
"""

from __future__ import annotations

import copy
import inspect
import threading
from typing import Any

_EXPECTED = "new_block = copy.deepcopy(the_ir.blocks[block_label])"


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


def install() -> bool:
    """Install the shared-memo copy in numba's inliner; False if numba's code is not as expected."""
    try:
        from numba.core import inline_closurecall, ir
    except ImportError:  # pragma: no cover - numba is a dependency
        return False
    current = getattr(inline_closurecall, "copy", None)
    if isinstance(current, _SharedMemoCopy):
        return True
    if current is not copy or _EXPECTED not in inspect.getsource(inline_closurecall.InlineWorker):
        return False
    setattr(inline_closurecall, "copy", _SharedMemoCopy(ir.Block))  # noqa: B010 (a module)
    return True
