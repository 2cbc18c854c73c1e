"""The servo loop's arrays by name: blob layout, row layouts, and the kernels' grouped views.

A :class:`~contour_gym.loop.ServoLoop` keeps every per-member array in two blobs
(:mod:`contour_gym._blob`): floats in the order of :data:`FLOATS`, ints in :data:`INTS`. The
compiled side rebuilds them as one named tuple of views (:func:`loop_arrays`), indexed by name
(``FLOAT_AT.ip_s`` is the blob index of ``ip_s``): the kernels take a handful of grouped
arguments (this tuple as ``loop``, the path bank as ``bank`` and each member's :data:`PathArrays` as
``path``, the scalar
settings :data:`Config` as ``cfg``) instead of dozens of positional arrays.

Per-axis and per-contour arrays are *row tables* (all but the last dimension merged: row
``b * A + a`` or ``b * C + c``); see :mod:`contour_gym.plant._kernel` for why the kernels index
rows rather than take row views.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba

from contour_gym._blob import carve, readonly, rows2, rows3, slab, view1, view2, view3
from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import number

# float blob: (name, how the kernel views it)
FLOATS = (
    ("ax_p", "rows2"), ("fr_p", "rows2"), ("rip", "rows3"), ("dist", "rows2"),
    ("ad", "rows3"), ("bd", "rows3"), ("ax_s", "rows2"), ("ctrl_p", "rows2"),
    ("ctrl_s", "rows2"), ("comp_p", "rows2"), ("comp_s", "rows2"), ("ccc_p", "rows2"),
    ("ccc_w", "rows2"), ("ccc_s", "rows2"), ("ccc_data", "view1"), ("est_p", "view1"),
    ("hist", "view2"), ("ip_p", "view2"), ("ip_s", "view2"), ("foot", "rows2"),
    ("last", "rows2"), ("acc_c", "rows2"), ("acc_a", "rows2"), ("ep_c", "rows2"),
    ("ep_a", "rows2"), ("u_cmd", "view2"), ("y_last", "view2"), ("x_ring", "view3"),
    ("mem", "view2"), ("work", "view3"), ("c_off", "view2"),
)
# noise_at: each member's row in the noise buffer of its next tick (the kernel advances it)
# p_at: each member's path in the path bank, row (first segment, segments, first s0 entry)
INTS = (("c_axes", "view2"), ("status", "view1"), ("k_start", "view1"), ("noise_at", "view1"),
        ("p_at", "view2"))
FLOAT_NAMES = tuple(n for n, _ in FLOATS)
INT_NAMES = tuple(n for n, _ in INTS)
FLOAT_AT = namedtuple("F", FLOAT_NAMES)(*range(len(FLOATS)))
INT_AT = namedtuple("I", INT_NAMES)(*range(len(INTS)))  # noqa: E741

LoopArrays = namedtuple("LoopArrays", FLOAT_NAMES + INT_NAMES)  # type: ignore[misc]
# The path bank: the members' paths (their tables and programs, each distinct path once, one
# after the other) and the shared time law in one float blob; the segment kinds apart (ints).
# ``member``: each member's path scalars (columns MEMBER_PATH). A member's PathArrays are
# views of its own part (member_path; where it lies: the int blob's p_at).
PATH_FLOATS = (
    ("s0", "view1"), ("data", "view2"), ("bound", "view2"), ("feed", "view1"),
    ("flags", "view1"), ("vcap", "view1"), ("vj", "view1"), ("wait", "view1"),
    ("dwell", "view1"), ("law_s", "view1"), ("law_v", "view1"), ("member", "view2"),
)
PATH_NAMES = tuple(n for n, _ in PATH_FLOATS)
PATH_AT = namedtuple("PF", PATH_NAMES)(*range(len(PATH_FLOATS)))
MEMBER_PATH = Schema("member path", length=1.0, closed=0.0)  # a member's path scalars
MP = MEMBER_PATH.col
P_AT = state_schema("path at", "seg", "n", "s0")  # columns of p_at
PA = P_AT.col
# one member's path: its table (kind, s0, data, bound), program, the time law, its scalars
PathArrays = namedtuple("PathArrays", ("kind",) + PATH_NAMES[:-1] + ("length", "closed"))  # type: ignore[misc]
# the whole bank, as the kernels take it (read-only): kinds, floats and the float layout
PathBank = namedtuple("PathBank", ("kinds", "floats", "layout"))

# the run's scalars, passed as one float row (a tuple argument costs the dispatcher ~2 us)
CONFIG = Schema(
    "loop config", ts=1e-3, nsub=1.0, dim=2.0, meas_exact=1.0,
    delay=0.0, inj_ref=0.0, record=0.0, settle_ticks=1000.0, in_band=1e-6, in_speed=1e-3,
    law_dt=1.0, sample_every=1.0, stop_above=Param(math.inf, number), ctrl=0.0, est=0.0,
    search=0.0, ccc=0.0, comp=0.0,
)
CF = CONFIG.col
Config = namedtuple("Config", CONFIG.names)  # type: ignore[misc]

# row layouts
# the machine's true foot point (tracked each tick; progress unwrapped on closed paths), and the
# foot point the exact-search estimator tracks for the encoder reading (e_*)
FOOT = state_schema("foot", "s", "progress", "qx", "qy", "qz", "seg", "e_s", "e_qx", "e_qy", "e_qz")
FT = FOOT.col
LAST = state_schema("last", "true", "est")
LS = LAST.col
MEM = state_schema("member", "in_pos", "arrival", "reason", "end")
MEM_COL = MEM.col
WORK = state_schema("work", "r0", "r", "rdot", "rddot", "x", "y", "u", "ua", "uccc", "v")
WORK_ROW = WORK.col

STATUS_OK, STATUS_FAILED, STATUS_PAUSED, STATUS_ARRIVED = 0, 1, 2, 3
REASON_NONE, REASON_DIVERGED, REASON_NOT_IN_POSITION, REASON_OVER_LIMIT = 0.0, 1.0, 2.0, 3.0
REASON_TIME_CAP = 4.0
REASON_HARD_LIMIT = 5.0  # an env's failure rule (the loop itself never ends a member for it)
# why a member failed (ServoLoop.failure_reason), in words
REASON_NAMES = {
    REASON_NONE: "", REASON_DIVERGED: "the axes diverged",
    REASON_NOT_IN_POSITION: "not in position within the settle time after the path end",
    REASON_OVER_LIMIT: "contour error above the run's stop_above",
    REASON_TIME_CAP: "the run's time cap was reached before the path end",
    REASON_HARD_LIMIT: "contour error above the env's hard limit",
}
STATE_LIMIT = 1e3  # |x| in m or |v| in m/s beyond this is a diverged member


@numba.njit(cache=True, inline="always")
def loop_arrays(floats, float_layout, ints, int_layout, part):
    """Every array of the loop's blobs as one named tuple of (borrowed) views.

    ``work`` is the scratch of ``part``: the members of a loop run on threads in parts
    (contiguous slices of the batch, :meth:`contour_gym.loop.ServoLoop.advance`), each part on
    scratch of its own; a member's results do not depend on its part.
    """
    return LoopArrays(
        rows2(floats, float_layout, FLOAT_AT.ax_p),
        rows2(floats, float_layout, FLOAT_AT.fr_p),
        rows3(floats, float_layout, FLOAT_AT.rip),
        rows2(floats, float_layout, FLOAT_AT.dist),
        rows3(floats, float_layout, FLOAT_AT.ad),
        rows3(floats, float_layout, FLOAT_AT.bd),
        rows2(floats, float_layout, FLOAT_AT.ax_s),
        rows2(floats, float_layout, FLOAT_AT.ctrl_p),
        rows2(floats, float_layout, FLOAT_AT.ctrl_s),
        rows2(floats, float_layout, FLOAT_AT.comp_p),
        rows2(floats, float_layout, FLOAT_AT.comp_s),
        rows2(floats, float_layout, FLOAT_AT.ccc_p),
        rows2(floats, float_layout, FLOAT_AT.ccc_w),
        rows2(floats, float_layout, FLOAT_AT.ccc_s),
        view1(floats, float_layout, FLOAT_AT.ccc_data),
        view1(floats, float_layout, FLOAT_AT.est_p),
        view2(floats, float_layout, FLOAT_AT.hist),
        view2(floats, float_layout, FLOAT_AT.ip_p),
        view2(floats, float_layout, FLOAT_AT.ip_s),
        rows2(floats, float_layout, FLOAT_AT.foot),
        rows2(floats, float_layout, FLOAT_AT.last),
        rows2(floats, float_layout, FLOAT_AT.acc_c),
        rows2(floats, float_layout, FLOAT_AT.acc_a),
        rows2(floats, float_layout, FLOAT_AT.ep_c),
        rows2(floats, float_layout, FLOAT_AT.ep_a),
        view2(floats, float_layout, FLOAT_AT.u_cmd),
        view2(floats, float_layout, FLOAT_AT.y_last),
        view3(floats, float_layout, FLOAT_AT.x_ring),
        view2(floats, float_layout, FLOAT_AT.mem),
        slab(floats, float_layout, FLOAT_AT.work, part),
        view2(floats, float_layout, FLOAT_AT.c_off),
        view2(ints, int_layout, INT_AT.c_axes),
        view1(ints, int_layout, INT_AT.status),
        view1(ints, int_layout, INT_AT.k_start),
        view1(ints, int_layout, INT_AT.noise_at),
        view2(ints, int_layout, INT_AT.p_at),
    )


@numba.njit(cache=True, inline="always")
def path_bank(path_kinds, path_floats, path_layout):
    """The path bank (segment kinds, the float blob in :data:`PATH_FLOATS` order, its layout).

    Typed read-only, as the path tables of the Python API are (:func:`_blob.readonly`).
    """
    return PathBank(readonly(path_kinds), readonly(path_floats), path_layout)


@numba.njit(cache=True, inline="always")
def member_path(bank, p_at, b):
    """Member ``b``'s :data:`PathArrays`: views of its part of the bank (row ``p_at[b]``).

    Carved (:func:`_blob.carve`): C-contiguous and read-only, the types of the whole path's
    views, so the path searches compile once for every bank.
    """
    buf, lay = bank.floats, bank.layout
    o, n, o0 = p_at[b, PA.seg], p_at[b, PA.n], p_at[b, PA.s0]
    w = lay[PATH_AT.data, 3]
    m = lay[PATH_AT.member, 0] + b * lay[PATH_AT.member, 3]
    return PathArrays(
        carve(bank.kinds, o, (n,)),
        carve(buf, lay[PATH_AT.s0, 0] + o0, (n + 1,)),
        carve(buf, lay[PATH_AT.data, 0] + o * w, (n, w)),
        # a path of n segments has 3n - 1 bound rows (contour_gym.paths._branch); the bank's
        # path j starts at segment o = first, at row 3 o - j, and o0 = o + j
        carve(buf, lay[PATH_AT.bound, 0] + (4 * o - o0) * lay[PATH_AT.bound, 3],
              (3 * n - 1, lay[PATH_AT.bound, 3])),
        carve(buf, lay[PATH_AT.feed, 0] + o, (n,)),
        carve(buf, lay[PATH_AT.flags, 0] + o, (n,)),
        carve(buf, lay[PATH_AT.vcap, 0] + o, (n,)),
        carve(buf, lay[PATH_AT.vj, 0] + o, (n,)),
        carve(buf, lay[PATH_AT.wait, 0] + o, (n,)),
        carve(buf, lay[PATH_AT.dwell, 0] + o, (n,)),
        view1(buf, lay, PATH_AT.law_s),
        view1(buf, lay, PATH_AT.law_v),
        buf[m + MP.length],
        buf[m + MP.closed] != 0.0,
    )


@numba.njit(cache=True, inline="always")
def next_path(bank, p_at, path, carved, b):
    """Member ``b``'s :data:`PathArrays`, and the member they were carved for.

    ``path`` (carved for member ``carved``) when ``b`` runs the same path, else carved anew
    (:func:`member_path`): members sharing a path carve it once per call.
    """
    if p_at[b, PA.seg] == p_at[carved, PA.seg]:
        return path, carved
    return member_path(bank, p_at, b), b


@numba.njit(cache=True, inline="always")
def config(c):
    """The :data:`CONFIG` row as a named tuple with the right types."""
    return Config(
        c[CF.ts], int(c[CF.nsub]), int(c[CF.dim]), c[CF.meas_exact] != 0.0, c[CF.delay] != 0.0,
        c[CF.inj_ref] != 0.0, c[CF.record] != 0.0, c[CF.settle_ticks], c[CF.in_band],
        c[CF.in_speed], c[CF.law_dt], int(c[CF.sample_every]),
        c[CF.stop_above], int(c[CF.ctrl]), int(c[CF.est]), c[CF.search] != 0.0, int(c[CF.ccc]),
        int(c[CF.comp]),
    )
