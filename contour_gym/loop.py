"""ServoLoop: the batched closed loop of DESIGN.md, one servo tick at a time.

It packs a stage, a path, per-axis PIDs, the CCC and the interpolator into arrays with a
leading batch dimension ``B`` and runs the compiled kernel of :mod:`contour_gym._loopkernel`.
Parameters that optimisers and agents search (CCC gains, axis gains, feedrate) may differ per
batch member. Random numbers come only from one ``numpy.random.Generator`` per member, spawned
from the seed given to :meth:`ServoLoop.reset`, so a member's result depends only on its own
seed and parameters, never on ``B``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import _loopkernel as LK
from contour_gym import motion
from contour_gym._blob import Blob
from contour_gym._validate import as_finite_array
from contour_gym.ccc import ccc_params
from contour_gym.contour import _kernel as CK
from contour_gym.contour import build_estimator
from contour_gym.metrics import ErrorSums, metrics_from_sums
from contour_gym.paths import Path
from contour_gym.plant import _kernel as PK
from contour_gym.plant.params import MAX_HARMONICS
from contour_gym.plant.stage import Stage, axis_row, disturbance_row, zoh_matrices
from contour_gym.servo import PIDGains, build_controller
from contour_gym.servo import _kernel as SK

Array = NDArray[np.float64]
NOISE_CHUNK = 256  # ticks of normals drawn per member at a time


@dataclass
class Trace:
    """Per-tick record of a run, batch-first.

    Attributes:
        t: (T,) time of each tick, s.
        s: (B, T) reference arc length, m.
        v: (B, T) reference path speed, m/s.
        r: (B, T, A) reference per axis, m.
        x: (B, T, A) true axis positions, m.
        u: (B, T, A) saturated control.
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


class _NoiseSource:
    """Per-member standard normals, drawn in chunks, each member with its own read position.

    A member's numbers are its own generator's normal stream consumed in order (numpy fills
    arrays sequentially, so chunk sizes do not matter): results never depend on B, on how a
    run is cut into calls, or on other members' resets and pauses.
    """

    def __init__(self, batch: int, width: int, active: bool) -> None:
        self.width, self.active = width, active
        self.gens: list[np.random.Generator | None] = [None] * batch
        self.buf = np.zeros((batch, NOISE_CHUNK if active else 0, width))
        self.pos = np.zeros(batch, dtype=np.intp)  # next unread row per member
        self.end = np.zeros(batch, dtype=np.intp)  # end of the valid rows per member

    def reseed(self, members: NDArray[np.intp], gens: list[np.random.Generator]) -> None:
        for b, g in zip(members, gens, strict=True):
            self.gens[b] = g
            self.pos[b] = self.end[b] = 0  # nothing left: the next take draws fresh

    def take(self, n: int, running: NDArray[np.bool_]) -> Array:
        """(B, n, width) normals; only ``running`` members advance their streams."""
        if not self.active:
            return np.zeros((len(self.gens), 0, 0))
        if n > self.buf.shape[1]:
            grown = np.zeros((self.buf.shape[0], n, self.width))
            grown[:, : self.buf.shape[1]] = self.buf
            self.buf = grown
        cap = self.buf.shape[1]
        for b in np.flatnonzero(running & (self.pos + n > self.end)):
            rest = self.buf[b, self.pos[b] : self.end[b]].copy()
            self.buf[b, : len(rest)] = rest
            self.buf[b, len(rest) :] = self.gens[b].standard_normal((cap - len(rest), self.width))  # type: ignore[union-attr]
            self.pos[b], self.end[b] = 0, cap
        rows = np.minimum(self.pos[:, None] + np.arange(n), cap - 1)
        out = self.buf[np.arange(len(self.gens))[:, None], rows]
        self.pos[running] += n
        return out


class ServoLoop:
    """Batched closed loop over one stage and one path.

    Args:
        stage: The machine.
        path: The contour; its dimension must match the stage's contours.
        axis_gains: One :class:`PIDGains` per axis.
        interpolator: Feedrate settings (the initial commanded feedrate for every member).
        batch_size: Number of members B.
        ccc_gains: Initial CCC gains, anything :func:`contour_gym.ccc.ccc_params` accepts.
        ccc_weights: Per-coordinate weights of the CCC output, broadcastable to (B, C, 3).
        record: Keep a per-tick :class:`Trace`.
        axis_controller: Name in :data:`contour_gym.servo.CONTROLLERS`.
        controller_options: Options of that controller.
        estimator: Contour error estimator feeding the CCC
            (:data:`contour_gym.contour.ESTIMATORS`); metrics always use the exact error.
        estimator_options: Options of that estimator.
    """

    # views into the float and int blobs (set by _attach_views; always written in place)
    ax_p: Array
    rip: Array
    dist: Array
    ad: Array
    bd: Array
    ax_s: Array
    ctrl_p: Array
    ctrl_s: Array
    ccc_p: Array
    ccc_w: Array
    ccc_s: Array
    est_p: Array
    hist: Array
    ip_p: Array
    ip_s: Array
    foot: Array
    last: Array
    acc_c: Array
    acc_a: Array
    ep_c: Array
    ep_a: Array
    u_last: Array
    y_last: Array
    work: Array
    c_off: Array
    c_axes: NDArray[np.int64]
    status: NDArray[np.int64]
    k_start: NDArray[np.int64]

    def __init__(
        self,
        stage: Stage,
        path: Path,
        axis_gains: Sequence[PIDGains],
        interpolator: motion.Interpolator,
        *,
        batch_size: int = 1,
        ccc_gains: ArrayLike | None = None,
        ccc_weights: ArrayLike = 1.0,
        record: bool = False,
        axis_controller: str = "pid",
        controller_options: dict[str, object] | None = None,
        estimator: str = "ground_truth",
        estimator_options: dict[str, object] | None = None,
    ) -> None:
        if not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
            raise ValueError(f"batch_size must be a positive int, got {batch_size!r}")
        if path.dim != stage.dim:
            raise ValueError(
                f"path {path.name!r} is {path.dim}-D but stage {stage.name!r} draws "
                f"{stage.dim}-D contours"
            )
        if len(axis_gains) != stage.n_axes:
            raise ValueError(f"need {stage.n_axes} axis gains, got {len(axis_gains)}")
        self.stage, self.path, self.batch_size, self.record = stage, path, int(batch_size), record
        self.interpolator = interpolator
        b, c, a = self.batch_size, len(stage.contours), stage.n_axes
        c_axes = np.full((c, 3), -1, dtype=np.int64)
        c_off = np.zeros((c, 3))
        for i, con in enumerate(stage.contours):
            c_axes[i, : con.dim] = con.axes
            if con.offset:
                c_off[i, : con.dim] = con.offset
        ax_p = np.repeat(np.stack([axis_row(x) for x in stage.axes])[None], b, axis=0)
        rip = np.zeros((b, a, MAX_HARMONICS, 3))
        for i, x in enumerate(stage.axes):
            if x.ripple is not None:
                rip[:, i] = x.ripple.as_array()
        dist = np.repeat(
            np.stack([disturbance_row(x, stage.ts) for x in stage.axes])[None], b, axis=0
        )
        ad, bd = zoh_matrices(ax_p, stage.ts / stage.substeps)
        self.ctrl_kind, ctrl_p = build_controller(
            axis_controller, stage, tuple(axis_gains), b, **(controller_options or {})
        )
        self.est_kind, est_p = build_estimator(estimator, **(estimator_options or {}))
        ccc_w = np.broadcast_to(as_finite_array(ccc_weights, "ccc_weights"), (b, c, 3))
        params = {
            "ax_p": ax_p, "rip": rip, "dist": dist, "ad": ad, "bd": bd, "ctrl_p": ctrl_p,
            "ccc_p": ccc_params(ccc_gains, b, c), "ccc_w": ccc_w, "est_p": est_p,
            "ip_p": interpolator.params(b), "c_off": c_off,
        }  # fmt: skip
        self._build_blobs(params, c_axes)
        self._meas_exact = not any(x.encoder_resolution > 0 or x.noise_std > 0 for x in stage.axes)
        self._rec_width = 2 + 3 * a + 2 * c
        self._no_record = np.zeros((b, 0, self._rec_width))
        self._no_noise = np.zeros((b, 0, 0))
        t = path.table
        # run_ticks' arguments that never change for this loop (built once: per-step cost)
        self._static_args = (
            stage.ts, stage.substeps, path.length, record, self._meas_exact, self.ctrl_kind,
            self.est_kind, t.kind, t.s0, t.data, t.bound, self._fblob.buffer,
            self._fblob.layout, self._iblob.buffer, self._iblob.layout,
        )  # fmt: skip
        self._nominal = (self.ax_p.copy(), self.dist.copy())
        self._start = np.zeros(a)
        start = path.point(0.0)
        for i in range(c):
            for j in range(stage.dim):
                self._start[c_axes[i, j]] = start[j] + c_off[i, j]
        self.reset(0)

    def _build_blobs(self, params: dict[str, Array], c_axes: NDArray[np.int64]) -> None:
        # every array the kernel touches lives in one of two blobs (see contour_gym._blob);
        # the attributes below are views, always written in place
        b, c, a = self.batch_size, len(self.stage.contours), self.stage.n_axes
        state_shapes = {
            "ax_s": (b, a, PK.N_ST), "ctrl_s": (b, a, SK.N_CS), "ccc_s": (b, c, 3, SK.N_CS),
            "hist": (b, CK.N_HIST + 1), "ip_s": (b, motion.N_IS), "foot": (b, c),
            "last": (b, c, 2), "acc_c": (b, c, 4), "acc_a": (b, a, 4), "ep_c": (b, c, 4),
            "ep_a": (b, a, 4), "u_last": (b, a), "y_last": (b, a), "work": (LK.N_W, a),
        }  # fmt: skip
        shapes = {**{k: v.shape for k, v in params.items()}, **state_shapes}
        self._fblob = Blob([(name, shapes[name]) for name in LK.FLOAT_ARRAYS])
        self._iblob = Blob(
            [("c_axes", c_axes.shape), ("status", (b,)), ("k_start", (b,))], np.int64
        )
        self._attach_views()
        for name, value in params.items():
            getattr(self, name)[...] = value
        self.c_axes[...] = c_axes

    def _attach_views(self) -> None:
        for name, view in {**self._fblob.views, **self._iblob.views}.items():
            setattr(self, name, view)
        self.sums = ErrorSums(self.ep_c, self.ep_a)

    def __getstate__(self) -> dict[str, object]:
        names = set(self._fblob.views) | set(self._iblob.views) | {"sums"}
        return {k: v for k, v in self.__dict__.items() if k not in names}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._attach_views()

    # ----------------------------------------------------------------- state
    def _restart_clock(self) -> None:
        self.tick = 0
        self._records: list[Array] = []
        self._noise = _NoiseSource(self.batch_size, 2 * self.stage.n_axes, self.stage.is_random)

    def reset(
        self, seed: int | Sequence[int] | None = None, members: ArrayLike | None = None
    ) -> None:
        """Put members at rest at the start of the path.

        Args:
            seed: An int (member ``i`` of the reset ones uses child ``i`` of
                ``SeedSequence(seed)``), one seed per reset member, or None for fresh entropy.
            members: Indices or boolean mask of the members to reset (default: all, which
                also restarts the loop's clock and recording).
        """
        if members is None:
            self._restart_clock()
            idx = np.arange(self.batch_size)
        else:
            idx = np.arange(self.batch_size)[np.asarray(members)].reshape(-1)
        for arr in (
            self.ctrl_s,
            self.ccc_s,
            self.foot,
            self.hist,
            self.last,
            self.u_last,
            self.y_last,
        ):
            arr[idx] = 0.0
        self.ax_s[idx] = 0.0
        self.ax_s[idx, :, PK.ST_X] = self._start
        self.y_last[idx] = self._start
        self.ip_s[idx] = motion.initial_state(len(idx))
        self.status[idx] = LK.STATUS_OK
        self.k_start[idx] = self.tick
        self.sums.contour[idx] = 0.0
        self.sums.axis[idx] = 0.0
        self._noise.reseed(idx, self._generators(seed, len(idx)))

    def _generators(
        self, seed: int | Sequence[int] | None, count: int
    ) -> list[np.random.Generator]:
        if seed is None or isinstance(seed, (int, np.integer)):
            children = np.random.SeedSequence(seed).spawn(count)
            return [np.random.default_rng(s) for s in children]
        seeds = list(seed)
        if len(seeds) != count:
            raise ValueError(f"need {count} seeds, got {len(seeds)}")
        return [np.random.default_rng(np.random.SeedSequence(int(s)).spawn(1)[0]) for s in seeds]

    # ------------------------------------------------------------ parameters
    def set_ccc_gains(self, gains: ArrayLike | None) -> None:
        """Set the CCC PID gains, broadcastable to (B, C, 3); None switches the CCC off."""
        self.ccc_p[...] = ccc_params(gains, self.batch_size, len(self.stage.contours))

    def set_feedrate(self, feedrate: ArrayLike) -> None:
        """Command a feedrate (m/s), scalar or (B,); the interpolator ramps to it."""
        f = as_finite_array(feedrate, "feedrate")
        if np.any(f < 0):
            raise ValueError(f"feedrate must be >= 0, got {f.min()}")
        self.ip_p[:, motion.IP_F] = np.broadcast_to(f, (self.batch_size,))

    def set_controller_params(self, params: ArrayLike) -> None:
        """Set per-member axis controller parameters, broadcastable to (B, A, N_CP).

        The layout is the controller's (see :mod:`contour_gym.servo`); for ``pid`` the first
        four columns are (kp, ki, kd, kff).
        """
        p = as_finite_array(params, "controller params")
        try:
            self.ctrl_p[...] = np.broadcast_to(p, self.ctrl_p.shape)
        except ValueError as exc:
            raise ValueError(
                f"controller params of shape {p.shape} do not broadcast to {self.ctrl_p.shape}"
            ) from exc

    def set_plant_scaling(
        self,
        members: ArrayLike,
        *,
        mass: ArrayLike = 1.0,
        damping: ArrayLike = 1.0,
        force_constant: ArrayLike = 1.0,
        friction: ArrayLike = 1.0,
        disturbance: ArrayLike = 1.0,
    ) -> None:
        """Scale members' axis parameters relative to the stage's nominal values.

        Domain randomisation (axis mismatch, friction and disturbance levels; 002 section 4.2
        analyses gain and time-constant mismatch). Each factor broadcasts to (len(members),
        n_axes) and must be finite and > 0 (friction/disturbance >= 0).
        """
        idx = np.arange(self.batch_size)[np.asarray(members)].reshape(-1)
        shape = (len(idx), self.stage.n_axes)
        f = {
            k: np.broadcast_to(as_finite_array(v, k), shape)
            for k, v in dict(mass=mass, damping=damping, force_constant=force_constant,
                             friction=friction, disturbance=disturbance).items()
        }  # fmt: skip
        for k in ("mass", "damping", "force_constant"):
            if np.any(f[k] <= 0):
                raise ValueError(f"{k} scale must be > 0, got {f[k].min()}")
        for k in ("friction", "disturbance"):
            if np.any(f[k] < 0):
                raise ValueError(f"{k} scale must be >= 0, got {f[k].min()}")
        ax_p, dist = self._nominal[0][idx].copy(), self._nominal[1][idx].copy()
        ax_p[..., PK.AX_M] *= f["mass"]
        ax_p[..., PK.AX_B] *= f["damping"]
        ax_p[..., PK.AX_K] *= f["force_constant"]
        for col in (PK.AX_FC, PK.AX_FS, PK.AX_FV, PK.AX_S0, PK.AX_S2):
            ax_p[..., col] *= f["friction"]
        for col in (PK.DS_STEP_A, PK.DS_SIN_A, PK.DS_RND_STD):
            dist[..., col] *= f["disturbance"]
        self.ax_p[idx], self.dist[idx] = ax_p, dist
        self.ad[idx], self.bd[idx] = zoh_matrices(ax_p, self.stage.ts / self.stage.substeps)

    # ----------------------------------------------------------------- views
    @property
    def s(self) -> Array:
        """(B,) reference arc length, m."""
        return self.ip_s[:, motion.IS_S]

    @property
    def done(self) -> NDArray[np.bool_]:
        """(B,) whether the reference has reached the end of the path."""
        return self.ip_s[:, motion.IS_DONE] >= 0

    @property
    def failed(self) -> NDArray[np.bool_]:
        """(B,) whether a member diverged (its state left the physical range)."""
        return self.status != LK.STATUS_OK

    @property
    def cycle_time(self) -> Array:
        """(B,) time at which the reference reached the path end, s (inf if not yet)."""
        done = self.ip_s[:, motion.IS_DONE]
        return np.where(done >= 0, done * self.stage.ts, np.inf)

    @property
    def contour_error(self) -> Array:
        """(B, C) true contour error at the last tick, m."""
        return self.last[..., LK.LS_TRUE]

    @property
    def contour_error_estimate(self) -> Array:
        """(B, C) contour error the CCC saw at the last tick, m."""
        return self.last[..., LK.LS_EST]

    # ------------------------------------------------------------------- run
    def step(self, n_ticks: int, skip: ArrayLike | None = None) -> ErrorSums:
        """Run ``n_ticks`` ticks; return the error sums of just these ticks.

        Args:
            n_ticks: Ticks to run.
            skip: Indices or mask of members that sit this call out (their clocks do not
                advance); a vector env's members being auto-reset.

        Members that failed stay frozen; their metrics report ``inf``.
        """
        call = self.prepare(n_ticks, skip)
        LK.run_ticks(*self.kernel_args(call))
        self.complete(call)
        return ErrorSums(self.acc_c.copy(), self.acc_a.copy())

    def prepare(self, n_ticks: int, skip: ArrayLike | None = None) -> tuple[int, Any, Array, Array]:
        """Bookkeeping before a kernel call; returns what :meth:`kernel_args` needs."""
        if not isinstance(n_ticks, (int, np.integer)) or n_ticks < 0:
            raise ValueError(f"n_ticks must be a non-negative int, got {n_ticks!r}")
        paused = None
        if skip is not None:
            paused = np.zeros(self.batch_size, dtype=bool)
            paused[np.asarray(skip)] = True
            paused &= self.status == LK.STATUS_OK
            self.status[paused] = LK.STATUS_PAUSED
        if self.record:
            rec = np.zeros((self.batch_size, n_ticks, self._rec_width))
        else:
            rec = self._no_record
        if self._noise.active:
            noise = self._noise.take(n_ticks, self.status == LK.STATUS_OK)
        else:
            noise = self._no_noise
        return n_ticks, paused, noise, rec

    def kernel_args(self, call: tuple[int, Any, Array, Array]) -> tuple[Any, ...]:
        """Arguments of :func:`contour_gym._loopkernel.run_ticks` for a prepared call."""
        n_ticks, _, noise, rec = call
        return (n_ticks, self.tick, *self._static_args, noise, rec)

    def complete(self, call: tuple[int, Any, Array, Array]) -> None:
        """Bookkeeping after a kernel call (clock, paused members, recording)."""
        n_ticks, paused, _, rec = call
        self.tick += n_ticks
        if paused is not None:
            self.status[paused] = LK.STATUS_OK
            self.k_start[paused] += n_ticks
        if self.record:
            self._records.append(rec)

    def run(self, max_time: float | None = None, chunk: int = 2048) -> dict[str, Array]:
        """Run until every member has finished the path (or failed), then return metrics.

        Args:
            max_time: Stop after this much simulated time, s (default: 20x the nominal
                cycle time at the slowest commanded feedrate).
            chunk: Ticks per kernel call.

        Returns:
            :func:`contour_gym.metrics.metrics_from_sums` of the whole run, with failed
            members' values set to ``inf``.
        """
        if max_time is None:
            slowest = max(float(self.ip_p[:, motion.IP_F].min()), 1e-9)
            max_time = 20.0 * self.path.length / slowest + 1.0
        limit = int(np.ceil(max_time / self.stage.ts))
        while self.tick < limit and not np.all(self.done | self.failed):
            self.step(min(chunk, limit - self.tick))
        return self.metrics()

    def metrics(self) -> dict[str, Array]:
        """Metrics of everything run since the last reset (failed members -> inf)."""
        out = metrics_from_sums(self.sums, self.cycle_time)
        for v in out.values():
            v[self.failed] = np.inf
        return out

    def trace(self) -> Trace:
        """The per-tick record since reset (requires ``record=True``)."""
        if not self.record:
            raise ValueError("trace() needs ServoLoop(record=True)")
        a, c = self.stage.n_axes, len(self.stage.contours)
        rec = (
            np.concatenate(self._records, axis=1)
            if self._records
            else np.zeros((self.batch_size, 0, 2 + 3 * a + 2 * c))
        )
        base = 2 + 3 * a
        return Trace(
            t=np.arange(rec.shape[1], dtype=np.float64) * self.stage.ts,
            s=rec[..., 0],
            v=rec[..., 1],
            r=rec[..., 2 : 2 + a],
            x=rec[..., 2 + a : 2 + 2 * a],
            u=rec[..., 2 + 2 * a : base],
            eps=rec[..., base::2],
            eps_est=rec[..., base + 1 :: 2],
        )
