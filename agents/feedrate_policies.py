"""Reference policies of the feedrate env: 004's fuzzy feedrate controller and a held override.

* ``fuzzy_feedrate`` (:class:`FuzzyFeedrate`): paper 004's Mamdani controller
  (:func:`agents.fuzzy.fuzzy_feedrate_004`, table 3.1 as extracted) closing the loop on the
  estimated contour error, ``F(k) = F(k-1) + g_dF dF(E, DE)`` (004 eq. 3.3);
* ``constant_feedrate`` (:class:`ConstantFeedrate`): a feed override held for the whole
  episode, 004's "constant speed" baseline;
* ``curvature_feed_limit`` (:class:`CurvatureFeedLimit`): the override a centripetal
  acceleration limit on the curvature ahead allows, as a CNC limits its feed on curves.

All are registered with :func:`agents.policies.register_policy` when this module is imported
(:func:`agents.policies.available` and :func:`agents.policies.make` import it):

>>> from agents.policies import make
>>> make("constant_feedrate", override=0.8).env_kwargs
{'feedrate_override': 0.8}
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, cast

import numpy as np

from agents.fuzzy import FEEDRATE_GAIN_004, CompiledMamdani, fuzzy_feedrate_004
from agents.policy_base import (
    Actions,
    ConstantPolicy,
    Observation,
    Policy,
    batch_size,
    register_policy,
)
from contour_gym.envs.core import FEEDRATE, ContourTask
from contour_gym.params import as_finite_array, choice, finite, positive

MM_PER_S = 1e-3  # m/s

# 004 gives g_dF = 0.35 without a unit. Each reading -> the override change per decision that
# one unit of g_dF dF makes, from (programmed feedrate F_nom in m/s, servo ticks per decision).
DF_UNITS: dict[str, Callable[[float, int], float]] = {
    "nominal_per_decision": lambda f_nom, ticks: 1.0,
    "nominal_per_tick": lambda f_nom, ticks: float(ticks),
    "mm_per_s_per_decision": lambda f_nom, ticks: MM_PER_S / f_nom,
    "mm_per_s_per_tick": lambda f_nom, ticks: MM_PER_S * ticks / f_nom,
}
DEFAULT_DF_UNIT = "mm_per_s_per_tick"


def feedrate_task(env: Any, who: str) -> ContourTask:
    """The :class:`~contour_gym.envs.core.ContourTask` of a feedrate env (single or vector).

    Raises:
        ValueError: for anything but a contour_gym feedrate env, naming ``who`` needs one.
    """
    task = getattr(getattr(env, "unwrapped", None), "task", None)
    if not isinstance(task, ContourTask) or task.kind != FEEDRATE:
        raise ValueError(f"{who} needs a contour_gym feedrate env, got {env!r}")
    return task


def _require_feedrate_obs(obs: Observation, who: str) -> None:
    if "feedrate" not in obs or "contour_error" not in obs:
        raise ValueError(f"{who} acts in the feedrate env; obs keys {sorted(obs)}")


class FuzzyFeedrate(Policy):
    """Paper 004's fuzzy feedrate controller (``fuzzy_feedrate``).

    Every decision, for every member at once (one call of the compiled surface,
    :meth:`agents.fuzzy.CompiledMamdani.lookup`)::

        E  = clip(e_gain  * contour_error,        -1, 1)   (observed: eps_hat / tol)
        DE = clip(de_gain * contour_error_change, -1, 1)   (observed: its change / tol)
        dF = fuzzy_feedrate_004(E, DE)                     (in [-1, 1])
        a  = clip(gain * dF * unit / max_feedrate_change, -1, 1)

    so that the env's ``F(k) = clip(F(k-1) + a max_feedrate_change F_nom)`` is 004's
    ``F(k) = F(k-1) + g_dF dF`` (eq. 3.3) with ``dF`` in the unit ``unit`` (below) until the
    env's own rate limit ``max_feedrate_change`` (read at :meth:`reset`) clips it.

    **Inputs.** 004 scales both gains "as the contour error bound", ``g_e = g_ce = 1 / tol``:
    the observation already divides by the env's tolerance, so ``e_gain = de_gain = 1`` is
    004's scaling and the universes [-1, 1] end at one tolerance. The error is the env's
    estimate (the preset's estimator, 004's variable window on its rig), signed in 2-D (its
    sign says on which side of the path the tool is), and 004 feeds the signed error: the
    rule base gives ``dF(E, DE) = dF(-E, -DE)`` (to 1e-14), so the sign convention does not
    matter, only that ``DE`` is the change of the same signed ``E``. In 3-D the env observes
    an unsigned magnitude; the rules then see ``E >= 0``. On a machine with several contours
    the one with the largest ``|E|`` drives the member. ``DE`` is the change over one decision
    (``decision_ticks`` servo ticks), not 004's per-sample difference: ``de_gain =
    1 / decision_ticks`` approximates the latter. The table as extracted speeds up more where
    ``|E|`` grows (E, DE of one sign: PB) than where it shrinks (PS); ``e_gain = -1`` reads
    its E columns in the opposite order (PB..NB, as its DE rows are listed), which swaps
    the two.

    **The unit of dF** (004 gives ``g_dF = 0.35`` without one), ``unit``:

    * ``"mm_per_s_per_tick"`` (default): mm/s per servo sample, 004's feedrate unit and its
      sampling period (the controller runs at every sampling time, 004 section III); the
      override moves ``0.35 dF mm/s x decision_ticks / F_nom`` per decision (on the 1 ms rig at
      53 mm/s, ``0.066 dF``), i.e. up to 0.35 m/s^2, next to the 0.25 m/s^2 at which the
      rig's acc/dec time constant (0.212 s) ramps 53 mm/s;
    * ``"mm_per_s_per_decision"``: mm/s per decision (ten times slower);
    * ``"nominal_per_decision"`` / ``"nominal_per_tick"``: fractions of ``F_nom`` per
      decision / per tick (0.35 and 3.5 override per decision at ``|dF| = 1``, far beyond
      the env's ``max_feedrate_change``: bang-bang).

    The default is 004's own units (its errors are in mm, its controller runs at every
    sampling time) and the one reading in which ``g_dF`` acts: the ``F_nom`` readings ask
    3.5 to 35 times the env's default ``max_feedrate_change`` at ``|dF| = 1``, so the action
    saturates and the env's rate limit, not 004's gain, sets the speed changes; per decision
    ties the gain to the env's ``decision_ticks``, which 004 does not have.
    ``benchmarks/feedrate_baselines.py --table fuzzy --fuzzy-units`` measures the readings on
    the feedrate ids.
    The mm/s readings use the env's nominal feedrate (a G-code part's highest cutting F word)
    for ``F_nom``; on a block programmed slower than that the change in mm/s is smaller in
    proportion.

    The policy keeps no state between decisions (``E``, ``DE`` and the override are in the
    observation), so :meth:`predict` passes ``state`` through and a batch's actions equal the
    members' own, bit for bit.

    Args:
        gain: 004's output gain ``g_dF`` (default :data:`agents.fuzzy.FEEDRATE_GAIN_004`,
            0.35), > 0.
        e_gain: Multiplies the observed ``contour_error`` (in tolerances) to give ``E``;
            finite and non-zero. Default 1 (004's ``g_e = 1 / tol``).
        de_gain: Multiplies the observed ``contour_error_change`` (in tolerances per
            decision) to give ``DE``; finite and non-zero. Default 1.
        unit: The reading of dF's unit, a key of :data:`DF_UNITS`.

    Raises:
        ValueError: for a gain <= 0, a zero or non-finite input gain or an unknown unit,
            naming the value.
    """

    name = "fuzzy_feedrate"
    tasks = (FEEDRATE,)

    def __init__(
        self,
        gain: float = FEEDRATE_GAIN_004,
        e_gain: float = 1.0,
        de_gain: float = 1.0,
        unit: str = DEFAULT_DF_UNIT,
    ) -> None:
        self.gain = positive(gain, "gain")
        self.e_gain, self.de_gain = finite(e_gain, "e_gain"), finite(de_gain, "de_gain")
        for label, value in (("e_gain", self.e_gain), ("de_gain", self.de_gain)):
            if value == 0.0:
                raise ValueError(f"{label} must be non-zero, got {value!r}")
        self.unit = choice(unit, "unit", DF_UNITS)
        self._scale: float | None = None  # action per unit of dF, set at reset(env)
        self._surface: CompiledMamdani | None = None

    def reset(self, env: Any = None) -> None:
        """Read the env's ``max_feedrate_change``, feedrate and decision time; compile dF.

        Raises:
            ValueError: for anything but a contour_gym feedrate env (single or vector).
        """
        task = feedrate_task(env, "fuzzy_feedrate")
        config = task.config
        per_unit = DF_UNITS[self.unit](task.loop.nominal_feedrate, config.decision_ticks)
        self._scale = self.gain * per_unit / config.max_feedrate_change
        if self._surface is None:  # a two-input Mamdani system: it has a surface
            self._surface = cast(CompiledMamdani, fuzzy_feedrate_004().compiled)

    def act(self, obs: Observation) -> Actions:
        """The override changes ``(B, 1)`` of a batch (see the class docstring).

        Raises:
            ValueError: before :meth:`reset`, or for an observation that is not a batched
                feedrate-env observation.
        """
        _require_feedrate_obs(obs, "fuzzy_feedrate")
        b = batch_size(obs)
        if self._scale is None or self._surface is None:
            raise ValueError("fuzzy_feedrate reads its env's settings at reset(env): call it first")
        e = np.asarray(obs["contour_error"], dtype=np.float64)
        de = np.asarray(obs["contour_error_change"], dtype=np.float64)
        if e.shape[1] > 1:  # several contours: the largest |E| drives the member
            worst = np.argmax(np.abs(e), axis=1)
            rows = np.arange(b)
            e, de = e[rows, worst][:, None], de[rows, worst][:, None]
        x = np.empty((b, 2))
        x[:, 0] = np.clip(self.e_gain * e[:, 0], -1.0, 1.0)
        x[:, 1] = np.clip(self.de_gain * de[:, 0], -1.0, 1.0)
        d_f = self._surface.lookup(x)
        return np.clip(self._scale * d_f, -1.0, 1.0)


class ConstantFeedrate(ConstantPolicy):
    """A feed override held for the whole episode (``constant_feedrate``), 004's baseline.

    The env is built with ``feedrate_override=override`` (:attr:`env_kwargs`) and the policy
    acts 0 (:class:`~agents.policies.ConstantPolicy` with action 0), so every cutting move runs
    at ``override`` times its programmed feed (capped at the machine's ``max_feedrate``).

    Args:
        override: The feed override, > 0 (default 1: the programmed feedrate). It must lie
            within the env's ``feedrate_range`` (checked at :meth:`reset`), which the env
            clips the override to after the first step.
        feedrate_range: The env's ``feedrate_range`` to build it with (None: the env's own,
            (0.2, 2) by default), e.g. ``(0.05, 2.0)`` for an override below 0.2, as a general
            agent trained with that floor runs.

    Raises:
        ValueError: for an override <= 0 or non-finite, or a ``feedrate_range`` that does not
            hold it, naming them.
    """

    name = "constant_feedrate"
    tasks = (FEEDRATE,)

    def __init__(self, override: float = 1.0,
                 feedrate_range: tuple[float, float] | None = None) -> None:
        super().__init__(0.0)
        self.override = positive(override, "override")
        self.feedrate_range: tuple[float, float] | None = None
        if feedrate_range is not None:
            lo, hi = (float(v) for v in as_finite_array(feedrate_range, "feedrate_range",
                                                        shape=(2,)))
            if not lo <= self.override <= hi:
                raise ValueError(f"override {override!r} is outside feedrate_range "
                                 f"{tuple(feedrate_range)!r}")
            self.feedrate_range = (lo, hi)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """``feedrate_override=override`` (and ``feedrate_range`` when given)."""
        out: dict[str, Any] = {"feedrate_override": self.override}
        if self.feedrate_range is not None:
            out["feedrate_range"] = self.feedrate_range
        return out

    def reset(self, env: Any = None) -> None:
        """Check that ``env`` is a feedrate env whose ``feedrate_range`` holds the override.

        Raises:
            ValueError: for another env, or an override outside the env's range.
        """
        if env is None:
            return
        lo, hi = feedrate_task(env, "constant_feedrate").config.feedrate_range
        if not lo <= self.override <= hi:
            raise ValueError(f"override {self.override!r} is outside the env's feedrate_range "
                             f"({lo!r}, {hi!r}), which the env clips it to")

    def act(self, obs: Observation) -> Actions:
        """Zeros ``(B, 1)``: hold the override (feedrate env only)."""
        _require_feedrate_obs(obs, "constant_feedrate")
        return super().act(obs)


class CurvatureFeedLimit(ConstantPolicy):
    """A CNC's centripetal acceleration limit on the feed (``curvature_feed_limit``).

    The env is built with ``feedrate_limit=(accel, reach, end_speed, end_reach)`` and
    ``feedrate_target=(floor, cap, 2)`` (:attr:`env_kwargs`; the feedrate env's docstring) and
    the policy acts 0: the override follows ``sqrt(accel / kappa) / F`` within [``floor``,
    ``cap``], kappa the tightest curvature within ``reach`` ahead and F the block's programmed
    feed, and keeps the speed to ``end_speed`` within ``end_reach`` of the path's end, moving
    toward it by at most ``max_feedrate_change`` a step. It is the zero action of a general
    feedrate agent trained on that env, and a reference beside it.

    The defaults are chosen, not published: on 64 validation paths of 004's machine (random
    seeds 1000000-1000063, nominal machine, never judged) ``accel`` 0.02, 0.035, 0.05 and
    0.1 m/s^2 at ``cap`` 0.6 kept 5 um on 60, 60, 59 (60 computed in the env) and 55 of them
    at median cycles of 6.40, 5.88, 5.40 and 4.61 s; at 0.02, ``cap`` 0.8 and 1 lost 9 and 12
    paths more on straight moves, where the axes' lag, not the curvature, sets the error. At
    0.05 two of the four paths lost broke at the path's end, where the axes stop; 20 mm/s within the
    last 10 mm kept both, 62 at 5.51 s (30 mm/s within 20 mm: 62 at 5.53 s); 5 mm/s within
    the last 5 mm kept one (Python rule, 60 at 5.70 s), the acc/dec filter still slowing when
    the end came on the other (docs/measurements.md, "the curvature limit it corrects").

    Args:
        accel: Centripetal acceleration a_c, m/s^2, > 0.
        reach: How far ahead the tightest curvature is sought, m, > 0.
        cap: The highest override it sets, within (floor, 2).
        floor: The lowest, > 0.
        end_speed: The speed kept near the path's end, m/s, > 0 (None: no end limit).
        end_reach: How far before the end it is kept, m, > 0.

    Raises:
        ValueError: naming a non-finite or out-of-range value.
    """

    name = "curvature_feed_limit"
    tasks = (FEEDRATE,)

    def __init__(self, accel: float = 0.05, reach: float = 0.005, cap: float = 0.6,
                 floor: float = 0.05, end_speed: float | None = 0.02,
                 end_reach: float = 0.01) -> None:
        super().__init__(0.0)
        self.accel, self.reach = positive(accel, "accel"), positive(reach, "reach")
        self.floor, self.cap = positive(floor, "floor"), finite(cap, "cap")
        if not self.floor < self.cap < 2.0:
            raise ValueError(f"cap must lie in (floor, 2) = ({floor!r}, 2), got {cap!r}")
        self.end = None if end_speed is None else (positive(end_speed, "end_speed"),
                                                   positive(end_reach, "end_reach"))

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """``feedrate_range``, ``feedrate_target`` and ``feedrate_limit`` as the class says."""
        return {"feedrate_range": (self.floor, 2.0),
                "feedrate_target": (self.floor, self.cap, 2.0),
                "feedrate_limit": (self.accel, self.reach, *(self.end or ()))}

    def act(self, obs: Observation) -> Actions:
        """Zeros ``(B, 1)``: follow the limit (feedrate env only)."""
        _require_feedrate_obs(obs, "curvature_feed_limit")
        return super().act(obs)


register_policy("fuzzy_feedrate", FuzzyFeedrate)
register_policy("curvature_feed_limit", CurvatureFeedLimit)
register_policy("constant_feedrate", ConstantFeedrate)
