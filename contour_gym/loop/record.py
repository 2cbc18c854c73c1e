"""The servo loop's per-tick record: the rows the kernel writes, kept per call, as a Trace.

With ``ServoLoop(record=True)`` the kernel writes one row per member and tick (reference arc
length and speed, reference, positions and command per axis, true and estimated contour error
per contour) into a buffer from :meth:`Recorder.new`; :meth:`Recorder.keep` keeps it, and
:meth:`Recorder.trace` joins the calls since the last reset into a batch-first
:class:`Trace`.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
MAX_RECORD_BYTES = 2 * 1024**3  # memory a recorded run() may fill with its trace


@dataclass
class Trace:
    """Per-tick record of a run, batch-first.

    Attributes:
        t: (T,) time of each tick, s.
        s: (B, T) reference arc length, m.
        v: (B, T) reference path speed, m/s.
        r: (B, T, A) reference per axis, m.
        x: (B, T, A) true axis positions, m.
        u: (B, T, A) saturated control command.
        eps: (B, T, C) true contour error (signed in 2-D), m.
        eps_est: (B, T, C) contour error seen by the CCC, m.
    """

    t: Array
    s: Array
    v: Array
    r: Array
    x: Array
    u: Array
    eps: Array
    eps_est: Array

    def window(self, start: int, ticks: int | None = None) -> Trace:
        """Rows ``[start, start + ticks)`` (to the end if None) as a trace of their own.

        Copied, so that it does not keep the whole record alive; its time starts at 0.

        Raises:
            ValueError: for a negative ``start`` or ``ticks`` (rows no longer kept, or none).
        """
        if start < 0 or (ticks is not None and ticks < 0):
            raise ValueError(f"a trace window needs start >= 0 and ticks >= 0, got start "
                             f"{start!r}, ticks {ticks!r}")
        rows = slice(start, None if ticks is None else start + ticks)
        n = len(self.t[rows])
        return Trace(t=self.t[:n].copy(),
                     **{f.name: getattr(self, f.name)[:, rows].copy() for f in fields(Trace)[1:]})


class Recorder:
    """The record buffers of one loop's calls since its last reset.

    Args:
        batch: Number of members B.
        n_axes: Axes A.
        n_contours: Contours C.
    """

    def __init__(self, batch: int, n_axes: int, n_contours: int) -> None:
        self.batch, self.n_axes, self.n_contours = batch, n_axes, n_contours
        self.width = 2 + 3 * n_axes + 2 * n_contours  # columns of a row
        self.empty = np.zeros((batch, 0, self.width))  # what a call without record writes
        self.calls: list[Array] = []

    def new(self, n_ticks: int) -> Array:
        """A zero buffer (B, n_ticks, width) for one call."""
        return np.zeros((self.batch, n_ticks, self.width))

    def clear(self) -> None:
        """Forget the calls kept so far (a reset of every member)."""
        self.calls = []

    def keep(self, rec: Array, ended: NDArray[np.bool_], end: Array, local: NDArray[np.int64],
             paused: NDArray[np.bool_] | None = None) -> None:
        """Keep a recorded call; rows a member never wrote are NaN, not data.

        Args:
            rec: The call's buffer.
            ended: (B,) members that arrived or failed.
            end: (B,) the tick of each ended member's end, on its own clock.
            local: (B,) each member's own clock at the call's first tick.
            paused: (B,) members that sat the call out (None: none).
        """
        for b in np.flatnonzero(ended):
            first = int(end[b]) - local[b]
            rec[b, max(first, 0) :] = np.nan
        if paused is not None:
            rec[paused] = np.nan
        self.calls.append(rec)

    def drop(self, rows: int) -> None:
        """Forget the first ``rows`` rows kept (their memory)."""
        while rows > 0 and self.calls:
            first = self.calls[0]
            if first.shape[1] <= rows:
                rows -= first.shape[1]
                self.calls.pop(0)
            else:
                self.calls[0], rows = first[:, rows:].copy(), 0

    def check_size(
        self, ticks: int, what: str, lower: str = "run without record=True, or a shorter max_time"
    ) -> None:
        """Raise ValueError if recording ``ticks`` ticks would exceed MAX_RECORD_BYTES.

        Args:
            ticks: Ticks of the run.
            what: The run's length in words, to start the message.
            lower: What the user can do instead, to end it.
        """
        need = ticks * self.batch * self.width * 8
        if need > MAX_RECORD_BYTES:
            raise ValueError(f"{what}: recording it needs {need / 2**30:.3g} GiB, more than "
                             f"{MAX_RECORD_BYTES / 2**30:.3g} GiB; {lower}")

    def trace(self, ts: float, member: int | None = None) -> Trace:
        """The kept calls as one :class:`Trace`, at ``ts`` seconds per tick.

        Args:
            ts: Seconds per tick.
            member: Only this member's rows (batch dimension 1, copied out of the calls, so
                that a long run's other members are not copied too); None: every member.
        """
        a, c = self.n_axes, self.n_contours
        rows = slice(None) if member is None else slice(member, member + 1)
        rec = (np.concatenate([call[rows] for call in self.calls], axis=1) if self.calls
               else np.zeros((self.batch if member is None else 1, 0, self.width)))
        base = 2 + 3 * a
        return Trace(
            t=np.arange(rec.shape[1], dtype=np.float64) * ts,
            s=rec[..., 0],
            v=rec[..., 1],
            r=rec[..., 2 : 2 + a],
            x=rec[..., 2 + a : 2 + 2 * a],
            u=rec[..., 2 + 2 * a : base],
            eps=rec[..., base : base + 2 * c : 2],
            eps_est=rec[..., base + 1 : base + 2 * c : 2],
        )
