"""ServoLoop: the batched closed loop of DESIGN.md, one servo tick at a time.

It packs a stage, a path, the axis controllers, the estimator, the CCC and the interpolator
into arrays with a leading batch dimension ``B`` and runs the compiled kernel of
:mod:`contour_gym.loop.kernel`, specialised to the components the loop uses
(:mod:`contour_gym.jit`). Parameters that optimisers and agents search (CCC gains, axis
gains, feed override) may differ per batch member. Random numbers come only from one
``numpy.random.Generator`` per member, spawned from the seed given to :meth:`ServoLoop.reset`,
so a member's result depends only on its own seed and parameters, never on ``B``.

The machine is a rig by default: the encoder quantises, noise is added where the axes have it,
and the command computed from sample k drives the plant from tick k + 1. ``ideal=True`` drops
all three (the papers' pure simulations).

This module holds the loop's core (construction, kernel choice, reset, stepping, runs and their
metrics); its parts live next to it: the arrays by name and their read-outs
(:mod:`contour_gym.loop.views`), the parameter setters (:mod:`contour_gym.loop.parameters`), the
arrays' construction (:mod:`contour_gym.loop.build`), the random numbers
(:mod:`contour_gym.loop.noise`) and the per-tick record (:mod:`contour_gym.loop.record`).
"""

from __future__ import annotations

import contextlib
import functools
import math
import time
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import jit, motion
from contour_gym._validate import as_finite_array, choice, non_negative, positive
from contour_gym.ccc import CCC_FAMILY, CCC_LAWS, INJECTIONS, ccc_params
from contour_gym.contour import ESTIMATORS, Estimator, get_estimator
from contour_gym.contour.base import ESTIMATOR_FAMILY
from contour_gym.jit import precompile, tiers
from contour_gym.jit.stack import on_reserved_stack
from contour_gym.limits import check_size, gigabytes
from contour_gym.loop.axis import LOOP_TEMPLATE, simulate_axis
from contour_gym.loop.bank import PathBank
from contour_gym.loop.build import (
    axis_arrays,
    check_sizes,
    config_row,
    contour_axes,
    contour_offsets,
    filled_blob,
    member_bytes,
    state_shapes,
)
from contour_gym.loop.noise import NOISE_CHUNK as NOISE_CHUNK  # re-exported
from contour_gym.loop.noise import NoiseSource, draws_noise, member_generators
from contour_gym.loop.options import DEFAULT_SETTLE as DEFAULT_SETTLE  # re-exported
from contour_gym.loop.options import LoopOptions as LoopOptions  # re-exported
from contour_gym.loop.parameters import Parameters
from contour_gym.loop.record import MAX_RECORD_BYTES, Recorder, Trace
from contour_gym.loop.state import (
    CF,
    FLOAT_NAMES,
    FT,
    INT_NAMES,
    MEM_COL,
    REASON_DIVERGED,
    REASON_NAMES,
    REASON_TIME_CAP,
    STATUS_FAILED,
    STATUS_OK,
    STATUS_PAUSED,
)
from contour_gym.loop.threads import ThreadChoice, check_threads, run_parts, split
from contour_gym.loop.views import LoopViews, member_indices
from contour_gym.metrics import ErrorSums, metrics_from_sums
from contour_gym.motion import IP
from contour_gym.paths import Path
from contour_gym.plant._kernel import ST
from contour_gym.plant.friction import FRICTION_FAMILY, FRICTION_LAWS
from contour_gym.plant.stage import (
    Stage,
    friction_laws,
)
from contour_gym.servo import CONTROLLERS, PIDGains, build_controller, compensation
from contour_gym.servo.base import CONTROLLER_FAMILY
from contour_gym.servo.compensation import COMPENSATION_FAMILY
from contour_gym.servo.gains import as_pid_gains

Array = NDArray[np.float64]
# config columns holding the code of the loop's one component of each family
_CODED = {"ctrl": CONTROLLER_FAMILY, "est": ESTIMATOR_FAMILY, "ccc": CCC_FAMILY,
          "comp": COMPENSATION_FAMILY}
MAX_RUN_TICKS = 200_000_000  # ticks one run() may take (55 h of machine time at 1 kHz)
CHECKED_ABOVE = 1024  # members above which a loop's memory is checked before it is made


class ServoLoop(LoopViews):
    """Batched closed loop over one stage; its members on one path, or each on its own.

    The arrays of its blobs are attributes (``loop.ax_s``, ``loop.status``, ...: views written
    in place, declared in :class:`contour_gym.loop.views.LoopViews` with the state read-outs
    ``done``, ``failed``, ``cycle_time`` ...). It holds two parts: its parameter setter
    ``parameters`` (:class:`~contour_gym.loop.parameters.Parameters`: ``set_ccc_gains``,
    ``set_feedrate``, ``set_plant_scaling`` ...) and its path bank ``bank``
    (:class:`~contour_gym.loop.bank.PathBank`: ``set_paths``, ``path``, ``paths``,
    ``planned_time`` ...); the loop's methods of the same names call them.

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
        threads: Threads the members run on, each over a contiguous part of the batch (None:
            :func:`contour_gym.loop.threads.default_threads`, every CPU when the batch is large
            enough, timed against one thread over the first calls and the faster kept,
            :class:`~contour_gym.loop.threads.ThreadChoice`; at most one per member). Results do
            not depend on it.
        **options: The fields of :class:`LoopOptions` (axis controller, estimator, CCC law and
            injection, ``ideal``, path control, settle time, sample period). A path carrying a
            time law (:attr:`Path.time_law`) is run on it instead of the interpolator's feeds.
    """

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
        threads: int | None = 1,
        **options: Any,
    ) -> None:
        check_sizes(stage, path, axis_gains, batch_size)
        if batch_size > CHECKED_ABOVE:  # before any array of B members is made
            _check_memory(stage, path, axis_gains, interpolator, int(batch_size), options)
        self.threads = check_threads(threads, int(batch_size))
        self._parts = split(int(batch_size), self.threads)
        # the default's threads are timed against one thread, the faster kept (ThreadChoice)
        self._choice = ThreadChoice(self._parts) if threads is None and self.threads > 1 else None
        stage.check_travel(path)  # before any array is sized
        self.opts = _options(options)
        self.stage, self.batch_size, self.record = stage, int(batch_size), record
        self.axis_gains = tuple(
            as_pid_gains(g, f"axis_gains[{i}]") for i, g in enumerate(axis_gains)
        )
        self.interpolator = interpolator
        b = self.batch_size
        self.controller, ctrl_p, comp_p = build_controller(
            self.opts.axis_controller, stage, self.axis_gains, b,
            **(self.opts.controller_options or {}),
        )
        self.estimator = get_estimator(self.opts.estimator, **(self.opts.estimator_options or {}))
        self.ccc_law = CCC_LAWS.get(self.opts.ccc_law)
        self.law_names = friction_laws(stage)
        self.bank = PathBank(stage, interpolator, self.opts, b, path, contour_offsets(stage))
        self._bind(bool(np.any(comp_p[..., compensation.C.mode] != compensation.NONE)))
        self._build_blobs(self._parameter_arrays(ctrl_p, comp_p, ccc_gains, ccc_weights))
        self._config = self._config_row()
        self._sync_bank()
        self.parameters = Parameters(self, self.ccc_law, interpolator)
        self._kernel: ModuleType | None = None  # chosen on first use (kernel)
        self._recorder = Recorder(b, stage.n_axes, len(stage.contours))
        self._marked = False  # mark_compiled done (advance)
        self._no_record = self._recorder.empty
        self.reset(0)

    # --------------------------------------------------------------- building
    def _parameter_arrays(
        self, ctrl_p: Array, comp_p: Array, ccc_gains: ArrayLike | None, ccc_weights: ArrayLike
    ) -> dict[str, Array]:
        stage, b = self.stage, self.batch_size
        c = len(stage.contours)
        code = dict(zip(self.law_names, self.codes[FRICTION_FAMILY.name], strict=True))
        law_params = self.opts.ccc_law_params or {}
        ccc_w = np.broadcast_to(as_finite_array(ccc_weights, "ccc_weights"), (b, c, 3))
        axes = axis_arrays(stage, b, code, self.opts.ideal)
        return {
            "ax_p": axes.pop("ax_p"), "ad": axes.pop("ad"), "bd": axes.pop("bd"),
            "ctrl_p": ctrl_p, "comp_p": comp_p,
            "ccc_p": ccc_params(ccc_gains, b, c, self.ccc_law, **law_params), "ccc_w": ccc_w,
            "ccc_data": self.ccc_law.table(), "est_p": self.estimator.params,
            "ip_p": self.interpolator.params(b), "c_off": contour_offsets(stage), **axes,
        }

    def _build_blobs(self, params: dict[str, Array]) -> None:
        # every array the kernel touches lives in one of two blobs (contour_gym._blob); the
        # attributes named in FLOAT_NAMES / INT_NAMES are views (LoopViews), written in place
        b = self.batch_size
        shapes = state_shapes(self.stage, b, self.controller.state.size, self.ccc_law.state.size,
                              self.threads)
        self._fblob = filled_blob(FLOAT_NAMES, params, shapes)
        self._iblob = filled_blob(
            INT_NAMES, {"c_axes": contour_axes(self.stage)},
            {"status": (b,), "k_start": (b,), "noise_at": (b,), "p_at": (b, 3)}, np.int64,
        )
        self.sums = ErrorSums(self.ep_c, self.ep_a)

    def _config_row(self) -> Array:
        codes = {key: self.codes[fam.name][0] for key, fam in _CODED.items()}
        search = self.estimator.kind.foot is None
        return config_row(self.stage, self.path, self.opts, self.record, search, codes)

    def _bind(self, compensates: bool) -> None:
        # the kernel's slots and this loop's component codes (contour_gym.jit.bind)
        self._compensates = compensates
        uses: dict[jit.Family, list[Any]] = {
            CONTROLLER_FAMILY: [self.controller], ESTIMATOR_FAMILY: [self.estimator.kind],
            CCC_FAMILY: [self.ccc_law], COMPENSATION_FAMILY: [compensates],
            FRICTION_FAMILY: [FRICTION_LAWS.get(n) for n in self.law_names],
        }
        self._slots, self.codes = jit.bind(uses)
        generic = jit.is_generic(self._slots)
        self._own_slots = jit.bind(uses, own=True)[0] if generic else self._slots

    # ------------------------------------------- the held parts: paths, parameters
    def _sync_bank(self) -> None:
        # the bank's member rows and time step into the loop's arrays (after any change)
        self.p_at[...] = self.bank.p_at
        self._config[CF.law_dt] = self.bank.time_step

    def set_paths(self, paths: Path | Sequence[Path], members: ArrayLike | None = None) -> None:
        """Give members paths of their own (:meth:`PathBank.set_paths`; from the next reset)."""
        self.bank.set_paths(paths, members)
        self._sync_bank()

    @property
    def path(self) -> Path:
        """The path every member runs when they share one; else member 0's (:attr:`paths`)."""
        return self.bank.path

    @property
    def paths(self) -> tuple[Path, ...]:
        """(B,) each member's path."""
        return self.bank.paths

    @property
    def program(self) -> motion.Program:
        """The program of :attr:`path` (member 0's)."""
        return self.bank.program

    @property
    def programs(self) -> tuple[motion.Program, ...]:
        """(B,) each member's program."""
        return self.bank.programs

    @property
    def path_lengths(self) -> Array:
        """(B,) each member's path length, m."""
        return self.bank.path_lengths

    @property
    def shares_path(self) -> bool:
        """Whether every member runs the same path."""
        return self.bank.shares_path

    def start_positions(self, member: int = 0) -> Array:
        """(A,) axis positions at the start of ``member``'s path (offsets included), m."""
        return self.bank.start_positions(member)

    def planned_time(self, override: float | None = None, member: int | None = None) -> float:
        """A generous estimate of one contour's duration, s (:meth:`PathBank.planned_time`)."""
        f_max = float(self.ip_p[:, IP.f_max].min())
        return self.bank.planned_time(self.ip_p[:, IP.ovr], f_max, override, member)

    def programmed_feedrate(self, member: int = 0) -> float:
        """``member``'s highest programmed cutting feed, m/s (the bank's, of the same name)."""
        return self.bank.programmed_feedrate(member)

    def path_blobs(self) -> tuple[NDArray[np.int64], NDArray[Any], NDArray[np.int64]]:
        """The path bank's segment kinds, float blob and layout (what compiled callers take)."""
        return self.bank.blobs()

    def set_ccc_gains(self, gains: ArrayLike | None, members: ArrayLike | None = None) -> None:
        """Set the CCC gains (kp, ki, kd) (:meth:`Parameters.set_ccc_gains`)."""
        self.parameters.set_ccc_gains(gains, members)

    def set_ccc_params(self, **params: ArrayLike) -> None:
        """Set the CCC law's named parameters, each broadcastable to (B, C)."""
        self.parameters.set_ccc_params(**params)

    def set_ccc_weights(self, weights: ArrayLike) -> None:
        """Set per-member CCC output weights (:meth:`Parameters.set_ccc_weights`)."""
        self.parameters.set_ccc_weights(weights)

    @property
    def nominal_feedrate(self) -> float:
        """The programmed cutting feedrate the override refers to, m/s."""
        return self.parameters.nominal_feedrate

    def set_feedrate(self, feedrate: ArrayLike) -> None:
        """Command a feedrate (m/s), scalar or (B,): the override ``F / nominal_feedrate``."""
        self.parameters.set_feedrate(feedrate)

    def set_feed_override(self, override: ArrayLike, members: ArrayLike | None = None) -> None:
        """Set the feed override (:meth:`Parameters.set_feed_override`)."""
        self.parameters.set_feed_override(override, members)

    @property
    def feedrate(self) -> Array:
        """(B,) commanded feedrate of the cutting moves, m/s (before the machine's cap)."""
        return self.parameters.feedrate

    def set_controller_params(self, params: ArrayLike) -> None:
        """Set per-member axis controller parameters, broadcastable to (B, A, P)."""
        self.parameters.set_controller_params(params)

    def set_plant_scaling(self, members: ArrayLike, **factors: Any) -> None:
        """Scale members' axis parameters (:meth:`Parameters.set_plant_scaling`)."""
        self.parameters.set_plant_scaling(members, **factors)

    # ---------------------------------------------------------------- kernel
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
            self._kernel = own if builtins is None else tiers.choose(own, builtins, "loop", self)
        return self._kernel

    def kernels(self) -> tuple[ModuleType, Callable[[], ModuleType] | None]:
        """This loop's own kernel module, and a maker of the built-ins' kernel module.

        The maker is None when the loop uses a component of the user's (its own kernel is
        then the only one). :mod:`contour_gym.jit.tiers` says which one runs.
        """
        own = jit.specialise(LOOP_TEMPLATE, self._own_slots)
        if self._own_slots is self._slots:
            return own, None
        return own, self._builtins_kernel

    def _builtins_kernel(self) -> ModuleType:
        precompile.ensure("loop")  # once per installation, in worker processes
        return jit.specialise(LOOP_TEMPLATE, self._slots)

    def use_kernel(self, kernel: ModuleType) -> None:
        """Run on ``kernel``, one of :meth:`kernels` (an env task chooses with its own kernel)."""
        self._kernel = kernel
        self._marked = False

    def compile_own(self) -> None:
        """Run one tick on this loop's own kernel (a background worker: :mod:`_tiers`)."""
        self.use_kernel(self.kernels()[0])
        self.reset(0)
        self.step(1)

    # -------------------------------------------------------------- pickling
    def __getstate__(self) -> dict[str, object]:
        # components are pickled by name (and the estimator with its option row) and looked
        # up in their registries again on load; the views are made again from the blobs
        names = set(self._fblob.views) | set(self._iblob.views) | {"sums", "_kernel"}
        state = {k: v for k, v in self.__dict__.items() if k not in names}
        state["controller"] = self.controller.name
        state["ccc_law"] = self.ccc_law.name
        state["estimator"] = (self.estimator.name, self.estimator.params)
        del state["_slots"]  # the codes stay: the blob's axis rows hold the friction codes
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self.__dict__.setdefault("trace_start", 0)  # a loop pickled before these existed
        self.__dict__.setdefault("_reset_tick", np.zeros(self.batch_size, dtype=np.int64))
        self.controller = CONTROLLERS.get(state["controller"])  # type: ignore[arg-type]
        self.ccc_law = CCC_LAWS.get(state["ccc_law"])  # type: ignore[arg-type]
        self.parameters.ccc_law = self.ccc_law
        est_name, est_params = cast(tuple[str, Array], state["estimator"])
        self.estimator = Estimator(ESTIMATORS.get(est_name), est_params)
        self.sums = ErrorSums(self.ep_c, self.ep_a)
        codes = self.codes
        self._bind(self._compensates)
        if codes != self.codes:
            raise ValueError(f"the components' codes changed since pickling: {codes} -> "
                             f"{self.codes}")
        self._kernel = None
        self._marked = False

    # ----------------------------------------------------------------- state
    def _restart_clock(self) -> None:
        self.tick = self.trace_start = 0
        self._reset_tick = np.zeros(self.batch_size, dtype=np.int64)  # each member's last reset
        self._recorder.clear()
        active = draws_noise(self.stage, self.opts.ideal)
        self._noise = NoiseSource(self.batch_size, 2 * self.stage.n_axes, active)

    def reset(
        self, seed: int | Sequence[int] | None = None, members: ArrayLike | None = None
    ) -> None:
        """Put members at rest at the start of their paths.

        Args:
            seed: An int (member ``i`` of the reset ones uses child ``i`` of
                ``SeedSequence(seed)``), one seed per reset member, or None for fresh entropy.
            members: Indices or boolean mask of the members to reset (default: all, which
                also restarts the loop's clock and recording).
        """
        if members is None:
            self._restart_clock()
        idx = member_indices(self.batch_size, members)
        start = self.bank.start_axes(idx)  # each member at its own path's start
        for arr in (self.ctrl_s, self.comp_s, self.ccc_s, self.hist, self.last, self.u_cmd,
                    self.mem, self.ax_s, self.foot):
            arr[idx] = 0.0
        self.ax_s[idx, :, ST.x] = start
        self.y_last[idx] = start
        self.x_ring[idx] = start[:, None, :]
        q0, dim = self.bank.start_points(idx)[:, None, :], self.stage.dim
        self.foot[idx, :, FT.qx : FT.qx + dim] = q0
        self.foot[idx, :, FT.e_qx : FT.e_qx + dim] = q0
        self.ip_s[idx] = motion.initial_state(len(idx))
        self.status[idx] = STATUS_OK
        self.k_start[idx] = self._reset_tick[idx] = self.tick
        self.sums.contour[idx] = 0.0
        self.sums.axis[idx] = 0.0
        gens = member_generators(seed, len(idx), self._noise.active)
        self._noise.reseed(idx, gens, self.noise_at)

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
        show = not self._marked and jit.needs_compile(self.kernel)
        return jit.compiling(f"the servo loop for {self.describe()}", show)

    def advance(
        self, n_ticks: int, skip: ArrayLike | None = None,
        via: Callable[..., Any] | None = None, leading: tuple[Any, ...] = (),
    ) -> Any:
        """Run ``n_ticks`` ticks, by the loop's kernel or by a compiled caller of its run.

        Args:
            n_ticks: Ticks to run.
            skip: As in :meth:`step`.
            via: None for the loop's own ``run_ticks``; else a compiled function called as
                ``via(*leading, n, k0, cf, fb, fl, ib, il, pk, pb, pl, noise, rec, lo, hi,
                part)`` that makes the views of these blobs and calls the kernel's
                ``run_members`` on members ``lo:hi`` (the env kernel: actions, the ticks and
                rewards in one call), once per part of the batch (on threads when the loop has
                several, :mod:`contour_gym.loop.threads`). If it returns False it ran nothing: the
                clock stays where it was.
            leading: ``via``'s own arguments.

        Returns:
            ``via``'s result (None without ``via``).
        """
        if not isinstance(n_ticks, (int, np.integer)) or n_ticks < 0:
            raise ValueError(f"n_ticks must be a non-negative int, got {n_ticks!r}")
        paused = None if skip is None else self._pause(skip)
        if self.record:
            self._drop_past_episodes()
        # reading noise ahead leaves no trace: each member's stream is consumed in order
        noise = self._noise.take(n_ticks, self.status, self.noise_at)
        rec = self._recorder.new(n_ticks) if self.record else self._no_record
        args = (n_ticks, self.tick, self._config, self._fblob.buffer, self._fblob.layout,
                self._iblob.buffer, self._iblob.layout, *self.bank.blobs(), noise, rec)
        call, head = (self.kernel.run_ticks, args) if via is None else (via, (*leading, *args))
        result = self._run_parts(call, head, n_ticks)
        if result is False:
            if paused is not None:
                self._resume(paused, 0)
            return result
        if self.record:  # rows after a member's end were never written: NaN, not data
            ends = self.mem[:, MEM_COL.end]
            self._recorder.keep(rec, self._ended, ends, self.tick - self.k_start, paused)
        self.tick += n_ticks
        if paused is not None:
            self._resume(paused, n_ticks)
        if not self._marked:  # once per loop: the marker is a file (a stat per call cost 7 us)
            jit.mark_compiled(self.kernel)
            self._marked = True
            tiers.start_pending()
        return result

    def _run_parts(self, call: Callable[..., Any], head: tuple[Any, ...], n_ticks: int) -> Any:
        # ``call`` on each part of the batch (those chosen by timing, or on trial), its result
        choice = self._choice
        parts = self._parts if choice is None else choice.parts()
        start = time.perf_counter()
        if not self._marked:  # the first call may compile: below a reserved stack
            call = functools.partial(on_reserved_stack, call)
        if len(parts) == 1:
            result = call(*head, 0, self.batch_size, 0)
        else:
            result = run_parts(lambda lo, hi, part: call(*head, lo, hi, part), parts)[0]
        if choice is not None and result is not False:
            choice.record(parts, time.perf_counter() - start, int(n_ticks))
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
                f"{ticks:.3g} ticks")
        if ticks > MAX_RUN_TICKS:
            raise ValueError(f"{what}, more than a run may take ({MAX_RUN_TICKS:.3g}): check "
                             "the path's length, its feeds and the stage's ts, or pass "
                             "max_time")
        if self.record:
            self._recorder.check_size(ticks, what)
        return ticks

    def array_bytes(self) -> int:
        """Bytes of the loop's arrays (its blobs, noise buffer and path bank; not the record)."""
        arrays = (self._fblob.buffer, self._iblob.buffer, self._noise.buf, *self.bank.blobs())
        return sum(a.nbytes for a in arrays)

    def check_record(self, ticks: int, what: str, lower: str) -> None:
        """Refuse (ValueError) a recorded stretch of ``ticks`` ticks over the record's cap.

        ``what`` starts the message, ``lower`` ends it (what to do instead).
        """
        self._recorder.check_size(ticks, what, lower)

    def _fail(self, members: NDArray[np.bool_], reason: float) -> None:
        # end these members now as failed, for this reason
        self.status[members] = STATUS_FAILED
        self.mem[members, MEM_COL.reason] = reason
        self.mem[members, MEM_COL.end] = (self.tick - self.k_start)[members]

    def metrics(self) -> dict[str, Array]:
        """Metrics of everything run since the last reset.

        A diverged member's values are all ``inf``; a member that never got in position keeps
        the errors measured until it was stopped, with ``cycle_time = inf``.
        """
        out = metrics_from_sums(self.sums, self.cycle_time)
        diverged = self.failed & (self.mem[:, MEM_COL.reason] == REASON_DIVERGED)
        for v in out.values():
            v[diverged] = np.inf
        return out

    def trace(self, member: int | None = None) -> Trace:
        """The per-tick record since reset (requires ``record=True``).

        Its first row is the loop's tick :attr:`trace_start`: 0 after a reset of every member;
        later once every member has reset since (an env's members, one by one: the rows of
        finished episodes are dropped as the next call starts) or :meth:`clear_trace` came.
        Rows after a member's end (arrival or failure), and of a call it sat out, are NaN.

        Args:
            member: Only this member's record (batch dimension 1); None: every member's.

        Raises:
            ValueError: without ``record=True``, or for a member out of range.
        """
        if not self.record:
            raise ValueError("trace() needs ServoLoop(record=True)")
        if member is not None and not 0 <= member < self.batch_size:
            raise ValueError(f"member must lie in [0, {self.batch_size}), got {member!r}")
        return self._recorder.trace(self.stage.ts, member)

    def episode_trace(self, member: int) -> Trace:
        """``member``'s record since its last reset (batch dimension 1, time from 0).

        Raises:
            ValueError: as :meth:`trace`.
        """
        return self.trace(member).window(max(int(self._reset_tick[member]) - self.trace_start, 0))

    def _drop_past_episodes(self) -> None:
        # rows before every member's last reset belong to finished episodes: a loop whose
        # members reset one by one (an env's) keeps only the episodes under way
        oldest = int(self._reset_tick.min())
        if oldest > self.trace_start:
            self._recorder.drop(oldest - self.trace_start)
            self.trace_start = oldest

    def clear_trace(self) -> None:
        """Forget the per-tick record kept so far (its memory), as a reset of every member does.

        The record grows with members x ticks: a caller that took what it needs of it (a
        member's :meth:`trace`) frees it here while it keeps the loop for later runs. The
        record then restarts at the current tick (:attr:`trace_start`).
        """
        self._recorder.clear()
        self.trace_start = self.tick


def _check_memory(
    stage: Stage, path: Path, axis_gains: Sequence[PIDGains],
    interpolator: motion.Interpolator, batch: int, options: dict[str, Any],
) -> None:
    """Refuse a loop of ``batch`` members whose memory (:func:`member_bytes`) would not fit."""
    member = member_bytes(lambda b: ServoLoop(stage, path, axis_gains, interpolator,
                                              batch_size=b, **options))
    check_size(batch * member, f"a loop of {batch} members ({gigabytes(member)} each)",
               "the number of members (num_envs, batch_size, members)")


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
]
