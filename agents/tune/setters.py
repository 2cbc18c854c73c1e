"""Setters: how a protocol writes ``(n, D)`` candidate parameters into the members of a loop.

A protocol names its setter (:data:`SETTERS`): ``"ccc_law"`` gives each member the CCC law's
parameters by name; ``"pid_factors"`` gives each member PID CCC gains scaled from the
machine's own (:data:`PID_FACTOR_NAMES`, :func:`pid_gains`); ``"acc2pid"`` gives each member
paper 003's ACC2PID, three two-dof PID axes and two P contour compensators
(:data:`ACC2PID_NAMES`, :func:`acc2pid_rows`, :func:`set_acc2pid`). A setter is called with the
loop, the parameter names, the ``(n, D)`` values and the scenario's own PID CCC gains
``(kp, ki, kd)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike

from agents.tune.fitness import FloatArray
from contour_gym.loop import ServoLoop
from contour_gym.servo.two_dof_pid import params_of

Gains = tuple[float, float, float]


def _set_ccc_law(loop: ServoLoop, names: Sequence[str], x: FloatArray, base: Gains) -> None:
    loop.set_ccc_params(**{name: x[:, j : j + 1] for j, name in enumerate(names)})


PID_FACTOR_NAMES = ("kp_factor", "ki_factor", "td")
"""The ``pid_factors`` setter's parameters: ``kp`` and ``ki`` as factors of the machine's own,
and ``td`` (s) a derivative time added to the machine's own ``kd0 / kp0``."""


def pid_gains(x: ArrayLike, base: Gains) -> FloatArray:
    """``(n, 3)`` :data:`PID_FACTOR_NAMES` values -> ``(n, 3)`` PID CCC gains ``kp, ki, kd``.

    ``kp = kp_factor kp0``, ``ki = ki_factor ki0``, ``kd = kp (kd0 / kp0 + td)``, with
    ``(kp0, ki0, kd0) = base`` the machine's own gains, in its units.

    Raises:
        ValueError: if the machine's ``kp0`` is not positive (nothing to scale).
    """
    kp0, ki0, kd0 = base
    if not kp0 > 0.0:
        raise ValueError(f"the pid_factors setter scales the machine's PID CCC gains: its kp "
                         f"is {kp0!r}, give the scenario ccc_gains with kp > 0")
    v = np.atleast_2d(np.asarray(x, dtype=np.float64))
    kp = v[:, 0] * kp0
    return np.stack([kp, v[:, 1] * ki0, kp * (kd0 / kp0 + v[:, 2])], axis=1)


def _set_pid_factors(loop: ServoLoop, names: Sequence[str], x: FloatArray, base: Gains) -> None:
    if tuple(names) != PID_FACTOR_NAMES:
        raise ValueError(f"the pid_factors setter needs the parameters {PID_FACTOR_NAMES}")
    gains = pid_gains(x, base)
    loop.set_ccc_params(kp=gains[:, :1], ki=gains[:, 1:2], kd=gains[:, 2:])


ACC2PID_AXES = ("x", "y1", "y2")
ACC2PID_COMPENSATORS = ("kc1x", "kc1y", "kc2x", "kc2y")
ACC2PID_NAMES = tuple(
    f"{q}_{a}" for a in ACC2PID_AXES for q in ("kp", "ti", "td", "alpha", "beta")
) + ACC2PID_COMPENSATORS
"""Paper 003's 19 ACC2PID parameters in its order (section 5.3's bee ``psi_i``), SI names:
``kp_x ti_x td_x alpha_x beta_x kp_y1 ... beta_y2 kc1x kc1y kc2x kc2y``."""


def acc2pid_rows(x: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """003's 19 parameters per member -> 2PID kernel rows and CCC weights.

    Args:
        x: ``(n, 19)`` in :data:`ACC2PID_NAMES` order, SI: ``Kp`` in V/m, ``TI, TD`` in s,
            ``alpha, beta`` dimensionless, ``K_c`` in V/m of contour error.

    Returns:
        ``(n, 3, P)`` two_dof_pid parameter rows (:func:`contour_gym.servo.two_dof_pid.params_of`)
        and ``(n, 2, 3)`` CCC weights ``[[K_c1x, K_c1y, 0], [K_c2x, K_c2y, 0]]`` (with the
        gantry's PID CCC ``kp = 1``, 003's P compensators eqs. 36-37).

    Raises:
        ValueError: for a shape other than ``(n, 19)`` or a value the 2PID rejects.
    """
    v = np.asarray(x, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != len(ACC2PID_NAMES):
        raise ValueError(f"ACC2PID parameters must have shape (n, 19), got {v.shape}")
    rows = params_of(v[:, :15].reshape(-1, 3, 5))
    weights = np.zeros((v.shape[0], 2, 3))
    weights[:, :, :2] = v[:, 15:].reshape(-1, 2, 2)
    return rows, weights


def set_acc2pid(
    loop: ServoLoop, names: Sequence[str], x: FloatArray, base: Gains | None = None
) -> None:
    """Give member ``b`` of ``loop`` the ACC2PID of ``x[b]`` (:func:`acc2pid_rows`).

    ``base`` (the scenario's PID CCC gains) is not used: 003's compensators replace them.

    Raises:
        ValueError: if ``names`` are not :data:`ACC2PID_NAMES` or the loop is not 003's
            2PID gantry (three axes, two contours).
    """
    if tuple(names) != ACC2PID_NAMES:
        raise ValueError(f"the acc2pid setter needs the parameters {ACC2PID_NAMES}")
    shape = (loop.stage.n_axes, len(loop.stage.contours))
    if loop.controller.name != "two_dof_pid" or shape != (3, 2):
        raise ValueError("the acc2pid setter needs 003's two_dof_pid gantry (3 axes, 2 contours)")
    rows, weights = acc2pid_rows(x)
    loop.set_controller_params(rows)
    loop.set_ccc_weights(weights)


SETTERS: dict[str, Callable[[ServoLoop, Sequence[str], FloatArray, Gains], None]] = {
    "ccc_law": _set_ccc_law,
    "pid_factors": _set_pid_factors,
    "acc2pid": set_acc2pid,
}
"""How a protocol writes ``(n, D)`` parameters (own units) into the ``n`` members of a loop."""

