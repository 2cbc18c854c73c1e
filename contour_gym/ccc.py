"""Cross-coupled controller (Koren 1980; papers 000-003): a PID on the contour error.

The CCC output ``U = kp eps + ki int(eps) + kd d(eps)/dt`` of each contour is distributed to
that contour's axes by the coupling gains ``C_i`` (the unit direction in which axis ``i``
must move to reduce the error, from the estimator) times optional per-axis weights ``w_i``
(003's separate compensator gains K_cix, K_ciy): ``u_i += w_i C_i U``.

Sign convention (DESIGN.md glossary): in 2-D ``eps`` is positive when the tool is to the
left of the direction of travel and ``C = -n_left``; in 3-D ``eps = |eps_vec| >= 0`` and
``C = eps_vec / |eps_vec|``. Either way the contour error vector (tool -> foot point) is
``eps_vec = C eps``, so a positive gain always pushes the tool back onto the path.

In 3-D the unsigned ``eps`` cannot carry integral action (its integral only grows), so the
PID acts on each signed component ``eps_vec_i`` with the same gains:
``u_i += w_i PID(eps_vec_i)``; in 2-D this would differ from the papers' scalar form only
through the frame's rotation, and the scalar form is kept there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from contour_gym._validate import as_finite_array
from contour_gym.servo import _kernel as SK


@dataclass(frozen=True)
class CCCGains:
    """PID gains of one contour's cross-coupled controller (control units per metre).

    Attributes:
        kp: Proportional gain.
        ki: Integral gain.
        kd: Derivative gain.
    """

    kp: float
    ki: float = 0.0
    kd: float = 0.0

    def __post_init__(self) -> None:
        vals = as_finite_array([self.kp, self.ki, self.kd], "CCC gains")
        if np.any(vals < 0):
            raise ValueError(f"CCC gains must be >= 0, got {self!r}")

    def as_tuple(self) -> tuple[float, float, float]:
        """Return ``(kp, ki, kd)``."""
        return (self.kp, self.ki, self.kd)


OFF = CCCGains(0.0, 0.0, 0.0)


def ccc_params(
    gains: ArrayLike | CCCGains | Sequence[float] | None, batch: int, n_contours: int
) -> np.ndarray:
    """Kernel rows (batch, n_contours, N_CP) from gains given as any broadcastable form.

    Args:
        gains: ``None`` (CCC off), a :class:`CCCGains`, a ``(kp, ki, kd)`` triple, or an
            array broadcastable to (batch, n_contours, 3).
        batch: Batch size.
        n_contours: Contours of the stage.

    Returns:
        The parameter rows.

    Raises:
        ValueError: on non-finite or negative gains, or a shape that does not broadcast.
    """
    if gains is None:
        gains = OFF
    if isinstance(gains, CCCGains):
        gains = gains.as_tuple()
    arr = as_finite_array(gains, "ccc_gains")
    try:
        arr = np.broadcast_to(arr, (batch, n_contours, 3))
    except ValueError as exc:
        raise ValueError(
            f"ccc_gains of shape {arr.shape} do not broadcast to (batch={batch}, "
            f"contours={n_contours}, 3)"
        ) from exc
    if np.any(arr < 0):
        raise ValueError(f"ccc_gains must be >= 0, got {arr.min()}")
    out = np.zeros((batch, n_contours, SK.N_CP))
    out[..., SK.CP_KP], out[..., SK.CP_KI], out[..., SK.CP_KD] = (
        arr[..., 0],
        arr[..., 1],
        arr[..., 2],
    )
    return out
