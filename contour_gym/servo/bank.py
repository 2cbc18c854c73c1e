"""The compiled axis controllers of a stage for B members, outside the servo loop.

For a custom loop (hardware in the loop, another simulator) or to inspect a controller: the
same kernels :class:`contour_gym.loop.ServoLoop` calls, on the same parameter rows and state,
with every input checked.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array
from contour_gym.servo import _kernel as K  # noqa: N812
from contour_gym.servo.builders import build_controller
from contour_gym.servo.gains import PIDGains

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage

Array = NDArray[np.float64]


@numba.njit(cache=True)
def _control_all(kind, p, s, ins, ts, out):  # type: ignore[no-untyped-def]
    # p, s: (B * A, N) row tables; ins: (4, B, A) reference position, velocity,
    # acceleration and measured position
    n_axes = ins.shape[2]
    for b in range(ins.shape[1]):
        for a in range(n_axes):
            r, r_dot, r_ddot, y = ins[0, b, a], ins[1, b, a], ins[2, b, a], ins[3, b, a]
            out[b, a] = K.axis_control(kind, p, s, b * n_axes + a, r, r_dot, r_ddot, y, ts)


@numba.njit(cache=True)
def _commit_all(kind, p, s, ins, ts, u_total, u_max):  # type: ignore[no-untyped-def]
    n_axes = ins.shape[2]
    for b in range(ins.shape[1]):
        for a in range(n_axes):
            r, r_dot, r_ddot, y = ins[0, b, a], ins[1, b, a], ins[2, b, a], ins[3, b, a]
            i = b * n_axes + a
            K.axis_commit(kind, p, s, i, r, r_dot, r_ddot, y, ts, u_total[b, a], u_max[a])


class AxisControllers:
    """A batch of per-axis controllers for one stage.

    Args:
        name: Controller name, a key of :data:`contour_gym.servo.CONTROLLERS`.
        stage: The machine (sampling time, saturation, nominal model).
        gains: The baseline PID gains per axis (e.g. a preset's ``axis_gains``).
        batch_size: Number of members B.
        **options: The controller's options.

    Attributes:
        kind: Kernel kind.
        params: (B, A, N_CP) parameter rows (assign to change members' parameters).
        state: (B, A, N_CS) controller state.
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
        self.kind, self.params = build_controller(name, stage, gains, int(batch_size), **options)
        self.ts = stage.ts
        self.u_max = np.array([a.u_max for a in stage.axes])
        self.state = np.zeros(self.params.shape[:2] + (K.N_CS,))

    def reset(self) -> None:
        """Zero every member's state (integrators, observer, bristle state, history)."""
        self.state[:] = 0.0

    def _tables(self) -> tuple[Array, Array]:
        # the kernels' (B * A, N) row tables; the state's is a view, written in place
        params = np.ascontiguousarray(self.params, dtype=np.float64).reshape(-1, K.N_CP)
        if not self.state.flags.c_contiguous:
            self.state = np.ascontiguousarray(self.state)
        return params, self.state.reshape(-1, K.N_CS)

    def _input(self, value: ArrayLike, name: str) -> Array:
        arr = as_finite_array(value, name)
        shape = self.params.shape[:2]
        try:
            return np.broadcast_to(arr, shape)
        except ValueError as exc:
            raise ValueError(f"{name} of shape {arr.shape} does not broadcast to {shape}") from exc

    def _inputs(self, r: ArrayLike, r_dot: ArrayLike, r_ddot: ArrayLike, y: ArrayLike) -> Array:
        names = ("r", "r_dot", "r_ddot", "y")
        return np.stack(
            [self._input(v, n) for v, n in zip((r, r_dot, r_ddot, y), names, strict=True)]
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
        _control_all(self.kind, *self._tables(), self._inputs(r, r_dot, r_ddot, y), self.ts, out)
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
        params, state = self._tables()
        _control_all(self.kind, params, state, ins, self.ts, total)
        total += self._input(u_extra, "u_extra")
        _commit_all(self.kind, params, state, ins, self.ts, total, self.u_max)
        return np.clip(total, -self.u_max, self.u_max)
