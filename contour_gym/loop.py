"""ServoLoop: the batched closed loop of DESIGN.md, one servo tick at a time.

It packs a stage, a path, the axis controllers, the estimator, the CCC and the interpolator
into arrays with a leading batch dimension ``B`` and runs the compiled kernel of
:mod:`contour_gym._loopkernel`, specialised to the components the loop uses
(:mod:`contour_gym._compile`). Parameters that optimisers and agents search (CCC gains, axis
gains, feed override) may differ per batch member. Random numbers come only from one
``numpy.random.Generator`` per member, spawned from the seed given to :meth:`ServoLoop.reset`,
so a member's result depends only on its own seed and parameters, never on ``B``.

The machine is a rig by default: the encoder quantises, noise is added where the axes have it,
and the command computed from sample k drives the plant from tick k + 1. ``ideal=True`` drops
all three (the papers' pure simulations).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import _compile, _precompile, _tiers, motion
from contour_gym._blob import Blob
from contour_gym._loopstate import ACC_A as ACC_A_SCHEMA
from contour_gym._loopstate import ACC_C as ACC_C_SCHEMA
from contour_gym._loopstate import (
    CF,
    CONFIG,
    FLOAT_NAMES,
    FOOT,
    FT,
    INT_NAMES,
    LS,
    MEM,
    PATH_FLOATS,
    REASON_DIVERGED,
    REASON_NAMES,
    REASON_TIME_CAP,
    STATUS_ARRIVED,
    STATUS_FAILED,
    STATUS_OK,
    STATUS_PAUSED,
    WORK,
    M,
)
from contour_gym._loopstate import LAST as LAST_SCHEMA
from contour_gym._validate import as_finite_array, choice, non_negative, positive, seed_value
from contour_gym.ccc import CCC_FAMILY, CCC_LAWS, INJECTIONS, ccc_params
from contour_gym.contour import ESTIMATORS, Estimator, get_estimator
from contour_gym.contour._history import HIST_WIDTH
from contour_gym.contour.base import ESTIMATOR_FAMILY
from contour_gym.metrics import ErrorSums, metrics_from_sums
from contour_gym.motion import IP, IS, build_program
from contour_gym.paths import Path
from contour_gym.plant._kernel import AX, DISTURBANCE, ST, STATE
from contour_gym.plant.friction import FRICTION_FAMILY, FRICTION_LAWS, law_for
from contour_gym.plant.params import AxisParams
from contour_gym.plant.stage import (
    Stage,
    axis_row,
    disturbance_row,
    friction_laws,
    friction_row,
    ripple_rows,
    zoh_matrices,
)
from contour_gym.servo import CONTROLLERS, PIDGains, build_controller, compensation
from contour_gym.servo.base import CONTROLLER_FAMILY
from contour_gym.servo.compensation import COMPENSATION_FAMILY
from contour_gym.servo.compensation import STATE as COMP_STATE
from contour_gym.servo.gains import as_pid_gains

Array = NDArray[np.float64]
# config columns holding the code of the loop's one component of each family
_CODED = {"ctrl": CONTROLLER_FAMILY, "est": ESTIMATOR_FAMILY, "ccc": CCC_FAMILY,
          "comp": COMPENSATION_FAMILY}  # fmt: skip
NOISE_CHUNK = 256  # ticks of normals drawn per member at a time
MAX_RUN_TICKS = 200_000_000  # ticks one run() may take (55 h of machine time at 1 kHz)
MAX_RECORD_BYTES = 2 * 1024**3  # memory a recorded run() may fill with its trace
LOOP_TEMPLATE = "contour_gym._loopkernel"  # the servo loop's kernel template (_compile)
DEFAULT_SETTLE = 1.0  # s the machine may take to get in position after the reference ends


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


class _NoiseSource:
    """Per-member standard normals, drawn in chunks, each member with its own read position.

    A member's numbers are its own generator's normal stream consumed in order (numpy fills
    arrays sequentially, so chunk sizes do not matter): results never depend on B, on how a
    run is cut into calls, or on other members' resets and pauses. The kernel reads member
    ``b``'s rows in place from ``pos[b]`` (the loop's ``noise_at``) and advances it.
    """

    def __init__(self, batch: int, width: int, active: bool) -> None:
        self.width, self.active = width, active
        self.gens: list[np.random.Generator | None] = [None] * batch
        self.buf = np.zeros((batch, NOISE_CHUNK if active else 0, width))
        self.end = np.zeros(batch, dtype=np.int64)  # end of the valid rows per member
        self.ahead = 0  # rows every member has left at least (a call takes n from each)

    def reseed(
        self, members: NDArray[np.intp], gens: list[np.random.Generator | None], pos: Any
    ) -> None:
        for b, g in zip(members, gens, strict=True):
            self.gens[b] = g
            pos[b] = self.end[b] = 0  # nothing left: the next take draws fresh
        self.ahead = 0

    def take(self, n: int, status: NDArray[np.int64], pos: Any) -> Array:
        """The buffer (B, rows, width): rows ``pos[b]`` on hold ``n`` for running members.

        Without noise, an empty buffer (B, 0, width).
        """
        if not self.active:
            return self.buf
        if n <= self.ahead:  # every member has its n rows: no array work on a short call
            self.ahead -= n
            return self.buf
        running = status == STATUS_OK
        if n > self.buf.shape[1]:
            grown = np.zeros((self.buf.shape[0], n, self.width))
            grown[:, : self.buf.shape[1]] = self.buf
            self.buf = grown
        cap = self.buf.shape[1]
        for b in np.flatnonzero(running & (pos + n > self.end)):
            rest = self.buf[b, pos[b] : self.end[b]].copy()
            self.buf[b, : len(rest)] = rest
            self.buf[b, len(rest) :] = self.gens[b].standard_normal((cap - len(rest), self.width))  # type: ignore[union-attr]
            pos[b], self.end[b] = 0, cap
        self.ahead = int((self.end - pos).min()) - n
        return self.buf


@dataclass(frozen=True)
class LoopOptions:
    """The loop's settings beyond the stage, path, gains and interpolator (see ServoLoop).

    Attributes:
        axis_controller: Name in :data:`contour_gym.servo.CONTROLLERS`.
        controller_options: Its options.
        estimator: Name in :data:`contour_gym.contour.ESTIMATORS`.
        estimator_options: Its options.
        ccc_law: Name in :data:`contour_gym.ccc.CCC_LAWS`.
        ccc_law_params: The law's parameters beyond kp, ki, kd.
        ccc_injection: ``"control"`` or ``"reference"`` (:mod:`contour_gym.ccc`).
        ideal: Drop the rig's encoder, noise and computation delay.
        path_control: ``"none"``, ``"G61"``, ``"G61.1"``, ``"G64"`` or None (the path's own).
        path_tolerance: G64 tolerance, m (None: the path's own or the default).
        use_program_feeds: Run a G-code part at its own F words.
        settle_time: Time allowed to get in position after the reference ends, s.
        sample_period: Sampling of P_e and P_eps, s (None: every tick).
    """

    axis_controller: str = "pid"
    controller_options: dict[str, Any] | None = None
    estimator: str = "ground_truth"
    estimator_options: dict[str, Any] | None = None
    ccc_law: str = "pid"
    ccc_law_params: dict[str, Any] | None = None
    ccc_injection: str = "control"
    ideal: bool = False
    path_control: str | None = None
    path_tolerance: float | None = None
    use_program_feeds: bool = True
    settle_time: float = DEFAULT_SETTLE
    sample_period: float | None = None


class ServoLoop:
    """Batched closed loop over one stage and one path.

    Args:
        stage: The machine.
        path: The contour; its dimension must match the stage's contours.
        axis_gains: One :class:`PIDGains` per axis (the baseline other controllers derive from).
        interpolator: Feedrate settings (the nominal feedrate and the machine's limits).
        batch_size: Number of members B.
        ccc_gains: Initial CCC gains (kp, ki, kd), anything :func:`contour_gym.ccc.ccc_params`
            accepts (None: no CCC).
        ccc_weights: Per-coordinate weights of the CCC output, broadcastable to (B, C, 3).
        record: Keep a per-tick :class:`Trace`.
        **options: The fields of :class:`LoopOptions` (axis controller, estimator, CCC law and
            injection, ``ideal``, path control, settle time, sample period). A path carrying a
            time law (:attr:`Path.time_law`) is run on it instead of the interpolator's feeds.
    """

    # views into the float and int blobs (contour_gym._loopstate; always written in place)
    ax_p: Array
    fr_p: Array
    rip: Array
    dist: Array
    ad: Array
    bd: Array
    ax_s: Array
    ctrl_p: Array
    ctrl_s: Array
    comp_p: Array
    comp_s: Array
    ccc_p: Array
    ccc_w: Array
    ccc_s: Array
    ccc_data: Array
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
    u_cmd: Array
    y_last: Array
    mem: Array
    work: Array
    c_off: Array
    c_axes: NDArray[np.int64]
    status: NDArray[np.int64]
    k_start: NDArray[np.int64]
    noise_at: NDArray[np.int64]

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
        **options: Any,
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
        stage.check_travel(path)  # before any array is sized
        self.opts = _options(options)
        self.stage, self.path, self.batch_size, self.record = stage, path, int(batch_size), record
        self.axis_gains = tuple(
            as_pid_gains(g, f"axis_gains[{i}]") for i, g in enumerate(axis_gains)
        )
        self.interpolator = interpolator
        b = self.batch_size
        self.controller, ctrl_p, comp_p = build_controller(
            self.opts.axis_controller, stage, self.axis_gains, b,
            **(self.opts.controller_options or {}),
        )  # fmt: skip
        self.estimator = get_estimator(self.opts.estimator, **(self.opts.estimator_options or {}))
        self.ccc_law = CCC_LAWS.get(self.opts.ccc_law)
        self.law_names = friction_laws(stage)
        self.program = build_program(
            path, interpolator, stage.ts, path_control=self.opts.path_control,
            path_tolerance=self.opts.path_tolerance,
            use_program_feeds=self.opts.use_program_feeds,
        )  # fmt: skip
        self._bind(bool(np.any(comp_p[..., compensation.C.mode] != compensation.NONE)))
        params = self._parameter_arrays(ctrl_p, comp_p, ccc_gains, ccc_weights)
        self._build_blobs(params)
        self._build_path_blob()
        self._config = self._config_row()
        self._kernel: ModuleType | None = None  # chosen on first use (kernel)
        self._rec_width = 2 + 3 * stage.n_axes + 2 * len(stage.contours)
        self._marked = False  # mark_compiled done (advance)
        self._no_record = np.zeros((b, 0, self._rec_width))
        self._nominal = (self.ax_p.copy(), self.fr_p.copy(), self.dist.copy())
        self.reset(0)

    # --------------------------------------------------------------- building
    def _parameter_arrays(
        self, ctrl_p: Array, comp_p: Array, ccc_gains: ArrayLike | None, ccc_weights: ArrayLike
    ) -> dict[str, Array]:
        stage, b, ideal = self.stage, self.batch_size, self.opts.ideal
        c = len(stage.contours)
        code = dict(zip(self.law_names, self.codes[FRICTION_FAMILY.name], strict=True))
        ax_p = np.stack(
            [axis_row(x, code[law_for(x.friction).name], ideal=ideal) for x in stage.axes]
        )
        ax_p = np.repeat(ax_p[None], b, axis=0)
        ad, bd = zoh_matrices(ax_p, stage.ts / stage.substeps)
        each = {
            "fr_p": np.stack([friction_row(x) for x in stage.axes]),
            "rip": np.stack([ripple_rows(x) for x in stage.axes]),
            "dist": np.stack([disturbance_row(x, stage.ts) for x in stage.axes]),
        }
        law_params = self.opts.ccc_law_params or {}
        ccc_w = np.broadcast_to(as_finite_array(ccc_weights, "ccc_weights"), (b, c, 3))
        params = {
            "ax_p": ax_p, "ad": ad, "bd": bd, "ctrl_p": ctrl_p, "comp_p": comp_p,
            "ccc_p": ccc_params(ccc_gains, b, c, self.ccc_law, **law_params), "ccc_w": ccc_w,
            "ccc_data": self.ccc_law.table(), "est_p": self.estimator.params,
            "ip_p": self.interpolator.params(b), "c_off": self._contour_offsets(),
            **{k: np.repeat(v[None], b, axis=0) for k, v in each.items()},
        }  # fmt: skip
        return params

    def _contour_offsets(self) -> Array:
        out = np.zeros((len(self.stage.contours), 3))
        for i, con in enumerate(self.stage.contours):
            if con.offset:
                out[i, : con.dim] = con.offset
        return out

    def _build_blobs(self, params: dict[str, Array]) -> None:
        # every array the kernel touches lives in one of two blobs (contour_gym._blob); the
        # attributes named in FLOAT_NAMES / INT_NAMES are views, always written in place
        stage, b = self.stage, self.batch_size
        c, a = len(stage.contours), stage.n_axes
        state = {
            "ax_s": (b, a, STATE.size), "ctrl_s": (b, a, self.controller.state.size),
            "comp_s": (b, a, COMP_STATE.size), "ccc_s": (b, c, 3, self.ccc_law.state.size),
            "hist": (b, HIST_WIDTH), "ip_s": (b, motion.IP_STATE.size), "foot": (b, c, FOOT.size),
            "last": (b, c, LAST_SCHEMA.size), "acc_c": (b, c, ACC_C_SCHEMA.size),
            "acc_a": (b, a, ACC_A_SCHEMA.size), "ep_c": (b, c, ACC_C_SCHEMA.size),
            "ep_a": (b, a, ACC_A_SCHEMA.size), "u_cmd": (b, a), "y_last": (b, a),
            "mem": (b, MEM.size), "work": (WORK.size, a),
        }  # fmt: skip
        shapes = {**{k: v.shape for k, v in params.items()}, **state}
        self._fblob = Blob([(name, shapes[name]) for name in FLOAT_NAMES])
        c_axes = np.full((c, 3), -1, dtype=np.int64)
        for i, con in enumerate(stage.contours):
            c_axes[i, : con.dim] = con.axes
        int_shapes = {"c_axes": c_axes.shape, "status": (b,), "k_start": (b,), "noise_at": (b,)}
        self._iblob = Blob([(name, int_shapes[name]) for name in INT_NAMES], np.int64)
        self._attach_views()
        for name, value in params.items():
            getattr(self, name)[...] = value
        self.c_axes[...] = c_axes

    def _build_path_blob(self) -> None:
        t, law = self.path.table, self.path.time_law
        names = ("feed", "flags", "vcap", "vj", "wait", "dwell")
        values = dict(zip(names, self.program.arrays(), strict=True))
        values.update(s0=t.s0, data=t.data, bound=t.bound)
        values["law_s"] = law.s if law is not None else np.zeros(1)
        values["law_v"] = law.v if law is not None else np.zeros(1)
        self._pblob = Blob([(name, values[name].shape) for name, _ in PATH_FLOATS])
        for name, _ in PATH_FLOATS:
            self._pblob.views[name][...] = values[name]
        self._kind = np.ascontiguousarray(t.kind, dtype=np.int64)

    def _config_row(self) -> Array:
        stage, o = self.stage, self.opts
        exact = o.ideal or not any(x.encoder_resolution > 0 or x.noise_std > 0 for x in stage.axes)
        every = 1 if o.sample_period is None else max(1, round(o.sample_period / stage.ts))
        return CONFIG.row(
            ts=stage.ts, nsub=stage.substeps, dim=self.path.dim, length=self.path.length,
            closed=float(self.path.closed), meas_exact=float(exact),
            delay=0.0 if o.ideal else float(stage.delay_ticks),
            inj_ref=float(o.ccc_injection == "reference"), record=float(self.record),
            settle_ticks=math.ceil(o.settle_time / stage.ts), in_band=stage.in_position,
            in_speed=stage.in_position_speed,
            law_dt=1.0 if self.path.time_law is None else self.path.time_law.dt,
            sample_every=every, search=float(self.estimator.kind.foot is None),
            **{key: self.codes[fam.name][0] for key, fam in _CODED.items()},
        )  # fmt: skip

    def _bind(self, compensates: bool) -> None:
        # the kernel's slots and this loop's component codes (contour_gym._compile.bind)
        self._compensates = compensates
        uses: dict[_compile.Family, list[Any]] = {
            CONTROLLER_FAMILY: [self.controller], ESTIMATOR_FAMILY: [self.estimator.kind],
            CCC_FAMILY: [self.ccc_law], COMPENSATION_FAMILY: [compensates],
            FRICTION_FAMILY: [FRICTION_LAWS.get(n) for n in self.law_names],
        }  # fmt: skip
        self._slots, self.codes = _compile.bind(uses)
        generic = _compile.is_generic(self._slots)
        self._own_slots = _compile.bind(uses, own=True)[0] if generic else self._slots

    def describe(self) -> str:
        """The components of this loop, in one line."""
        return (
            f"{self.controller.name} axes, {self.estimator.name} estimator, "
            f"{self.ccc_law.name} CCC, friction {'+'.join(self.law_names)}"
        )

    @property
    def kernel(self) -> ModuleType:
        """The compiled kernel module this loop runs on (chosen on first use: :meth:`kernels`)."""
        if self._kernel is None:
            own, builtins = self.kernels()
            self._kernel = own if builtins is None else _tiers.choose(own, builtins, "loop", self)
        return self._kernel

    def kernels(self) -> tuple[ModuleType, Callable[[], ModuleType] | None]:
        """This loop's own kernel module, and a maker of the built-ins' kernel module.

        The maker is None when the loop uses a component of the user's (its own kernel is
        then the only one). :mod:`contour_gym._tiers` says which one runs.
        """
        own = _compile.specialise(LOOP_TEMPLATE, self._own_slots)
        if self._own_slots is self._slots:
            return own, None
        return own, self._builtins_kernel

    def _builtins_kernel(self) -> ModuleType:
        _precompile.ensure("loop")  # once per installation, in worker processes
        return _compile.specialise(LOOP_TEMPLATE, self._slots)

    def use_kernel(self, kernel: ModuleType) -> None:
        """Run on ``kernel``, one of :meth:`kernels` (an env task chooses with its own kernel)."""
        self._kernel = kernel
        self._marked = False

    def compile_own(self) -> None:
        """Run one tick on this loop's own kernel (a background worker: :mod:`_tiers`)."""
        self.use_kernel(self.kernels()[0])
        self.reset(0)
        self.step(1)

    def _attach_views(self) -> None:
        for name, view in {**self._fblob.views, **self._iblob.views}.items():
            setattr(self, name, view)
        self.sums = ErrorSums(self.ep_c, self.ep_a)

    def __getstate__(self) -> dict[str, object]:
        # components are pickled by name (and the estimator with its option row) and looked
        # up in their registries again on load
        names = set(self._fblob.views) | set(self._iblob.views) | {"sums", "_kernel"}
        state = {k: v for k, v in self.__dict__.items() if k not in names}
        state["controller"] = self.controller.name
        state["ccc_law"] = self.ccc_law.name
        state["estimator"] = (self.estimator.name, self.estimator.params)
        del state["_slots"]  # the codes stay: the blob's axis rows hold the friction codes
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self.controller = CONTROLLERS.get(state["controller"])  # type: ignore[arg-type]
        self.ccc_law = CCC_LAWS.get(state["ccc_law"])  # type: ignore[arg-type]
        est_name, est_params = cast(tuple[str, Array], state["estimator"])
        self.estimator = Estimator(ESTIMATORS.get(est_name), est_params)
        self._attach_views()
        codes = self.codes
        self._bind(self._compensates)
        if codes != self.codes:
            raise ValueError(f"the components' codes changed since pickling: {codes} -> "
                             f"{self.codes}")
        self._kernel = None
        self._marked = False

    # ----------------------------------------------------------------- state
    def _restart_clock(self) -> None:
        self.tick = 0
        self._records: list[Array] = []
        active = self.stage.is_random if not self.opts.ideal else any(
            x.disturbance is not None and x.disturbance.is_random for x in self.stage.axes
        )  # fmt: skip
        self._noise = _NoiseSource(self.batch_size, 2 * self.stage.n_axes, active)

    def start_positions(self) -> Array:
        """(A,) axis positions at the path start (contour offsets included), m."""
        out = np.zeros(self.stage.n_axes)
        start = self.path.point(0.0)
        for i, con in enumerate(self.stage.contours):
            for j in range(con.dim):
                out[con.axes[j]] = start[j] + self.c_off[i, j]
        return out

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
        start = self.start_positions()
        for arr in (self.ctrl_s, self.comp_s, self.ccc_s, self.hist, self.last, self.u_cmd,
                    self.mem, self.ax_s, self.foot):  # fmt: skip
            arr[idx] = 0.0
        self.ax_s[idx, :, ST.x] = start
        self.y_last[idx] = start
        q0 = self.path.point(0.0)
        self.foot[idx, :, FT.qx : FT.qx + self.path.dim] = q0
        self.foot[idx, :, FT.e_qx : FT.e_qx + self.path.dim] = q0
        self.ip_s[idx] = motion.initial_state(len(idx))
        self.status[idx] = STATUS_OK
        self.k_start[idx] = self.tick
        self.sums.contour[idx] = 0.0
        self.sums.axis[idx] = 0.0
        self._noise.reseed(idx, self._generators(seed, len(idx)), self.noise_at)

    def _generators(
        self, seed: int | Sequence[int] | None, count: int
    ) -> list[np.random.Generator | None]:
        """The reset members' generators, checked seeds.

        None each when the loop draws no noise: a tuner's reset of 16 members spent 0.2 ms
        making generators it never used.
        """
        if seed is None or isinstance(seed, (int, np.integer)):
            root = np.random.SeedSequence(None if seed is None else seed_value(seed))
            children = root.spawn(count) if self._noise.active else []
        else:
            if not isinstance(seed, (Sequence, np.ndarray)) or isinstance(seed, (str, bytes)):
                raise ValueError("seed must be a non-negative int, a sequence of them or None, "
                                 f"got {seed!r}")  # fmt: skip
            roots = [np.random.SeedSequence(seed_value(s)) for s in seed]
            if len(roots) != count:
                raise ValueError(f"need {count} seeds, got {len(roots)}")
            children = [r.spawn(1)[0] for r in roots] if self._noise.active else []
        if not self._noise.active:
            return [None] * count
        return [np.random.default_rng(c) for c in children]

    # ------------------------------------------------------------ parameters
    def set_ccc_gains(self, gains: ArrayLike | None) -> None:
        """Set the CCC gains (kp, ki, kd), broadcastable to (B, C, 3); None switches it off."""
        rows = ccc_params(gains, self.batch_size, len(self.stage.contours))
        self.ccc_p[..., :3] = rows[..., :3]

    def set_ccc_params(self, **params: ArrayLike) -> None:
        """Set the CCC law's named parameters, each broadcastable to (B, C)."""
        schema = self.ccc_law.params
        schema.check_names(params)
        for name, value in params.items():
            arr = np.broadcast_to(as_finite_array(value, name), self.ccc_p.shape[:2])
            for x in np.unique(arr):
                schema.value(name, x)
            self.ccc_p[..., schema.names.index(name)] = arr

    def set_ccc_weights(self, weights: ArrayLike) -> None:
        """Set per-member CCC output weights, broadcastable to (B, C, 3).

        ``weights[b, c, i]`` scales what contour ``c``'s CCC adds to coordinate ``i`` of
        member ``b`` (:mod:`contour_gym.ccc`; e.g. 003's compensator gains K_cix, K_ciy with
        ``kp = 1``).

        Raises:
            ValueError: for a NaN or infinite weight or a shape that does not broadcast.
        """
        _assign(self.ccc_w, weights, "ccc_weights")

    @property
    def nominal_feedrate(self) -> float:
        """The programmed cutting feedrate the override refers to, m/s."""
        return self.program.nominal

    def set_feedrate(self, feedrate: ArrayLike) -> None:
        """Command a feedrate (m/s), scalar or (B,): the override ``F / nominal_feedrate``."""
        f = as_finite_array(feedrate, "feedrate")
        if np.any(f < 0):
            raise ValueError(f"feedrate must be >= 0, got {f.min()}")
        self.set_feed_override(f / self.nominal_feedrate)

    def set_feed_override(self, override: ArrayLike) -> None:
        """Set the feed override (fraction of the programmed feeds), scalar or (B,)."""
        o = as_finite_array(override, "feed override")
        if np.any(o < 0):
            raise ValueError(f"feed override must be >= 0, got {o.min()}")
        self.ip_p[:, IP.ovr] = np.broadcast_to(o, (self.batch_size,))

    @property
    def feedrate(self) -> Array:
        """(B,) commanded feedrate of the cutting moves, m/s (before the machine's cap)."""
        return self.ip_p[:, IP.ovr] * self.nominal_feedrate

    def set_controller_params(self, params: ArrayLike) -> None:
        """Set per-member axis controller parameters, broadcastable to (B, A, P).

        The columns are the controller's schema (``loop.controller.params.col``).
        """
        _assign(self.ctrl_p, params, "controller params")

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
        n_axes) and must be finite and > 0 (friction/disturbance >= 0); friction scales the
        parameters each law names in its ``scale``.
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
        ax_p, fr_p, dist = (arr[idx].copy() for arr in self._nominal)
        ax_p[..., AX.m] *= f["mass"]
        ax_p[..., AX.b] *= f["damping"]
        ax_p[..., AX.k] *= f["force_constant"]
        for a, axis in enumerate(self.stage.axes):
            law = law_for(axis.friction)
            for name in law.scale:
                fr_p[:, a, law.params.names.index(name)] *= f["friction"][:, a]
        for name in ("step_a", "sin_a", "rnd_std"):
            dist[..., DISTURBANCE.names.index(name)] *= f["disturbance"]
        self.ax_p[idx], self.fr_p[idx], self.dist[idx] = ax_p, fr_p, dist
        self.ad[idx], self.bd[idx] = zoh_matrices(ax_p, self.stage.ts / self.stage.substeps)

    # ----------------------------------------------------------------- views
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

        In words: :data:`REASON_NAMES`. 2: not in position within the settle time after the
        path end; 3: stopped by :meth:`run`'s ``stop_above``; 4: still running when
        :meth:`run`'s ``max_time`` ran out.
        """
        return self.mem[:, M.reason].copy()

    @property
    def running(self) -> NDArray[np.bool_]:
        """(B,) members still on their way."""
        return (self.status == STATUS_OK) | (self.status == STATUS_PAUSED)

    @property
    def ticks_run(self) -> NDArray[np.int64]:
        """(B,) ticks each member has run since its reset (until its end, if it ended)."""
        ended = (self.status == STATUS_ARRIVED) | (self.status == STATUS_FAILED)
        return np.where(ended, self.mem[:, M.end], self.tick - self.k_start).astype(np.int64)

    @property
    def cycle_time(self) -> Array:
        """(B,) time from the start to the arrival in position at the end, s (inf if not)."""
        return np.where(self.done, self.mem[:, M.arrival] * self.stage.ts, np.inf)

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

    def path_blobs(self) -> tuple[NDArray[np.int64], NDArray[Any], NDArray[np.int64]]:
        """The path's segment kinds, float blob and its layout (what compiled callers take)."""
        return self._kind, self._pblob.buffer, self._pblob.layout

    # ------------------------------------------------------------------- run
    def step(self, n_ticks: int, skip: ArrayLike | None = None) -> ErrorSums:
        """Run ``n_ticks`` ticks; return the error sums of just these ticks.

        Args:
            n_ticks: Ticks to run.
            skip: Indices or mask of members that sit this call out (their clocks do not
                advance); a vector env's members being auto-reset.

        Members that failed or arrived stay frozen.
        """
        with self.compiling():
            self.advance(n_ticks, skip)
        return ErrorSums(self.acc_c.copy(), self.acc_a.copy())

    def compiling(self) -> contextlib.AbstractContextManager[None]:
        """A progress line around the first call if this loop's kernel compiles in-process."""
        show = not self._marked and _compile.needs_compile(self.kernel)
        return _compile.compiling(f"the servo loop for {self.describe()}", show)

    def advance(
        self, n_ticks: int, skip: ArrayLike | None = None,
        via: Callable[..., Any] | None = None, leading: tuple[Any, ...] = (),
    ) -> Any:  # fmt: skip
        """Run ``n_ticks`` ticks, by the loop's kernel or by a compiled caller of its run.

        Args:
            n_ticks: Ticks to run.
            skip: As in :meth:`step`.
            via: None for the loop's own ``run_ticks``; else a compiled function called as
                ``via(*leading, n, k0, cf, fb, fl, ib, il, pk, pb, pl, noise, rec)`` that makes
                the views of these blobs and calls the kernel's ``run_members`` on them once
                (the env kernel: actions, the ticks and rewards in one call). If it returns
                False it ran nothing: the clock stays where it was.
            leading: ``via``'s own arguments.

        Returns:
            ``via``'s result (None without ``via``).
        """
        if not isinstance(n_ticks, (int, np.integer)) or n_ticks < 0:
            raise ValueError(f"n_ticks must be a non-negative int, got {n_ticks!r}")
        paused = None if skip is None else self._pause(skip)
        # reading noise ahead leaves no trace: each member's stream is consumed in order
        noise = self._noise.take(n_ticks, self.status, self.noise_at)
        rec = np.zeros((self.batch_size, n_ticks, self._rec_width)) if self.record else (
            self._no_record)  # fmt: skip
        args = (n_ticks, self.tick, self._config, self._fblob.buffer, self._fblob.layout,
                self._iblob.buffer, self._iblob.layout, self._kind, self._pblob.buffer,
                self._pblob.layout, noise, rec)  # fmt: skip
        result = self.kernel.run_ticks(*args) if via is None else via(*leading, *args)
        if result is False:
            if paused is not None:
                self._resume(paused, 0)
            return result
        if self.record:
            self._keep_record(rec)
        self.tick += n_ticks
        if paused is not None:
            self._resume(paused, n_ticks)
        if not self._marked:  # once per loop: the marker is a file (a stat per call cost 7 us)
            _compile.mark_compiled(self.kernel)
            self._marked = True
            _tiers.start_pending()
        return result

    def _pause(self, skip: ArrayLike) -> NDArray[np.bool_]:
        # members in skip that are running sit this call out (status PAUSED)
        paused = np.zeros(self.batch_size, dtype=bool)
        paused[np.asarray(skip)] = True
        paused &= self.status == STATUS_OK
        self.status[paused] = STATUS_PAUSED
        return paused

    def _resume(self, paused: NDArray[np.bool_], n_ticks: int) -> None:
        # paused members run again, their local clocks n_ticks behind the loop's
        self.status[paused] = STATUS_OK
        self.k_start[paused] += n_ticks

    def _keep_record(self, rec: Array) -> None:
        # keep a recorded call; rows after a member's end were never written: NaN, not data
        local = self.tick - self.k_start
        ended = (self.status == STATUS_ARRIVED) | (self.status == STATUS_FAILED)
        for b in np.flatnonzero(ended):
            first = int(self.mem[b, M.end]) - local[b]
            rec[b, max(first, 0) :] = np.nan
        self._records.append(rec)

    def planned_time(self, override: float | None = None) -> float:
        """A generous estimate of one contour's duration, s.

        Args:
            override: Feed override to plan at (default: the slowest member's).
        """
        ovr = float(self.ip_p[:, IP.ovr].min()) if override is None else override
        slowest = max(ovr, 1e-9)
        if self.path.time_law is not None:
            return self.path.time_law.duration / slowest + self.opts.settle_time
        feed = np.minimum(self.program.feed, self.program.vcap)
        scale = np.where((self.program.flags.astype(int) & motion.RAPID) != 0, 1.0, slowest)
        speed = np.maximum(np.minimum(feed * scale, float(self.ip_p[:, IP.f_max].min())), 1e-9)
        move = float(np.sum(np.diff(self.path.table.s0) / speed))
        dwell = float(self.program.dwell.sum()) * self.stage.ts
        stops = float(self.program.wait.sum()) * self.opts.settle_time
        return move + dwell + stops + self.opts.settle_time

    def run(
        self,
        max_time: float | None = None,
        chunk: int = 2048,
        stop_above: float | None = None,
        members: ArrayLike | None = None,
    ) -> dict[str, Array]:
        """Run until every member has finished the contour (or failed), then return metrics.

        Args:
            max_time: Stop after this much simulated time, s (default: 5x
                :meth:`planned_time` + 1 s).
            chunk: Ticks per kernel call.
            stop_above: If given, a member whose max contour error exceeds it (m) stops on
                that tick and fails (:attr:`failure_reason` 3): it has failed whatever it
                would do next (the max never falls), so a tuner saves simulating it. Its
                metrics keep the errors measured until then.
            members: Indices or mask of the members that run (default: all); the others sit
                the run out as with :meth:`step`'s ``skip`` (a tuner running fewer
                candidates than its loop holds).

        Returns:
            :func:`contour_gym.metrics.metrics_from_sums` of the whole run, with failed
            members' values set to ``inf``.
        """
        if max_time is None:
            max_time = 5.0 * self.planned_time() + 1.0
        limit = self._bounded_ticks(max_time)
        if stop_above is not None and not stop_above >= 0.0:
            raise ValueError(f"stop_above must be a non-negative number, got {stop_above!r}")
        active = np.ones(self.batch_size, dtype=bool)
        if members is not None:
            active[:] = False
            active[np.asarray(members)] = True
        skip = None if members is None else ~active
        self._config[CF.stop_above] = math.inf if stop_above is None else stop_above
        try:
            while self.tick < limit and np.any(self.running & active):
                self.step(min(chunk, limit - self.tick), skip)
        finally:
            self._config[CF.stop_above] = math.inf
        self._fail(self.running & active, REASON_TIME_CAP)  # cut off: a failure, not a result
        return self.metrics()

    def _bounded_ticks(self, max_time: float) -> int:
        # the run's tick cap, checked before anything runs: time and memory are bounded
        ticks = math.ceil(positive(max_time, "max_time") / self.stage.ts)
        what = (f"{max_time:.4g} s of machine time at a {self.stage.ts:.3g} s servo period is "
                f"{ticks:.3g} ticks")  # fmt: skip
        if ticks > MAX_RUN_TICKS:
            raise ValueError(f"{what}, more than a run may take ({MAX_RUN_TICKS:.3g}): check "
                             "the path's length, its feeds and the stage's ts, or pass "
                             "max_time")  # fmt: skip
        need = ticks * self.batch_size * self._rec_width * 8
        if self.record and need > MAX_RECORD_BYTES:
            raise ValueError(f"{what}: recording it needs {need / 2**30:.3g} GiB, more than "
                             f"{MAX_RECORD_BYTES / 2**30:.3g} GiB; run without record=True, or "
                             "a shorter max_time")  # fmt: skip
        return ticks

    def _fail(self, members: NDArray[np.bool_], reason: float) -> None:
        # end these members now as failed, for this reason
        self.status[members] = STATUS_FAILED
        self.mem[members, M.reason] = reason
        self.mem[members, M.end] = (self.tick - self.k_start)[members]

    def metrics(self) -> dict[str, Array]:
        """Metrics of everything run since the last reset.

        A diverged member's values are all ``inf``; a member that never got in position keeps
        the errors measured until it was stopped, with ``cycle_time = inf``.
        """
        out = metrics_from_sums(self.sums, self.cycle_time)
        diverged = self.failed & (self.mem[:, M.reason] == REASON_DIVERGED)
        for v in out.values():
            v[diverged] = np.inf
        return out

    def trace(self) -> Trace:
        """The per-tick record since reset (requires ``record=True``).

        Rows after a member's end (arrival or failure) are NaN.
        """
        if not self.record:
            raise ValueError("trace() needs ServoLoop(record=True)")
        a, c = self.stage.n_axes, len(self.stage.contours)
        rec = (
            np.concatenate(self._records, axis=1)
            if self._records
            else np.zeros((self.batch_size, 0, self._rec_width))
        )
        base = 2 + 3 * a
        return Trace(
            t=np.arange(rec.shape[1], dtype=np.float64) * self.stage.ts,
            s=rec[..., 0],
            v=rec[..., 1],
            r=rec[..., 2 : 2 + a],
            x=rec[..., 2 + a : 2 + 2 * a],
            u=rec[..., 2 + 2 * a : base],
            eps=rec[..., base : base + 2 * c : 2],
            eps_est=rec[..., base + 1 : base + 2 * c : 2],
        )


def _assign(target: Array, value: ArrayLike, name: str) -> None:
    """Write finite ``value`` into ``target`` in place, broadcast; ValueError naming ``name``."""
    v = as_finite_array(value, name)
    try:
        target[...] = np.broadcast_to(v, target.shape)
    except ValueError as exc:
        raise ValueError(f"{name} of shape {v.shape} do not broadcast to {target.shape}") from exc


def simulate_axis(
    axis: AxisParams,
    controls: ArrayLike,
    *,
    ts: float = 1e-3,
    substeps: int = 1,
    x0: float = 0.0,
    v0: float = 0.0,
    noise: ArrayLike | None = None,
) -> tuple[Array, Array, Array]:
    """Drive one axis open-loop through the servo loop's own plant step (tests, studies).

    Args:
        axis: The axis.
        controls: (n,) control held over each tick.
        ts: Tick, s.
        substeps: Plant substeps per tick.
        x0: Initial position, m.
        v0: Initial velocity, m/s.
        noise: (n,) standard normals for a random disturbance (default zeros).

    Returns:
        ``(positions (n,), velocities (n,), final state row)`` after each tick.
    """
    u = np.ascontiguousarray(as_finite_array(controls, "controls", ndim=1))
    n = u.shape[0]
    w = np.zeros(n) if noise is None else np.ascontiguousarray(
        as_finite_array(noise, "noise", shape=(n,)))  # fmt: skip
    law = law_for(axis.friction)
    slots, codes = _compile.bind({FRICTION_FAMILY: [law]})
    ax = axis_row(axis, codes[FRICTION_FAMILY.name][0], ideal=True)[None]
    ad, bd = zoh_matrices(ax, positive(ts, "ts") / substeps)
    st = np.zeros((1, STATE.size))
    st[0, ST.x], st[0, ST.v] = x0, v0
    kernel = _compile.specialise("contour_gym._loopkernel", slots)
    xs, vs = np.zeros(n), np.zeros(n)
    kernel.drive_axis(ax, friction_row(axis)[None], ripple_rows(axis)[None],
                      disturbance_row(axis, ts)[None], ad, bd, st, u, 0.0, ts, substeps, w, xs,
                      vs)  # fmt: skip
    return xs, vs, st[0].copy()


def _options(options: dict[str, Any]) -> LoopOptions:
    fields = set(LoopOptions.__dataclass_fields__)
    unknown = sorted(set(options) - fields)
    if unknown:
        raise ValueError(f"unknown loop option(s) {unknown}; accepted: {', '.join(sorted(fields))}")
    opts = LoopOptions(**options)
    choice(opts.ccc_injection, "ccc_injection", INJECTIONS)
    positive(opts.settle_time, "settle_time")
    if opts.sample_period is not None:
        positive(opts.sample_period, "sample_period")
    if opts.path_tolerance is not None:
        non_negative(opts.path_tolerance, "path_tolerance")
    return opts


__all__ = [
    "MAX_RECORD_BYTES", "MAX_RUN_TICKS", "REASON_NAMES", "LoopOptions", "ServoLoop", "Trace",
    "simulate_axis",
]  # fmt: skip
