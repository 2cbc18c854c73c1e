"""One axis driven open-loop through the servo loop's own plant step (tests, studies)."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym import jit
from contour_gym._validate import as_finite_array, positive
from contour_gym.plant._kernel import ST, STATE
from contour_gym.plant.friction import FRICTION_FAMILY, law_for
from contour_gym.plant.params import AxisParams
from contour_gym.plant.stage import (
    axis_row,
    disturbance_row,
    friction_row,
    ripple_rows,
    zoh_matrices,
)

Array = NDArray[np.float64]
LOOP_TEMPLATE = "contour_gym.loop.kernel"  # the servo loop's kernel template (contour_gym.jit)


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
        as_finite_array(noise, "noise", shape=(n,)))
    law = law_for(axis.friction)
    slots, codes = jit.bind({FRICTION_FAMILY: [law]})
    ax = axis_row(axis, codes[FRICTION_FAMILY.name][0], ideal=True)[None]
    ad, bd = zoh_matrices(ax, positive(ts, "ts") / substeps)
    st = np.zeros((1, STATE.size))
    st[0, ST.x], st[0, ST.v] = x0, v0
    kernel = jit.specialise(LOOP_TEMPLATE, slots)
    xs, vs = np.zeros(n), np.zeros(n)
    kernel.drive_axis(ax, friction_row(axis)[None], ripple_rows(axis)[None],
                      disturbance_row(axis, ts)[None], ad, bd, st, u, 0.0, ts, substeps, w, xs,
                      vs)
    return xs, vs, st[0].copy()
