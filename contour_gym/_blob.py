"""Many arrays in one contiguous buffer, so a compiled call takes a few arguments, not dozens.

The view functions are inlined and carve their views in a few instructions (:func:`carve`): a
kernel builds tens of views per call, and a call or a reshape each cost ~3 us per env step
(numba calls a compiled function it loaded from the cache, never inlines it).

Unboxing each array argument of a numba call costs ~0.2 us; the servo loop has ~30 arrays and
is called once per env step. The Python side keeps ordinary numpy views into the buffer (so
code reads and writes ``loop.ax_s`` as usual, in place); the compiled side rebuilds the same
views from the layout table with :func:`view1` .. :func:`view3`, or as row tables (leading
dimensions merged) with :func:`rows2` and :func:`rows3`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numba
import numpy as np
from numba.core import cgutils, types
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic
from numba.np.arrayobj import populate_array
from numpy.typing import NDArray

from contour_gym._callee import callee

MAX_NDIM = 4


class Blob:
    """Named arrays of one dtype in one buffer.

    Args:
        specs: (name, shape) pairs, in layout order.
        dtype: Element type of every array.
    """

    def __init__(
        self, specs: Sequence[tuple[str, tuple[int, ...]]], dtype: type = np.float64
    ) -> None:
        sizes = [int(np.prod(shape)) for _, shape in specs]
        self.buffer: NDArray[np.generic] = np.zeros(max(sum(sizes), 1), dtype=dtype)
        self.layout = np.zeros((len(specs), 2 + MAX_NDIM), dtype=np.int64)
        self.views: dict[str, NDArray[Any]] = {}
        offset = 0
        for i, ((name, shape), size) in enumerate(zip(specs, sizes, strict=True)):
            if len(shape) > MAX_NDIM:
                raise ValueError(f"{name}: at most {MAX_NDIM} dimensions, got {shape}")
            self.layout[i, 0], self.layout[i, 1] = offset, len(shape)
            self.layout[i, 2 : 2 + len(shape)] = shape
            self.views[name] = self.buffer[offset : offset + size].reshape(shape)
            offset += size
        self.index = {name: i for i, (name, _) in enumerate(specs)}

    def __getstate__(self) -> dict[str, object]:
        # pickle the buffer once; the views are rebuilt on load so they alias it again
        return {"buffer": self.buffer, "layout": self.layout, "index": self.index}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.buffer, self.layout, self.index = state["buffer"], state["layout"], state["index"]  # type: ignore[assignment]
        self.views = {}
        for name, i in self.index.items():
            offset, ndim = int(self.layout[i, 0]), int(self.layout[i, 1])
            shape = tuple(int(d) for d in self.layout[i, 2 : 2 + ndim])
            self.views[name] = self.buffer[offset : offset + int(np.prod(shape))].reshape(shape)


@intrinsic
def borrow(typingctx, arr):
    """The array ``arr`` without its reference-counted owner (compiled code only).

    Every view numba makes (``a[b]``, ``a[b, i]``) increments and later decrements its
    owner's reference count with atomic instructions: without borrowing, ~30 % of the servo
    loop's tick (perf: ``lock incq``/``lock decq`` in ``NRT_incref``/``NRT_decref``).
    Views of a borrowed array carry no owner, so those calls do nothing. Use it only inside a
    compiled function whose caller keeps ``arr`` alive, and never return or store the result.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):
        src = context.make_array(arr)(context, builder, value=args[0])
        out = context.make_array(arr)(context, builder)
        cgutils.copy_struct(out, src)
        out.meminfo = cgutils.get_null_value(out.meminfo.type)
        out.parent = cgutils.get_null_value(out.parent.type)
        return out._getvalue()

    return arr(arr), codegen


@intrinsic
def readonly(typingctx, arr):
    """The array ``arr`` typed read-only (the same data; compiled code only).

    numba compiles a function anew for each argument type, and a read-only array is another
    type: the path tables a user's Python calls pass are read-only, so the loop reads its
    path blob through this too, and one compile of the path searches serves both.
    """
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):
        return impl_ret_borrowed(context, builder, signature.return_type, args[0])

    return arr.copy(readonly=True)(arr), codegen


@intrinsic
def carve(typingctx, buf, offset, shape):
    """The C-contiguous array of ``shape`` at element ``offset`` of the 1-D array ``buf``.

    What ``buf[offset : offset + size].reshape(shape)`` gives, made in a few instructions:
    numba's reshape calls a C helper, ~20 ns a view, and a kernel call makes ~60 views (half
    the fixed cost of an env step's compiled call). Nothing is checked: the blob's layout
    table is trusted. The view shares ``buf``'s owner (none for a borrowed blob).
    """
    if not (isinstance(buf, types.Array) and buf.ndim == 1 and isinstance(shape, types.UniTuple)
            and isinstance(shape.dtype, types.Integer)):
        return None
    nd = shape.count
    ret = types.Array(buf.dtype, nd, "C", readonly=not buf.mutable)

    def codegen(context, builder, signature, args):
        src = context.make_array(buf)(context, builder, value=args[0])
        out = context.make_array(ret)(context, builder)
        intp = context.get_value_type(types.intp)
        dims = [builder.sext(d, intp) if d.type.width < intp.width else d
                for d in cgutils.unpack_tuple(builder, args[2], nd)]
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(
            context.get_data_type(buf.dtype)))
        strides, step = [], itemsize
        for d in reversed(dims):
            strides.insert(0, step)
            step = builder.mul(step, d)
        start = builder.sext(args[1], intp) if args[1].type.width < intp.width else args[1]
        populate_array(
            out, data=builder.gep(src.data, [start]), shape=cgutils.pack_array(builder, dims),
            strides=cgutils.pack_array(builder, strides), itemsize=itemsize,
            meminfo=src.meminfo, parent=cgutils.get_null_value(src.parent.type),
        )
        return impl_ret_borrowed(context, builder, ret, out._getvalue())

    return ret(buf, offset, shape), codegen


@numba.njit(cache=True, inline="always")
def view1(buf, lay, i):
    """1-D view number ``i`` of a blob."""
    return carve(buf, lay[i, 0], (lay[i, 2],))


@numba.njit(cache=True, inline="always")
def view2(buf, lay, i):
    """2-D view number ``i`` of a blob."""
    return carve(buf, lay[i, 0], (lay[i, 2], lay[i, 3]))


@numba.njit(cache=True, inline="always")
def view3(buf, lay, i):
    """3-D view number ``i`` of a blob."""
    return carve(buf, lay[i, 0], (lay[i, 2], lay[i, 3], lay[i, 4]))


@callee(forceinline=True)
def _size(lay, i, ndim):
    """Product of the first ``ndim`` dimensions of array ``i`` of a blob.

    Typed once and inlined by LLVM (``forceinline``): inlined by numba, a kernel that makes
    twenty row tables typed its loop twenty times.
    """
    n = 1
    for d in range(ndim):
        n *= lay[i, 2 + d]
    return n


@numba.njit(cache=True, inline="always")
def rows2(buf, lay, i):
    """Array ``i`` of a blob as a 2-D row table: all but its last dimension merged into rows."""
    nd = lay[i, 1]
    n, last = _size(lay, i, nd - 1), lay[i, 1 + nd]
    return carve(buf, lay[i, 0], (n, last))


@numba.njit(cache=True, inline="always")
def rows3(buf, lay, i):
    """Array ``i`` of a blob as a 3-D row table: all but its last two dimensions merged."""
    nd = lay[i, 1]
    n, r, c = _size(lay, i, nd - 2), lay[i, nd], lay[i, 1 + nd]
    return carve(buf, lay[i, 0], (n, r, c))


@numba.njit(cache=True, inline="always")
def slab(buf, lay, i, j):
    """Slab ``j`` (a 2-D view) of the 3-D array ``i`` of a blob."""
    rows, cols = lay[i, 3], lay[i, 4]
    return carve(buf, lay[i, 0] + j * rows * cols, (rows, cols))


@numba.njit(cache=True, inline="always")
def flat(buf, lay, i):
    """All elements of array ``i`` of a blob as one 1-D view."""
    return carve(buf, lay[i, 0], (_size(lay, i, lay[i, 1]),))
