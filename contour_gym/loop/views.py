"""The servo loop's arrays as attributes, and the read-outs of its per-member state.

Every array the compiled loop touches lives in one of two blobs (:mod:`contour_gym._blob`,
layouts in :mod:`contour_gym.loop.state`). :class:`LoopViews` declares each of them once, as a
:class:`BlobView`: ``loop.ax_s`` is the numpy view of ``ax_s`` in the float blob, written in
place. The first read of a view stores it in the instance's ``__dict__``, so every later read
(``advance`` reads some per env step) is a plain instance attribute lookup. The declared names
are checked against the blob layouts on import.

The properties here read the state the kernel leaves in those arrays (status, failure reason,
cycle time, errors at the last tick, progress) for :class:`contour_gym.loop.ServoLoop`.
"""

from __future__ import annotations

import typing
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._blob import Blob
from contour_gym.loop.state import (
    FLOAT_NAMES,
    FT,
    INT_NAMES,
    LS,
    MEM_COL,
    STATUS_ARRIVED,
    STATUS_FAILED,
    STATUS_OK,
    STATUS_PAUSED,
)
from contour_gym.motion import IS
from contour_gym.plant.stage import Stage

Array = NDArray[np.float64]
Ints = NDArray[np.int64]
V = TypeVar("V", bound=NDArray[Any])


class BlobView(Generic[V]):
    """A class attribute naming one array of a loop's blob; reads give the array's view.

    A non-data descriptor: the first read on an instance stores the view in the instance's
    ``__dict__``, which then answers every later read without calling the descriptor.

    Args:
        blob: Name of the instance attribute holding the :class:`~contour_gym._blob.Blob`.
    """

    __slots__ = ("blob", "name")

    def __init__(self, blob: str) -> None:
        self.blob = blob
        self.name = ""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name

    def __repr__(self) -> str:
        return f"BlobView({self.name!r} of {self.blob})"

    # typing.overload spelt out: the bare decorator marks kernel modules (jit.cache._KERNEL_MARKS)
    @typing.overload
    def __get__(self, obj: None, owner: type | None = None) -> BlobView[V]: ...
    @typing.overload
    def __get__(self, obj: object, owner: type | None = None) -> V: ...
    def __get__(self, obj: object | None, owner: type | None = None) -> BlobView[V] | V:
        if obj is None:
            return self
        view: V = getattr(obj, self.blob).views[self.name]
        obj.__dict__[self.name] = view  # later reads: a plain instance attribute
        return view


def _float() -> BlobView[Array]:
    return BlobView("_fblob")


def _int() -> BlobView[Ints]:
    return BlobView("_iblob")


class LoopViews:
    """The blobs' arrays by name (:data:`contour_gym.loop.state.FLOATS`, ``INTS``) and read-outs.

    A base of :class:`contour_gym.loop.ServoLoop`; its subclasses set the attributes declared
    below.
    """

    stage: Stage
    batch_size: int
    tick: int
    _fblob: Blob
    _iblob: Blob
    _pblob: Blob
    _kind: Ints

    # float blob: parameters, states, accumulators (per member first)
    ax_p = _float()
    fr_p = _float()
    rip = _float()
    dist = _float()
    ad = _float()
    bd = _float()
    ax_s = _float()
    ctrl_p = _float()
    ctrl_s = _float()
    comp_p = _float()
    comp_s = _float()
    ccc_p = _float()
    ccc_w = _float()
    ccc_s = _float()
    ccc_data = _float()
    est_p = _float()
    hist = _float()
    ip_p = _float()
    ip_s = _float()
    foot = _float()
    last = _float()
    acc_c = _float()
    acc_a = _float()
    ep_c = _float()
    ep_a = _float()
    u_cmd = _float()
    y_last = _float()
    x_ring = _float()
    mem = _float()
    work = _float()
    c_off = _float()
    # int blob
    c_axes = _int()
    status = _int()
    k_start = _int()
    noise_at = _int()
    p_at = _int()

    @classmethod
    def view_names(cls) -> tuple[set[str], set[str]]:
        """The names declared as views of the float blob and of the int blob."""
        views = [v for v in vars(cls).values() if isinstance(v, BlobView)]
        return ({v.name for v in views if v.blob == "_fblob"},
                {v.name for v in views if v.blob == "_iblob"})

    @property
    def s(self) -> Array:
        """(B,) reference arc length, m."""
        return self.ip_s[:, IS.s]

    @property
    def reference_done(self) -> NDArray[np.bool_]:
        """(B,) whether the reference has reached the end of the path."""
        return self.ip_s[:, IS.done] >= 0

    @property
    def done(self) -> NDArray[np.bool_]:
        """(B,) whether a member has finished the contour: in position at the path end."""
        return self.status == STATUS_ARRIVED

    @property
    def failed(self) -> NDArray[np.bool_]:
        """(B,) whether a member failed: diverged, or never got in position at the end."""
        return self.status == STATUS_FAILED

    @property
    def failure_reason(self) -> NDArray[np.float64]:
        """(B,) why a member failed: 0 none, 1 diverged, 2 not in position, 3 over, 4 time cap.

        In words: :data:`contour_gym.loop.REASON_NAMES`. 2: not in position within the settle
        time after the path end; 3: stopped by :meth:`~contour_gym.loop.ServoLoop.run`'s
        ``stop_above``; 4: still running when its ``max_time`` ran out.
        """
        return self.mem[:, MEM_COL.reason].copy()

    @property
    def running(self) -> NDArray[np.bool_]:
        """(B,) members still on their way."""
        return (self.status == STATUS_OK) | (self.status == STATUS_PAUSED)

    @property
    def _ended(self) -> NDArray[np.bool_]:
        # (B,) members that arrived or failed (their clocks stopped at their end)
        return (self.status == STATUS_ARRIVED) | (self.status == STATUS_FAILED)

    @property
    def ticks_run(self) -> NDArray[np.int64]:
        """(B,) ticks each member has run since its reset (until its end, if it ended)."""
        ticks = np.where(self._ended, self.mem[:, MEM_COL.end], self.tick - self.k_start)
        return ticks.astype(np.int64)

    @property
    def cycle_time(self) -> Array:
        """(B,) time from the start to the arrival in position at the end, s (inf if not)."""
        return np.where(self.done, self.mem[:, MEM_COL.arrival] * self.stage.ts, np.inf)

    @property
    def contour_error(self) -> Array:
        """(B, C) true contour error at the last tick, m."""
        return self.last[..., LS.true]

    @property
    def contour_error_estimate(self) -> Array:
        """(B, C) contour error the CCC saw at the last tick, m."""
        return self.last[..., LS.est]

    @property
    def progress(self) -> Array:
        """(B, C) arc length of the machine's foot point along the path (unwrapped), m."""
        return self.foot[..., FT.progress]

    def blobs(self) -> tuple[NDArray[Any], NDArray[Any], NDArray[Any], NDArray[Any]]:
        """The float and int blobs and their layouts (what compiled callers take)."""
        return self._fblob.buffer, self._fblob.layout, self._iblob.buffer, self._iblob.layout


def member_indices(batch: int, members: ArrayLike | None) -> NDArray[np.intp]:
    """The indices of ``members`` (indices or a boolean mask; None: every member of ``batch``)."""
    every = np.arange(batch)
    return every if members is None else every[np.asarray(members)].reshape(-1)


def _check_declared() -> None:
    # one home for the names: the views declared above are exactly the blobs' arrays
    floats, ints = LoopViews.view_names()
    if floats != set(FLOAT_NAMES) or ints != set(INT_NAMES):
        raise RuntimeError(
            f"LoopViews declares {sorted(floats)} / {sorted(ints)}; the blobs hold "
            f"{sorted(FLOAT_NAMES)} / {sorted(INT_NAMES)} (contour_gym.loop.state)"
        )


_check_declared()
