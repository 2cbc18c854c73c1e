"""How a servo loop's arrays are sized and first filled: axis rows, state shapes, path, config.

The functions here turn a stage, a path and its program into the arrays of
:class:`contour_gym.loop.ServoLoop`'s blobs (:mod:`contour_gym.loop.state` names them): the
per-axis plant rows repeated per member, the shapes of the states and accumulators, the int
arrays, the path's float blob, and the run's scalar settings row.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from contour_gym import motion
from contour_gym._blob import Blob
from contour_gym.contour._history import HIST_WIDTH
from contour_gym.loop.state import (
    CONFIG,
    FOOT,
    LAST,
    MEM,
    MEMBER_PATH,
    PATH_FLOATS,
    WORK,
)
from contour_gym.metrics import ACC_A, ACC_C
from contour_gym.paths import Path
from contour_gym.plant._kernel import AX, STATE
from contour_gym.plant.friction import law_for
from contour_gym.plant.stage import (
    Stage,
    axis_row,
    disturbance_row,
    friction_row,
    ripple_rows,
    zoh_matrices,
)
from contour_gym.servo.compensation import STATE as COMP_STATE

if TYPE_CHECKING:
    from contour_gym.loop.options import LoopOptions
    from contour_gym.servo import PIDGains

Array = NDArray[np.float64]
Shape = tuple[int, ...]
class HasArrays(Protocol):
    """What :func:`member_bytes` measures: a loop (:meth:`ServoLoop.array_bytes`)."""

    def array_bytes(self) -> int:
        """Bytes of its arrays."""


MEMBER_OBJECT_BYTES = 3000
"""Memory of a member's Python objects beside its arrays, bytes: its random generators and
their seed sequences (0.57 + 0.48 kB each, measured with numpy 2), the loop's and an env's."""
BAND_INCLUSIVE = 1.0 + 1e-9
"""The in-position band's factor: a reading exactly on the band (a whole number of encoder
counts from the end) is in position, as a controller comparing counts decides, not by the
last bit of a float difference (a machine resting that many counts away was in position or not
by rounding)."""


def axis_arrays(
    stage: Stage, batch: int, friction_code: Mapping[str, int], ideal: bool
) -> dict[str, Array]:
    """The plant's per-axis rows, repeated per member: ax_p, ad, bd, fr_p, rip, dist.

    Args:
        stage: The machine.
        batch: Number of members B.
        friction_code: The loop's code of each friction law, by name.
        ideal: Drop the rig's encoder and noise from the axis rows.
    """
    ax_p = np.stack(
        [axis_row(x, friction_code[law_for(x.friction).name], ideal=ideal) for x in stage.axes]
    )
    ax_p[:, AX.in_ticks] = in_position_ticks(stage, ideal)
    ax_p = np.repeat(ax_p[None], batch, axis=0)
    ad, bd = zoh_matrices(ax_p, stage.ts / stage.substeps)
    each = {
        "fr_p": np.stack([friction_row(x) for x in stage.axes]),
        "rip": np.stack([ripple_rows(x) for x in stage.axes]),
        "dist": np.stack([disturbance_row(x, stage.ts) for x in stage.axes]),
    }
    return {"ax_p": ax_p, "ad": ad, "bd": bd,
            **{k: np.repeat(v[None], batch, axis=0) for k, v in each.items()}}


def in_position_ticks(stage: Stage, ideal: bool = False) -> Array:
    """(A,) per axis, the ticks the in-position check reads an axis's speed over.

    The fewest over which one encoder count is no faster than the stage's
    ``in_position_speed`` (1 for an exact encoder, or one fine enough): over a single tick a
    coarse encoder reads only "moved a count" (50 um per 0.5 ms is 0.1 m/s), and an axis
    ringing through the end point at up to that speed would pass for still.
    """
    step = np.array([0.0 if ideal else x.encoder_resolution for x in stage.axes])
    ticks = np.ceil(step / (stage.in_position_speed * stage.ts) * (1.0 - 1e-9))
    return np.maximum(ticks, 1.0)


def contour_offsets(stage: Stage) -> Array:
    """(C, 3) offset of each contour's origin from the axes' (zero past its dimension), m."""
    out = np.zeros((len(stage.contours), 3))
    for i, con in enumerate(stage.contours):
        if con.offset:
            out[i, : con.dim] = con.offset
    return out


# rows after each part's scratch, unused: parts written on threads share no cache line (on 2
# threads at B = 1024, adjacent scratch made the loop 18 % slower than on one)
WORK_PAD = 8


def state_shapes(
    stage: Stage, batch: int, ctrl_width: int, ccc_width: int, parts: int = 1
) -> dict[str, Shape]:
    """Shapes of the float blob's states, accumulators and scratch arrays.

    Args:
        stage: The machine.
        batch: Number of members B.
        ctrl_width: The axis controller's state size.
        ccc_width: The CCC law's state size.
        parts: Slices of the batch that may run at once, each on its own scratch (``work``).
    """
    b, c, a = batch, len(stage.contours), stage.n_axes
    return {
        "ax_s": (b, a, STATE.size), "ctrl_s": (b, a, ctrl_width),
        "comp_s": (b, a, COMP_STATE.size), "ccc_s": (b, c, 3, ccc_width),
        "hist": (b, HIST_WIDTH), "ip_s": (b, motion.IP_STATE.size), "foot": (b, c, FOOT.size),
        "last": (b, c, LAST.size), "acc_c": (b, c, ACC_C.size), "acc_a": (b, a, ACC_A.size),
        "ep_c": (b, c, ACC_C.size), "ep_a": (b, a, ACC_A.size), "u_cmd": (b, a),
        "y_last": (b, a), "x_ring": (b, int(in_position_ticks(stage).max()), a),
        "mem": (b, MEM.size), "work": (parts, WORK.size + WORK_PAD, a),
    }


def contour_axes(stage: Stage) -> NDArray[np.int64]:
    """(C, 3) the axis of each contour coordinate (-1 past the contour's dimension)."""
    c_axes = np.full((len(stage.contours), 3), -1, dtype=np.int64)
    for i, con in enumerate(stage.contours):
        c_axes[i, : con.dim] = con.axes
    return c_axes


def filled_blob(names: Sequence[str], values: Mapping[str, NDArray[np.generic]],
                shapes: Mapping[str, Shape], dtype: type = np.float64) -> Blob:
    """A blob of the arrays ``names`` in this order: ``values`` copied in, the rest zero.

    Args:
        names: The blob's arrays, in layout order.
        values: Initial values of some of them (their shapes are the arrays').
        shapes: Shapes of the others.
        dtype: Element type.
    """
    every = {**{k: v.shape for k, v in values.items()}, **shapes}
    blob = Blob([(name, every[name]) for name in names], dtype)
    for name, value in values.items():
        blob.views[name][...] = value
    return blob


def path_bank(
    paths: Sequence[Path], programs: Sequence[motion.Program], slots: NDArray[np.int64]
) -> tuple[Blob, NDArray[np.int64], NDArray[np.int64]]:
    """The path bank: float blob, segment kinds, and each member's row of ``p_at``.

    Args:
        paths: The distinct paths the members run (each stored once, in this order).
        programs: Their programs.
        slots: Member ``b`` runs ``paths[slots[b]]``.

    Returns:
        The float blob (:data:`contour_gym.loop.state.PATH_FLOATS`: the tables and programs one
        after the other, the time law of ``paths[0]``, every member's path scalars), the
        segment kinds, and ``p_at`` (B, 3): each member's first segment, its number of
        segments and its first ``s0`` entry (:data:`contour_gym.loop.state.P_AT`).
    """
    tables = [p.table for p in paths]
    count = np.array([t.n_segments for t in tables], dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    names = ("feed", "flags", "vcap", "vj", "wait", "dwell")
    each = [dict(zip(names, prog.arrays(), strict=True)) for prog in programs]
    values = {name: np.concatenate([e[name] for e in each]) for name in names}
    for name in ("s0", "data", "bound"):
        values[name] = np.concatenate([getattr(t, name) for t in tables])
    law = paths[0].time_law
    values["law_s"] = law.s if law is not None else np.zeros(1)
    values["law_v"] = law.v if law is not None else np.zeros(1)
    slot = np.asarray(slots, dtype=np.int64)
    scalars = [MEMBER_PATH.row(length=p.length, closed=float(p.closed)) for p in paths]
    values["member"] = np.stack(scalars)[slot]
    blob = filled_blob([name for name, _ in PATH_FLOATS], values, {})
    kinds = np.ascontiguousarray(np.concatenate([t.kind for t in tables]), dtype=np.int64)
    p_at = np.stack([first[slot], count[slot], first[slot] + slot], axis=1)
    return blob, kinds, p_at


def config_row(stage: Stage, path: Path, opts: LoopOptions, record: bool, search: bool,
               codes: Mapping[str, float]) -> Array:
    """The run's scalar settings row (:data:`contour_gym.loop.state.CONFIG`).

    Args:
        stage: The machine.
        path: The contour.
        opts: The loop's options.
        record: Whether the kernel writes the per-tick record.
        search: Whether the estimator searches for the foot point.
        codes: The component code of each coded config column.
    """
    exact = opts.ideal or not any(
        x.encoder_resolution > 0 or x.noise_std > 0 for x in stage.axes)
    every = 1 if opts.sample_period is None else max(1, round(opts.sample_period / stage.ts))
    return CONFIG.row(
        ts=stage.ts, nsub=stage.substeps, dim=path.dim, meas_exact=float(exact),
        delay=0.0 if opts.ideal else float(stage.delay_ticks),
        inj_ref=float(opts.ccc_injection == "reference"), record=float(record),
        settle_ticks=math.ceil(opts.settle_time / stage.ts),
        in_band=stage.in_position * BAND_INCLUSIVE, in_speed=stage.in_position_speed,
        law_dt=1.0 if path.time_law is None else path.time_law.dt,
        sample_every=every, search=float(search), **codes,
    )


def check_sizes(stage: Stage, path: Path, axis_gains: Sequence[PIDGains], batch: Any) -> None:
    """Raise ValueError unless the batch size, path dimension and axis gains fit the stage."""
    if not isinstance(batch, (int, np.integer)) or batch < 1:
        raise ValueError(f"batch_size must be a positive int, got {batch!r}")
    if path.dim != stage.dim:
        raise ValueError(
            f"path {path.name!r} is {path.dim}-D but stage {stage.name!r} draws "
            f"{stage.dim}-D contours"
        )
    if len(axis_gains) != stage.n_axes:
        raise ValueError(f"need {stage.n_axes} axis gains, got {len(axis_gains)}")


def member_bytes(make: Callable[[int], HasArrays]) -> float:
    """Memory one more member costs a loop, bytes: measured on ``make(2)`` against ``make(1)``.

    Its arrays (:meth:`ServoLoop.array_bytes`; a loop's tables and scratch are shared) and
    :data:`MEMBER_OBJECT_BYTES` of Python objects. ``make(b)``: a loop of ``b`` members.
    """
    return make(2).array_bytes() - make(1).array_bytes() + MEMBER_OBJECT_BYTES
