"""The servo loop's paths: each member its own, in one path bank the kernels slice per member.

:class:`PathBank` is held by :class:`contour_gym.loop.ServoLoop` (``loop.bank``). A loop starts
with every member on the path it was built with; :meth:`PathBank.set_paths` gives members paths
of their own (a vector env's members draw one at each reset). The distinct paths are stored once
each, one after the other, in the path bank (:func:`contour_gym.loop.build.path_bank`); the int
blob's ``p_at`` says where each member's segments lie, and the bank's ``member`` rows hold each
member's path scalars (length, closed). The kernels carve a member's views of its own part once
per call (:func:`contour_gym.loop.state.member_path`): new paths change the arrays' sizes, never
their types, so changing paths compiles nothing.

A path with a time law (:attr:`Path.time_law`) is run on it for every member: such a path may
only be shared by all members.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import motion
from contour_gym.loop.build import path_bank
from contour_gym.loop.options import LoopOptions
from contour_gym.loop.state import MP
from contour_gym.loop.views import member_indices
from contour_gym.motion import build_program
from contour_gym.paths import Path
from contour_gym.plant.stage import Stage

Array = NDArray[np.float64]


class PathBank:
    """Each member's path, its program, and the bank the kernels read them from.

    Args:
        stage: The machine.
        interpolator: The feeds' settings (a member's program is built with them).
        opts: The loop's options (path control, tolerance, program feeds, settle time).
        batch: Number of members B.
        path: The path every member starts on.
        offsets: (C, 3) each contour's origin in the axes' frame, m.
    """

    def __init__(self, stage: Stage, interpolator: motion.Interpolator, opts: LoopOptions,
                 batch: int, path: Path, offsets: Array) -> None:
        self.stage, self.interpolator, self.opts = stage, interpolator, opts
        self.batch_size, self._offsets = batch, offsets
        program = self._build_program(path)
        self._paths: list[Path] = [path] * batch  # member b's path
        self._programs = [program] * batch  # its program (one object for a shared path)
        self._build()

    # ------------------------------------------------------------- the paths
    @property
    def path(self) -> Path:
        """The loop's path: the path every member runs when they share one (the usual case).

        When members run paths of their own (:meth:`set_paths`), member 0's; :attr:`paths`
        holds every member's.
        """
        return self._paths[0]

    @property
    def paths(self) -> tuple[Path, ...]:
        """(B,) each member's path."""
        return tuple(self._paths)

    @property
    def program(self) -> motion.Program:
        """The program of :attr:`path` (member 0's)."""
        return self._programs[0]

    @property
    def programs(self) -> tuple[motion.Program, ...]:
        """(B,) each member's program (:func:`contour_gym.motion.build_program` of its path)."""
        return tuple(self._programs)

    @property
    def path_lengths(self) -> Array:
        """(B,) each member's path length, m (metrics of members on different paths)."""
        return self._pblob.views["member"][:, MP.length].copy()

    @property
    def shares_path(self) -> bool:
        """Whether every member runs the same path."""
        return len(self._bank_paths) == 1

    def _build_program(self, path: Path) -> motion.Program:
        return build_program(
            path, self.interpolator, self.stage.ts, path_control=self.opts.path_control,
            path_tolerance=self.opts.path_tolerance,
            use_program_feeds=self.opts.use_program_feeds,
        )

    def set_paths(self, paths: Path | Sequence[Path], members: ArrayLike | None = None) -> None:
        """Give members paths of their own (they start them at their next reset).

        Nothing compiles: the path bank changes size, not type. A member's program is built
        from its path with the loop's interpolator and path options.

        Args:
            paths: One path for every member in ``members``, or one path per member there.
            members: Indices or boolean mask of the members (default: all).

        Raises:
            ValueError: for a path whose dimension is not the stage's, a path beyond the
                axes' travel, a number of paths that does not match the members, or members
                left on different paths where one of them carries a time law (a time-law
                path may only be shared by all members).
        """
        idx = member_indices(self.batch_size, members)
        given = [paths] * len(idx) if isinstance(paths, Path) else list(paths)
        if len(given) != len(idx):
            raise ValueError(f"need one path or {len(idx)} paths (one per member), got "
                             f"{len(given)}")
        new = list(self._paths)
        for b, path in zip(idx, given, strict=True):
            new[int(b)] = path
        _check_time_laws(new)
        programs = {id(p): prog for p, prog in zip(self._paths, self._programs, strict=True)}
        for path in {id(p): p for p in given}.values():
            if not isinstance(path, Path):
                raise ValueError(f"paths must be Path objects, got {path!r}")
            if path.dim != self.stage.dim:
                raise ValueError(f"path {path.name!r} is {path.dim}-D but stage "
                                 f"{self.stage.name!r} draws {self.stage.dim}-D contours")
            if id(path) not in programs:
                self.stage.check_travel(path)
                programs[id(path)] = self._build_program(path)
        self._paths, self._programs = new, [programs[id(p)] for p in new]
        self._build()

    def _build(self) -> None:
        # the bank of the distinct member paths, p_at, the starts (each bank path's first
        # point, and the axis positions there)
        slots: dict[int, int] = {}
        for path in self._paths:
            slots.setdefault(id(path), len(slots))
        self._bank_paths = list({id(p): p for p in self._paths}.values())
        programs = list({id(p): prog for p, prog in zip(self._paths, self._programs,
                                                       strict=True)}.values())
        self._slot = np.array([slots[id(p)] for p in self._paths], dtype=np.int64)
        self._pblob, self._kind, self.p_at = path_bank(self._bank_paths, programs, self._slot)
        self._firsts = np.stack([p.point(0.0) for p in self._bank_paths])
        self._starts = np.stack([self._start_of(q) for q in self._firsts])

    def _start_of(self, start: Array) -> Array:
        # (A,) axis positions at a path's first point ``start`` (contour offsets included), m
        out = np.zeros(self.stage.n_axes)
        for i, con in enumerate(self.stage.contours):
            for j in range(con.dim):
                out[con.axes[j]] = start[j] + self._offsets[i, j]
        return out

    def start_positions(self, member: int = 0) -> Array:
        """(A,) axis positions at the start of member ``member``'s path (offsets included), m."""
        return self._starts[self._slot[member]].copy()

    def start_points(self, idx: NDArray[np.intp]) -> Array:
        """(len(idx), dim) the first points of members ``idx``'s paths, m."""
        return self._firsts[self._slot[idx]]

    def start_axes(self, idx: NDArray[np.intp]) -> Array:
        """(len(idx), A) the axis positions at the start of members ``idx``'s paths, m."""
        return self._starts[self._slot[idx]]

    @property
    def time_step(self) -> float:
        """The time law's step, s (1 without one): a time-law path is every member's."""
        law = self._bank_paths[0].time_law
        return 1.0 if law is None else law.dt

    # ------------------------------------------------------------- planning
    def planned_time(self, overrides: Array, f_max: float, override: float | None = None,
                     member: int | None = None) -> float:
        """A generous estimate of one contour's duration, s.

        Args:
            overrides: (B,) each member's feed override.
            f_max: The machine's highest feed, m/s.
            override: Feed override to plan at (default: the member's, or the slowest
                member's).
            member: The member whose path to plan (default: the longest of every member's).
        """
        ovr_of = overrides if member is None else overrides[member : member + 1]
        slowest = max(float(ovr_of.min()) if override is None else override, 1e-9)
        if member is not None:
            return self._plan(self._paths[member], self._programs[member], slowest, f_max)
        programs = {id(p): prog for p, prog in zip(self._paths, self._programs, strict=True)}
        return max(self._plan(p, programs[id(p)], slowest, f_max) for p in self._bank_paths)

    def _plan(self, path: Path, program: motion.Program, slowest: float, f_max: float) -> float:
        if path.time_law is not None:
            return path.time_law.duration / slowest + self.opts.settle_time
        feed = np.minimum(program.feed, program.vcap)
        scale = np.where((program.flags.astype(int) & motion.RAPID) != 0, 1.0, slowest)
        speed = np.maximum(np.minimum(feed * scale, f_max), 1e-9)
        move = float(np.sum(np.diff(path.table.s0) / speed))
        dwell = float(program.dwell.sum()) * self.stage.ts
        stops = float(program.wait.sum()) * self.opts.settle_time
        return move + dwell + stops + self.opts.settle_time

    def programmed_feedrate(self, member: int = 0) -> float:
        """Member ``member``'s highest programmed feed on a cutting segment, m/s.

        The loop's ``nominal_feedrate`` on a plain path (or a part run at one feed); a
        part's highest F word when run at its own feeds (:func:`contour_gym.make_scenario`'s
        nominal for a G-code part).
        """
        program = self._programs[member]
        cut = program.cutting & ((program.flags.astype(np.int64) & motion.RAPID) == 0)
        feeds = program.feed[cut] if cut.any() else program.feed
        return float(np.max(feeds))

    def blobs(self) -> tuple[NDArray[np.int64], NDArray[Any], NDArray[np.int64]]:
        """The path bank's segment kinds, float blob and layout (what compiled callers take)."""
        return self._kind, self._pblob.buffer, self._pblob.layout


def _check_time_laws(paths: Sequence[Path]) -> None:
    """Raise ValueError unless members on a time-law path all share that one path."""
    timed = [p for p in paths if p.time_law is not None]
    if timed and any(p is not paths[0] for p in paths):
        raise ValueError(
            f"path {timed[0].name!r} carries a time law: such a path runs only when every "
            "member shares it (give it to all members, or give no member a time-law path)"
        )


__all__ = ["PathBank"]
