"""The compiled axis controllers of a stage for B members, outside the servo loop.

For a custom loop (hardware in the loop, another simulator) or to inspect a controller: the
same compiled laws :class:`contour_gym.loop.ServoLoop` inlines, on the same parameter rows and
state, with every input checked.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import jit
from contour_gym._validate import as_finite_array
from contour_gym.servo.base import CONTROLLER_FAMILY
from contour_gym.servo.build import build_controller
from contour_gym.servo.compensation import COMPENSATION_FAMILY
from contour_gym.servo.compensation import STATE as COMP_STATE
from contour_gym.servo.gains import PIDGains

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage

Array = NDArray[np.float64]


class AxisControllers:
    """A batch of per-axis controllers for one stage.

    Args:
        name: Controller name, a key of :data:`contour_gym.servo.CONTROLLERS`.
        stage: The machine (sampling time, saturation, nominal model).
        gains: The baseline PID gains per axis (e.g. a preset's ``axis_gains``).
        batch_size: Number of members B.
        **options: The controller's options.

    Attributes:
        controller: The registered controller.
        params: (B, A, P) parameter rows (assign to change members' parameters).
        state: (B, A, S) controller state.
        compensation: (B, A, N) friction-compensation rows.
    """

    def __init__(
        self,
        name: str,
        stage: Stage,
        gains: Sequence[PIDGains],
        batch_size: int = 1,
        **options: object,
    ) -> None:
        if not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
            raise ValueError(f"batch_size must be a positive int, got {batch_size!r}")
        self.controller, self.params, self.compensation = build_controller(
            name, stage, gains, int(batch_size), **options
        )
        self.ts = stage.ts
        self.u_max = np.array([a.u_max for a in stage.axes])
        b, a = self.params.shape[:2]
        self.state = np.zeros((b, a, self.controller.state.size))
        self.comp_state = np.zeros((b, a, COMP_STATE.size))
        slots, codes = jit.bind(
            {CONTROLLER_FAMILY: [self.controller], COMPENSATION_FAMILY: [True]}
        )
        self._codes = (codes[CONTROLLER_FAMILY.name][0], codes[COMPENSATION_FAMILY.name][0])
        self._kernel = jit.specialise("contour_gym.servo._bank", slots)

    def reset(self) -> None:
        """Zero every member's state (integrators, observer, bristle state, history)."""
        self.state[:] = 0.0
        self.comp_state[:] = 0.0

    def _tables(self) -> tuple[Array, Array, Array, Array]:
        # the kernels' (B * A, N) row tables; the states' are views, written in place
        def table(arr: Array) -> Array:
            return np.ascontiguousarray(arr, dtype=np.float64).reshape(-1, arr.shape[-1])

        for attr in ("state", "comp_state"):
            if not getattr(self, attr).flags.c_contiguous:
                setattr(self, attr, np.ascontiguousarray(getattr(self, attr)))
        return (
            table(self.params), self.state.reshape(-1, self.state.shape[-1]),
            table(self.compensation), self.comp_state.reshape(-1, self.comp_state.shape[-1]),
        )

    def _input(self, value: ArrayLike, name: str) -> Array:
        arr = as_finite_array(value, name)
        shape = self.params.shape[:2]
        try:
            return np.broadcast_to(arr, shape)
        except ValueError as exc:
            raise ValueError(f"{name} of shape {arr.shape} does not broadcast to {shape}") from exc

    def _inputs(self, r: ArrayLike, r_dot: ArrayLike, r_ddot: ArrayLike, y: ArrayLike) -> Array:
        names = ("r", "r_dot", "r_ddot", "y")
        return np.ascontiguousarray(
            np.stack([self._input(v, n) for v, n in zip((r, r_dot, r_ddot, y), names, strict=True)])
        )

    def control(self, r: ArrayLike, r_dot: ArrayLike, r_ddot: ArrayLike, y: ArrayLike) -> Array:
        """Control of this tick, before saturation, without changing the state.

        Args:
            r: Reference position per member and axis, m, broadcastable to (B, A).
            r_dot: Reference velocity, m/s.
            r_ddot: Reference acceleration, m/s^2.
            y: Measured position, m.

        Returns:
            (B, A) control signal.

        Raises:
            ValueError: for a non-finite (NaN) input or a shape that does not broadcast.
        """
        out = np.zeros(self.params.shape[:2])
        ins = self._inputs(r, r_dot, r_ddot, y)
        self._kernel.control_all(*self._codes, *self._tables(), ins, self.ts, out)
        return out

    def step(
        self,
        r: ArrayLike,
        r_dot: ArrayLike,
        r_ddot: ArrayLike,
        y: ArrayLike,
        u_extra: ArrayLike = 0.0,
    ) -> Array:
        """One tick: control, plus ``u_extra`` (e.g. a CCC's share), commit, saturate.

        Args:
            r: Reference position, m, broadcastable to (B, A).
            r_dot: Reference velocity, m/s.
            r_ddot: Reference acceleration, m/s^2.
            y: Measured position, m.
            u_extra: Control added before saturation (it counts for anti-windup and the
                observer, as in the loop).

        Returns:
            (B, A) saturated control to apply.

        Raises:
            ValueError: for a non-finite (NaN) input or a shape that does not broadcast.
        """
        ins = self._inputs(r, r_dot, r_ddot, y)
        total = np.zeros(self.params.shape[:2])
        tables = self._tables()
        self._kernel.control_all(*self._codes, *tables, ins, self.ts, total)
        total += self._input(u_extra, "u_extra")
        self._kernel.commit_all(*self._codes, *tables, ins, self.ts, total, self.u_max)
        return np.clip(total, -self.u_max, self.u_max)
