"""What a policy is: :class:`Policy`, its helpers, and the registry policies are made from.

A policy acts on a *batch* of observations (:class:`Policy`); :class:`ConstantPolicy` and
:class:`CNCLookahead` are the simplest. :data:`POLICIES` holds every policy by name
(:func:`register_policy`, :func:`make_policy`); :mod:`agents.policies`, which re-exports this
module, fills it with the reference families and the trained agents on first use.
"""

from __future__ import annotations

import abc
import inspect
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym.envs.core import CCC, FEEDRATE
from contour_gym.motion import DEFAULT_TOLERANCE
from contour_gym.params import as_finite_array, choice, positive
from contour_gym.registry import Registry

Actions = NDArray[np.float64]
Observation = Mapping[str, ArrayLike]


class Policy(abc.ABC):
    """A batch-first policy: ``act(obs) -> actions (B, n)``, ``reset(env)``, ``env_kwargs``.

    Actions are float64 (the envs take any float; float64 keeps a policy's gains exact).
    :attr:`tasks` names the env kinds the policy acts in (``"ccc"``, ``"feedrate"``; both by
    default): a harness runs a policy only on scenarios of those kinds (:mod:`agents.bench`).
    """

    name: ClassVar[str] = "policy"
    tasks: ClassVar[tuple[str, ...]] = (CCC, FEEDRATE)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """Env keyword arguments this policy needs the env built with (a fresh dict)."""
        return {}

    def reset(self, env: Any = None) -> None:  # noqa: B027 (stateless policies need nothing)
        """Start a batch of episodes.

        Args:
            env: The env (single or native vector) the policy acts in, for policies that read
                its action map; None when the policy needs nothing from it.
        """

    @abc.abstractmethod
    def act(self, obs: Observation) -> Actions:
        """Actions ``(B, n)`` for a batch of observations (every value ``(B, ...)``).

        Raises:
            ValueError: for an observation that is not a batched contour_gym observation, or
                one of an env the policy cannot act in.
        """

    def predict(
        self,
        obs: Observation,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[Actions, Any]:
        """Stable-baselines3's interface on a batch: ``(act(obs), state)``."""
        return self.act(obs), state


def batch_size(obs: Observation) -> int:
    """The leading (batch) dimension shared by every value of a batched observation.

    Raises:
        ValueError: for an empty or non-mapping observation, or values without a common
            leading dimension (an unbatched single-env observation included).
    """
    if not isinstance(obs, Mapping) or not obs:
        raise ValueError(f"obs must be a non-empty dict of arrays, got {type(obs).__name__}")
    shapes = {k: np.shape(v) for k, v in obs.items()}
    sizes = {s[0] for s in shapes.values() if len(s) == 2}
    if len(sizes) != 1 or any(len(s) != 2 for s in shapes.values()):
        raise ValueError(
            f"obs values must be batched (B, n) arrays with one B, got shapes {shapes}; add a "
            "leading axis to a single env's observation"
        )
    return sizes.pop()


def action_size(obs: Observation) -> int:
    """The action length of the env that made ``obs``: 3C (CCC env) or 1 (feedrate env)."""
    if "gains" in obs:
        return int(np.shape(obs["gains"])[-1])
    if "feedrate" in obs:
        return 1
    raise ValueError(f"not a contour_gym observation (keys {sorted(obs)})")


class ConstantPolicy(Policy):
    """The same action at every step (``constant``).

    In the feedrate env the action is the override change ``a`` (``F(k) = F(k-1) + a
    max_feedrate_change F_nom``; 0 holds the override the env starts at, ``feedrate_override``).
    In the CCC env give ``gains`` (kp, ki, kd), mapped by the env's ``gains_to_action`` at
    :meth:`reset`, or a raw action vector.

    Args:
        action: A scalar (every component, any env), an ``(n,)`` vector or a ``(B, n)`` array
            (one row per batch member), in [-1, 1]. Default 0 when ``gains`` is not given.
        gains: CCC env: (kp, ki, kd) for every contour, or ``(C, 3)``; must lie within the
            env's gain range (an action in [-1, 1]).

    Raises:
        ValueError: for both or non-finite arguments, actions outside [-1, 1], negative gains
            or a gains shape other than (3,) or (C, 3), naming the value.
    """

    name = "constant"

    def __init__(self, action: ArrayLike | None = None, *, gains: ArrayLike | None = None) -> None:
        if action is not None and gains is not None:
            raise ValueError(f"give action or gains, not both (action={action!r}, gains={gains!r})")
        self.gains: NDArray[np.float64] | None = None
        self._action: NDArray[np.float64] | None = None
        if gains is not None:
            g = as_finite_array(gains, "gains")
            if g.shape[-1:] != (3,) or g.ndim > 2 or np.any(g < 0):
                raise ValueError(f"gains must be >= 0 (kp, ki, kd) or (C, 3), got {gains!r}")
            self.gains = g
        else:
            self._action = _in_unit_box(0.0 if action is None else action, "action")

    def reset(self, env: Any = None) -> None:
        """Map ``gains`` to the action of ``env`` (a CCC env, single or vector).

        Raises:
            ValueError: for gains without a CCC env, or gains beyond the env's range.
        """
        if self.gains is None:
            return
        task = getattr(getattr(env, "unwrapped", None), "task", None)
        if task is None or task.kind != CCC:
            raise ValueError(f"constant(gains=...) needs a contour_gym CCC env, got {env!r}")
        g = np.broadcast_to(self.gains, (task.n_contours, 3))
        action = task.gains_to_action(g)
        if np.any(np.abs(action) > 1.0 + 1e-12):
            raise ValueError(
                f"gains {self.gains.tolist()} are beyond the env's range (largest kp, ki, kd "
                f"{task.g_max.tolist()}; raise gain_range or kd_scale)"
            )
        self._action = np.clip(action, -1.0, 1.0)

    def act(self, obs: Observation) -> Actions:
        """The constant action, ``(B, n)`` (see the class docstring)."""
        if self._action is None:
            raise ValueError("constant(gains=...) maps its gains at reset(env): call it first")
        b, n = batch_size(obs), action_size(obs)
        a = self._action
        if a.ndim == 0:
            return np.full((b, n), float(a))
        if a.shape[-1] != n or (a.ndim == 2 and a.shape[0] != b):
            raise ValueError(f"constant action of shape {a.shape} does not fit a batch of {b} "
                             f"members with {n} action(s) each")
        return np.array(np.broadcast_to(a, (b, n)))


def _in_unit_box(value: ArrayLike, name: str) -> NDArray[np.float64]:
    a = as_finite_array(value, name)
    if a.ndim > 2 or np.any(np.abs(a) > 1.0):
        raise ValueError(f"{name} must be a scalar, (n,) or (B, n) within [-1, 1], got {value!r}")
    return a


LOOKAHEAD_MODES = ("G64", "G61", "G61.1")


class CNCLookahead(Policy):
    """What a CNC does by itself (``cnc_lookahead``): its own path planning at 100 % override.

    The env is built with ``path_control=mode`` (and ``path_tolerance=tolerance`` under G64)
    and ``feedrate_override=1.0`` (:attr:`env_kwargs`); the policy acts 0 in the feedrate env,
    ``F(k) = F(k-1) + 0``, so every cutting move runs at its programmed feed wherever the
    interpolator's planning allows. A G-code part's own G61/G61.1/G64 choices are replaced by
    ``mode``; its mandatory stops (M codes, G28, dwells, changes between rapid and feed:
    ``GcodePath.mandatory_stops``) stay.

    The planning is :func:`contour_gym.motion.build_program`'s; at the junction of segment j
    (end direction ``t_j``) and j + 1 (start direction ``t_(j+1)``), with ``a`` the machine's
    tangential acceleration limit (the preset's ``accel``; under an acc/dec time constant T the
    lower of ``F / T`` of the two segments' feeds, as :mod:`contour_gym.motion` says) and
    ``delta`` the G64 tolerance, it uses Grbl's junction-deviation rule::

        c     = -t_j . t_(j+1)                     (cos of the angle between -t_j and t_(j+1))
        h     = sqrt((1 - c) / 2)                  (its half-angle sine)
        v_j^2 = a delta h / (1 - h)

    (``v_j = inf`` straight on, ``t_j . t_(j+1) >= 0.999999``; ``0`` on a reversal; ``inf``
    when ``a = inf``). G61 sets every ``v_j = 0`` (exact stop; the next block starts when the
    axes are in position); G61.1 takes ``delta = 0``, a stop only where the tangent jumps by
    more than 1e-8. Every segment is also capped at ``sqrt(a / kappa_max)`` (its curvature
    sampled at 9 points), the path end is 0, and a backward pass lowers each ``v_j`` to
    ``sqrt(v_(j+1)^2 + 2 a L_(j+1))`` so that every limit is reachable by braking at ``a``; the
    interpolator then brakes for every limit within its braking reach (``a`` of segment
    j + 1 there). The override does not scale the junction speeds (a starting override does
    under a time constant, through ``F / T``). ``delta`` is the distance from the vertex to the
    circular arc tangent to both segments whose radius ``R = delta h / (1 - h)`` is taken at
    centripetal acceleration ``a`` (``v_j^2 = a R``); but the reference is not blended (it
    passes through the vertex at ``v_j`` with a jump in direction), so ``delta`` does not bound
    the servo's contour error: ``benchmarks/feedrate_baselines.py`` measures it.

    Args:
        tolerance: G64 path tolerance (the P value), m (default
            :data:`contour_gym.motion.DEFAULT_TOLERANCE`); only with ``mode="G64"``.
        mode: ``"G64"`` (blending), ``"G61"`` (exact stop at every junction) or ``"G61.1"``
            (exact path: stops at corners only).

    Raises:
        ValueError: for an unknown mode, a tolerance <= 0 or non-finite, or a tolerance with
            a mode other than G64, naming the value.
    """

    name = "cnc_lookahead"
    tasks = (FEEDRATE,)

    def __init__(self, tolerance: float | None = None, mode: str = "G64") -> None:
        self.mode = choice(mode, "mode", LOOKAHEAD_MODES)
        if mode != "G64" and tolerance is not None:
            raise ValueError(f"tolerance applies to mode 'G64' only, got tolerance={tolerance!r} "
                             f"with mode={mode!r}")
        self.tolerance: float | None = None
        if mode == "G64":
            given = DEFAULT_TOLERANCE if tolerance is None else tolerance
            self.tolerance = positive(given, "tolerance")

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """``path_control`` (and ``path_tolerance`` under G64), ``feedrate_override=1.0``."""
        out: dict[str, Any] = {"path_control": self.mode, "feedrate_override": 1.0}
        if self.tolerance is not None:
            out["path_tolerance"] = self.tolerance
        return out

    def act(self, obs: Observation) -> Actions:
        """Zeros ``(B, 1)``: hold the override (feedrate env only)."""
        if "feedrate" not in obs:
            raise ValueError(f"cnc_lookahead acts in the feedrate env; obs keys {sorted(obs)}")
        return np.zeros((batch_size(obs), 1))


@dataclass(frozen=True)
class PolicyEntry:
    """A registered policy: its name and the factory that builds it from its parameters."""

    name: str
    factory: Callable[..., Policy] = field(repr=False)

    def params(self) -> tuple[str, ...] | None:
        """The factory's keyword parameters (None: it takes ``**kwargs``, any name)."""
        sig = inspect.signature(self.factory).parameters.values()
        if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in sig):
            return None
        kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
        return tuple(p.name for p in sig if p.kind in kinds)


POLICIES: Registry[PolicyEntry] = Registry("policy")  # filled on first use: agents.policies


def register_policy(name: str, factory: Callable[..., Policy], *, replace: bool = False) -> None:
    """Register a policy factory (a :class:`Policy` subclass or a function) under ``name``.

    Args:
        name: Registry key (letters, digits and ``_``).
        factory: Called with the keyword parameters given to :func:`make_policy`; raises
            ValueError naming a bad value.
        replace: Replace an existing registration of ``name``.

    Raises:
        ValueError: for a taken name (unless ``replace``) or an invalid one.
    """
    POLICIES.register(PolicyEntry(name, factory), replace=replace)


def make_policy(name: str, **params: Any) -> Policy:
    """A new policy ``name`` built with ``params``.

    Raises:
        ValueError: for an unknown name (listing the registered ones), an unknown parameter
            (listing the accepted ones) or a bad value (naming it).
    """
    entry = POLICIES.get(name)
    accepted = entry.params()
    if accepted is not None:
        unknown = sorted(set(params) - set(accepted))
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown} of policy {name!r}; accepted: "
                             f"{', '.join(accepted) or 'none'}")
    policy = entry.factory(**params)
    if not isinstance(policy, Policy):
        raise ValueError(f"policy factory {name!r} returned {type(policy).__name__}, not Policy")
    return policy


register_policy("constant", ConstantPolicy)
register_policy("cnc_lookahead", CNCLookahead)
