"""The servo loop's searched parameters: CCC gains and weights, feed, controller, plant scaling.

:class:`Parameters` is held by :class:`contour_gym.loop.ServoLoop` (``loop.parameters``; the
loop's setters of the same names call it): it writes checked values in place into the loop's
parameter arrays (:mod:`contour_gym.loop.views`), per batch member where optimisers, agents and
domain randomisation need them to differ.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym._validate import as_finite_array
from contour_gym.ccc import CCCLaw, ccc_params
from contour_gym.loop.views import Array, LoopViews, member_indices
from contour_gym.motion import IP, Interpolator
from contour_gym.plant._kernel import AX, DISTURBANCE
from contour_gym.plant.friction import law_for
from contour_gym.plant.stage import Stage, zoh_matrices


class Parameters:
    """Setters of the parameters optimisers and agents search, on one loop's arrays.

    Args:
        loop: The loop's arrays (its :class:`~contour_gym.loop.views.LoopViews`).
        ccc_law: The loop's CCC law.
        interpolator: The loop's feed settings.
    """

    def __init__(self, loop: LoopViews, ccc_law: CCCLaw, interpolator: Interpolator) -> None:
        self.loop, self.ccc_law, self.interpolator = loop, ccc_law, interpolator
        self.stage, self.batch_size = loop.stage, loop.batch_size
        # the stage's ax_p, fr_p, dist, rip before any scaling
        self._nominal = (loop.ax_p.copy(), loop.fr_p.copy(), loop.dist.copy(), loop.rip.copy())

    def __getstate__(self) -> dict[str, object]:
        # the law is pickled by name with its loop, which gives it back on load
        return {k: v for k, v in self.__dict__.items() if k != "ccc_law"}

    def set_ccc_gains(self, gains: ArrayLike | None, members: ArrayLike | None = None) -> None:
        """Set the CCC gains (kp, ki, kd); None switches the CCC off.

        Args:
            gains: Broadcastable to (n, C, 3) for the n members set.
            members: Indices or mask of the members to set (default: all).
        """
        idx = self._members(members)
        rows = ccc_params(gains, len(idx), len(self.stage.contours))
        self.loop.ccc_p[idx, :, :3] = rows[..., :3]

    def _members(self, members: ArrayLike | None) -> NDArray[np.intp]:
        return member_indices(self.batch_size, members)

    def set_ccc_params(self, **params: ArrayLike) -> None:
        """Set the CCC law's named parameters, each broadcastable to (B, C)."""
        schema = self.ccc_law.params
        schema.check_names(params)
        for name, value in params.items():
            arr = np.broadcast_to(as_finite_array(value, name), self.loop.ccc_p.shape[:2])
            for x in np.unique(arr):
                schema.value(name, x)
            self.loop.ccc_p[..., schema.names.index(name)] = arr

    def set_ccc_weights(self, weights: ArrayLike) -> None:
        """Set per-member CCC output weights, broadcastable to (B, C, 3).

        ``weights[b, c, i]`` scales what contour ``c``'s CCC adds to coordinate ``i`` of
        member ``b`` (:mod:`contour_gym.ccc`; e.g. 003's compensator gains K_cix, K_ciy with
        ``kp = 1``).

        Raises:
            ValueError: for a NaN or infinite weight or a shape that does not broadcast.
        """
        _assign(self.loop.ccc_w, weights, "ccc_weights")

    @property
    def nominal_feedrate(self) -> float:
        """The programmed cutting feedrate the override refers to, m/s."""
        return float(self.interpolator.feedrate)  # every member's program's nominal

    def set_feedrate(self, feedrate: ArrayLike) -> None:
        """Command a feedrate (m/s), scalar or (B,): the override ``F / nominal_feedrate``."""
        f = as_finite_array(feedrate, "feedrate")
        if np.any(f < 0):
            raise ValueError(f"feedrate must be >= 0, got {f.min()}")
        self.set_feed_override(f / self.nominal_feedrate)

    def set_feed_override(self, override: ArrayLike, members: ArrayLike | None = None) -> None:
        """Set the feed override (fraction of the programmed feeds).

        Args:
            override: Scalar, or one per member set.
            members: Indices or mask of the members to set (default: all).
        """
        o = as_finite_array(override, "feed override")
        if np.any(o < 0):
            raise ValueError(f"feed override must be >= 0, got {o.min()}")
        idx = self._members(members)
        self.loop.ip_p[idx, IP.ovr] = np.broadcast_to(o, (len(idx),))

    @property
    def feedrate(self) -> Array:
        """(B,) commanded feedrate of the cutting moves, m/s (before the machine's cap)."""
        return self.loop.ip_p[:, IP.ovr] * self.nominal_feedrate

    def set_controller_params(self, params: ArrayLike) -> None:
        """Set per-member axis controller parameters, broadcastable to (B, A, P).

        The columns are the controller's schema (``loop.controller.params.col``).
        """
        _assign(self.loop.ctrl_p, params, "controller params")

    def set_plant_scaling(
        self,
        members: ArrayLike,
        *,
        mass: ArrayLike = 1.0,
        damping: ArrayLike = 1.0,
        force_constant: ArrayLike = 1.0,
        friction: ArrayLike = 1.0,
        disturbance: ArrayLike = 1.0,
        friction_params: Mapping[str, ArrayLike] | None = None,
        random_disturbance: ArrayLike = 1.0,
        ripple: ArrayLike = 1.0,
    ) -> None:
        """Scale members' axis parameters relative to the stage's nominal values.

        Domain randomisation (axis mismatch, friction and disturbance levels; 002 section 4.2
        analyses gain and time-constant mismatch) and identification (a candidate machine per
        member). Each factor broadcasts to (len(members), n_axes) and must be finite and > 0
        (friction/disturbance >= 0); friction scales the parameters each law names in its
        ``scale``; ``friction_params`` scales single friction parameters by name (``fc``,
        ``sigma0``, ...) on the axes whose law has them, on top of ``friction``;
        ``random_disturbance`` scales the disturbance's random part alone, on top of
        ``disturbance`` (0: its deterministic part only, as an identification replays a log);
        ``ripple`` scales the force ripple's amplitudes (>= 0).
        """
        idx = self._members(members)
        shape = (len(idx), self.stage.n_axes)
        f = _scale_factors(shape, mass=mass, damping=damping, force_constant=force_constant,
                           friction=friction, disturbance=disturbance,
                           random_disturbance=random_disturbance, ripple=ripple)
        one = _friction_factors(self.stage, shape, friction_params or {})
        ax_p, fr_p, dist, rip = (arr[idx].copy() for arr in self._nominal)
        ax_p[..., AX.m] *= f["mass"]
        ax_p[..., AX.b] *= f["damping"]
        ax_p[..., AX.k] *= f["force_constant"]
        for a, axis in enumerate(self.stage.axes):
            law = law_for(axis.friction)
            for name in law.scale:
                fr_p[:, a, law.params.names.index(name)] *= f["friction"][:, a]
            for name, factor in one.items():
                if name in law.params.names:
                    fr_p[:, a, law.params.names.index(name)] *= factor[:, a]
        for name in ("step_a", "sin_a", "rnd_std"):
            dist[..., DISTURBANCE.names.index(name)] *= f["disturbance"]
        dist[..., DISTURBANCE.names.index("rnd_std")] *= f["random_disturbance"]
        rip[..., :2] *= f["ripple"][:, :, None, None]  # (a_j, b_j); the wavenumbers stay
        loop = self.loop
        loop.ax_p[idx], loop.fr_p[idx], loop.dist[idx], loop.rip[idx] = ax_p, fr_p, dist, rip
        loop.ad[idx], loop.bd[idx] = zoh_matrices(ax_p, self.stage.ts / self.stage.substeps)


def _scale_factors(shape: tuple[int, int], **factors: ArrayLike) -> dict[str, Array]:
    """The plant scale factors broadcast to ``shape``, checked (> 0; the others >= 0)."""
    f = {k: np.broadcast_to(as_finite_array(v, k), shape) for k, v in factors.items()}
    for k in ("mass", "damping", "force_constant"):
        if np.any(f[k] <= 0):
            raise ValueError(f"{k} scale must be > 0, got {f[k].min()}")
    for k in ("friction", "disturbance", "random_disturbance", "ripple"):
        if np.any(f[k] < 0):
            raise ValueError(f"{k} scale must be >= 0, got {f[k].min()}")
    return f


def _friction_factors(
    stage: Stage, shape: tuple[int, int], factors: Mapping[str, ArrayLike]
) -> dict[str, Array]:
    """Per-parameter friction factors broadcast to ``shape``, checked (>= 0, known names)."""
    known = {n for axis in stage.axes for n in law_for(axis.friction).params.names}
    out = {}
    for name, value in factors.items():
        if name not in known:
            raise ValueError(f"friction_params: no axis's friction law has {name!r}; the laws "
                             f"here have {', '.join(sorted(known)) or 'no parameters'}")
        out[name] = np.broadcast_to(as_finite_array(value, name), shape)
        if np.any(out[name] < 0):
            raise ValueError(f"friction_params[{name!r}] must be >= 0, got {out[name].min()}")
    return out


def _assign(target: Array, value: ArrayLike, name: str) -> None:
    """Write finite ``value`` into ``target`` in place, broadcast; ValueError naming ``name``."""
    v = as_finite_array(value, name)
    try:
        target[...] = np.broadcast_to(v, target.shape)
    except ValueError as exc:
        raise ValueError(f"{name} of shape {v.shape} do not broadcast to {target.shape}") from exc
