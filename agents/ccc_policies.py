"""Reference policies of the CCC env: no CCC, the PID CCC, and paper 000's fuzzy PID CCC.

Each holds constant CCC gains, mapped to the env's action by its ``gains_to_action`` at
:meth:`~agents.policies.ConstantPolicy.reset` (they are :class:`ConstantPolicy` s):

- ``no_ccc``: every gain 0 (action -1: the axis controllers alone).
- ``pid_ccc``: the env's own PID CCC gains (``task.g0``: the env's ``ccc_gains``, else the
  preset's), the classic CCC (Koren 1980).
- ``fuzzy_pid_ccc``: paper 000's fuzzy PID CCC. Its :attr:`~FuzzyPIDCCC.env_kwargs` build
  the env with the compiled law ``fuzzy_pid`` (:mod:`agents.ccc_laws`) and the law's
  quantisation and proportional factors; the action holds the base gains ``Kp0, Ki0, Kd0``
  (default the env's PID CCC gains), and the law reschedules the gains from the contour
  error every servo tick inside the compiled loop, as 000 does (``decision_ticks`` only sets
  how often the constant action is re-sent).
- ``pso_fuzzy_pid_ccc_000``: the same with the factors paper 000's improved PSO finds on 000's
  own three paths, tuning protocol ``000`` of :mod:`agents.tune` (``contour-gym tune 000
  --seed 0``; shipped in ``agents/data/pso_fuzzy_pid_ccc_000.json``): 000's experiment.
- ``pso_fuzzy_pid_ccc``: the same law with a general factor set, tuned by the same improved
  PSO on random paths for parts it never saw (protocol ``000_general``: ``contour-gym tune
  000_general --seed 0``; ``agents/data/pso_fuzzy_pid_ccc.json``).

Their errors on the papers' paths, measured, are in the documentation (Measurements and design
notes: reference CCC policies).

Paper 003 (ACC2PID on the X-Y-Y gantry, ``contour_gym/CCC-XYYGantry-Circle-v0`` and
``-ThreeLeaf-v0``):

- ``acc2pid``: 003's hand-tuned 2PID axes plus its hand-set P compensators (the gantry
  preset's own settings: there it runs as ``pid_ccc``); ``no_ccc`` on those envs is 003's
  hand-tuned 2PID without compensators.
- ``iabc_acc2pid``: the 19 parameters of tuning protocol ``003`` (``contour-gym tune 003
  --seed 0``; ``agents/data/iabc_acc2pid.json``).

Their errors, measured with ``benchmarks/tune_003.py``, and 003's claims are in the
documentation (Measurements and design notes: ACC2PID).
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike

from agents.ccc_laws import (
    ADAPTIVE_FUZZY_PID,
    ADAPTIVE_FUZZY_PID_PARAMS,
    FUZZY_PID,
    FUZZY_PID_PARAMS,
)
from agents.policy_base import ConstantPolicy, register_policy
from contour_gym.envs.core import CCC
from contour_gym.params import Schema, choice
from contour_gym.presets import get_preset

_FACTORS = FUZZY_PID_PARAMS.names[3:]  # the law's parameters beyond kp, ki, kd


def law_params(schema: Schema, given: tuple[float | None, ...]) -> dict[str, float]:
    """The CCC law parameters given beyond kp, ki, kd (``given`` in schema order).

    None is not given: the env's machine makes it (:func:`contour_gym.api.machine_law_params`).

    Raises:
        ValueError: for a value the schema rejects (NaN, infinite, out of range), naming it.
    """
    names = schema.names[3:]
    return {name: schema.value(name, value)
            for name, value in zip(names, given, strict=True) if value is not None}


class HeldGains(ConstantPolicy):
    """Constant CCC gains; ``None`` takes the env's own PID CCC gains at :meth:`reset`.

    Args:
        gains: (kp, ki, kd) for every contour, or (C, 3); None: the env's ``task.g0`` (its
            ``ccc_gains`` argument, else the preset's), read at :meth:`reset`.

    Raises:
        ValueError: as :class:`ConstantPolicy` for bad gains.
    """

    name = "held_gains"
    tasks = (CCC,)

    def __init__(self, gains: ArrayLike | None = None) -> None:
        super().__init__(gains=(0.0, 0.0, 0.0) if gains is None else gains)
        self._env_gains = gains is None

    def reset(self, env: Any = None) -> None:
        """Read the env's gains (when none were given), then map them to its action.

        Raises:
            ValueError: without a contour_gym CCC env, or for gains beyond its range.
        """
        task = getattr(getattr(env, "unwrapped", None), "task", None)
        if self._env_gains and task is not None:
            self.gains = np.array(task.g0, dtype=np.float64)
        super().reset(env)


class NoCCC(ConstantPolicy):
    """No cross-coupled control (``no_ccc``): every CCC gain 0, i.e. action -1."""

    name = "no_ccc"
    tasks = (CCC,)

    def __init__(self) -> None:
        super().__init__(gains=(0.0, 0.0, 0.0))


class PIDCCC(HeldGains):
    """The classic PID CCC (``pid_ccc``): the env's own PID CCC gains, held."""

    name = "pid_ccc"

    def __init__(self) -> None:
        super().__init__(None)


class FuzzyPIDCCC(HeldGains):
    """Paper 000's fuzzy PID CCC (``fuzzy_pid_ccc``; the law is :mod:`agents.ccc_laws`).

    Args:
        k_e: Quantisation factor of the contour error, 1/m (None: the law's default).
        k_de: Quantisation factor of its rate, s/m (None: the law's default).
        k_pf: Proportional factor of dKp, units of kp (None: the law's default).
        k_if: Proportional factor of dKi, units of ki (None: the law's default).
        k_df: Proportional factor of dKd, units of kd (None: the law's default).
        base_gains: The base gains (Kp0, Ki0, Kd0), (3,) or (C, 3), which the action
            holds; None: the env's PID CCC gains.

    A factor not given is the law's default *for the env's machine* (the rule of
    :mod:`agents.ccc_laws` applied to its tolerance, encoder and PID CCC gains); a factor
    given is used as it is, in the env machine's units.

    Raises:
        ValueError: for a NaN, infinite or negative factor or bad base gains, naming it.
    """

    name = "fuzzy_pid_ccc"

    def __init__(
        self,
        k_e: float | None = None,
        k_de: float | None = None,
        k_pf: float | None = None,
        k_if: float | None = None,
        k_df: float | None = None,
        base_gains: ArrayLike | None = None,
    ) -> None:
        super().__init__(base_gains)
        self.factors = law_params(FUZZY_PID_PARAMS, (k_e, k_de, k_pf, k_if, k_df))

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """``ccc_law="fuzzy_pid"``; ``ccc_law_params``: the factors given (the machine's rest)."""
        return {"ccc_law": FUZZY_PID.name, "ccc_law_params": dict(self.factors)}


TUNED_000 = Path(__file__).parent / "data" / "pso_fuzzy_pid_ccc_000.json"
"""The shipped run of tuning protocol ``000`` (its best factors, the command, the history)."""
TUNED_GENERAL = Path(__file__).parent / "data" / "pso_fuzzy_pid_ccc.json"
"""The shipped run of tuning protocol ``000_general`` (the general factor set)."""


@functools.cache
def tuned_factors_000() -> dict[str, float]:
    """The five factors protocol ``000`` found (:data:`TUNED_000`; ``contour-gym tune 000``).

    Raises:
        ValueError: if the file lacks a factor.
    """
    return _shipped_params(TUNED_000, _FACTORS)


@functools.cache
def tuned_factors_general() -> dict[str, float]:
    """The five factors protocol ``000_general`` found (:data:`TUNED_GENERAL`).

    Raises:
        ValueError: if the file lacks a factor.
    """
    return _shipped_params(TUNED_GENERAL, _FACTORS)


def _shipped_params(file: Path, names: tuple[str, ...]) -> dict[str, float]:
    """The ``params`` of a shipped tuning run, in ``names`` order; ValueError if one lacks."""
    params = json.loads(file.read_text(encoding="utf-8"))["params"]
    missing = [name for name in names if name not in params]
    if missing:
        raise ValueError(f"{file} lacks parameter(s) {missing}")
    return {name: float(params[name]) for name in names}


class PSOFuzzyPIDCCC(FuzzyPIDCCC):
    """Paper 000's fuzzy PID CCC with a general improved-PSO factor set (``pso_fuzzy_pid_ccc``).

    The factors are the best of tuning protocol ``000_general`` (:mod:`agents.tune`: 000's
    improved PSO, 50 particles x 100 generations, on 28 random paths of 000's machine, four
    of each family: the worst path's max contour error relative to the untuned law's,
    chattering bounded), shipped in ``agents/data/pso_fuzzy_pid_ccc.json`` with the command
    that reproduces them, ``contour-gym tune 000_general --seed 0``: a factor set for parts it
    never saw. The search starts at the untuned law and finds nothing better on its worst
    path, so the factors are the untuned law's and the policy acts as :class:`FuzzyPIDCCC`
    does, bit for bit (the search without that start returned factors worse than the untuned
    law on 6 of the generalization suite's 20 unseen paths of 000's machine, by up to 1.9 %:
    the law's peak errors barely move with its factors off the paths they were tuned on). 000's own
    experiment, tuned on its three paths, is :class:`PSOFuzzyPIDCCC000`.

    Args:
        base_gains: The base gains (Kp0, Ki0, Kd0), (3,) or (C, 3); None: the env's PID CCC
            gains (those the factors were tuned with).

    Raises:
        ValueError: for bad base gains.
    """

    name = "pso_fuzzy_pid_ccc"
    shipped: ClassVar[Callable[[], dict[str, float]]] = staticmethod(tuned_factors_general)
    tuned_on: ClassVar[str] = "xy_dc_servo"  # the machine protocols 000 and 000_general tune on

    def __init__(self, base_gains: ArrayLike | None = None) -> None:
        super().__init__(**type(self).shipped(), base_gains=base_gains)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The fuzzy law's, with ``"machine"``: the factors carry from :attr:`tuned_on`."""
        kwargs = super().env_kwargs
        kwargs["ccc_law_params"]["machine"] = self.tuned_on
        return kwargs


class PSOFuzzyPIDCCC000(PSOFuzzyPIDCCC):
    """Paper 000's fuzzy PID CCC with its improved-PSO factors (``pso_fuzzy_pid_ccc_000``).

    The best of tuning protocol ``000`` (improved PSO, 000's eq. 15 averaged over its circle,
    "infinity" and trident on the rig; ``agents/data/pso_fuzzy_pid_ccc_000.json``,
    ``contour-gym tune 000 --seed 0``). Tuned on those paths, it loses to the untuned law on
    others (the generalization suite).
    """

    name = "pso_fuzzy_pid_ccc_000"
    shipped = staticmethod(tuned_factors_000)


register_policy("no_ccc", NoCCC)
register_policy("pid_ccc", PIDCCC)
register_policy("fuzzy_pid_ccc", FuzzyPIDCCC)


# ----------------------------------------------------------------------------------------
# paper 001: the adaptive fuzzy PID CCC
# ----------------------------------------------------------------------------------------

AXES_001 = ("smc_dob", "pid")  # axis controllers the policy builds the env with


class AdaptiveFuzzyPIDCCC(HeldGains):
    """Paper 001's adaptive fuzzy PID CCC (``adaptive_fuzzy_pid_ccc``; law ``adaptive_fuzzy_pid``).

    Its :attr:`env_kwargs` build the env with 001's axis control (``smc_dob``: sliding mode
    with disturbance observer; ``axes="pid"`` for the PID axes) and the compiled law
    ``adaptive_fuzzy_pid`` (:mod:`agents.ccc_laws`) with its parameters. The action holds
    the base gains (default the env's PID CCC gains); the law adapts the gain changes from
    the contour error every servo tick inside the compiled loop.

    Measured with :func:`agents.evaluate.run_policy` on ``CCC-PMLSM-Helix-v0`` (001's helix,
    ``smc_dob`` axes for every row; law defaults; seed 0, one episode), max / mean true
    contour error over the cut in um, mean against ``pid_ccc``, on the rig (default) and with
    ``ideal=True``; "pid_ccc + kd" is the PID CCC with ``kd = 6 kp0 ts = 18`` A s/m added
    (``adaptive_fuzzy_pid_ccc`` with zero rates and ``base_gains=(3000, 3e4, 18)``)::

        policy                 rig max  rig mean        ideal max  ideal mean
        no_ccc                   32.02     7.491 (-4 %)     16.74     3.869 (+16 %)
        pid_ccc                  33.67     7.832            14.28     3.335
        adaptive_fuzzy_pid_ccc   31.24     6.266 (-20 %)    10.40     2.398 (-28 %)
        pid_ccc + kd             25.37     5.800 (-26 %)    10.22     2.278 (-32 %)

    Seeds 0-4 averaged: -19.8 % (rig) and -27.9 % (ideal) for the adaptive law, -25.8 % and
    -31.6 % for the PID CCC with kd; on a user Lissajous path (30 x 15 x 5 mm, seeds 0-4)
    -20.8 % and -26.3 % against -25.2 % and -30.5 %. 001 reports -30.5 % mean contour error
    against its PID CCC (17.7 -> 12.3, unit not printed); the adapted law gets most of that
    ideal, but its gain is the derivative action it adds to a PID CCC without one: a fixed,
    retuned PID CCC with derivative does better (the law's docstring has the sweep).

    Args:
        k_e: Scaling of the error input, 1/m (None: the law's default, also below).
        k_de: Scaling of the de/dt input, s/m.
        gamma_p: Adaptation rate of theta_kp, kp / (s m^2).
        gamma_i: Adaptation rate of theta_ki, ki / (s^2 m^2).
        gamma_d: Adaptation rate of theta_kd, kd / m^2.
        dkp_max: Bound on the Kp change, units of kp.
        dki_max: Bound on the Ki change, units of ki.
        dkd_max: Bound on the Kd change, units of kd.
        axes: Axis controller: ``"smc_dob"`` (001's) or ``"pid"``.
        base_gains: The base gains (kp, ki, kd), (3,) or (C, 3), which the action holds;
            None: the env's PID CCC gains.

    Raises:
        ValueError: for a NaN, infinite or negative parameter, unknown ``axes`` or bad base
            gains, naming it.
    """

    name = "adaptive_fuzzy_pid_ccc"

    def __init__(
        self,
        k_e: float | None = None,
        k_de: float | None = None,
        gamma_p: float | None = None,
        gamma_i: float | None = None,
        gamma_d: float | None = None,
        dkp_max: float | None = None,
        dki_max: float | None = None,
        dkd_max: float | None = None,
        axes: str = "smc_dob",
        base_gains: ArrayLike | None = None,
    ) -> None:
        super().__init__(base_gains)
        self.axes = choice(axes, "axes", AXES_001)
        given = (k_e, k_de, gamma_p, gamma_i, gamma_d, dkp_max, dki_max, dkd_max)
        self.law_params = law_params(ADAPTIVE_FUZZY_PID_PARAMS, given)

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """``axis_controller``, ``ccc_law="adaptive_fuzzy_pid"`` and its ``ccc_law_params``."""
        return {
            "axis_controller": self.axes,
            "ccc_law": ADAPTIVE_FUZZY_PID.name,
            "ccc_law_params": dict(self.law_params),
        }


register_policy("adaptive_fuzzy_pid_ccc", AdaptiveFuzzyPIDCCC)
register_policy("pso_fuzzy_pid_ccc", PSOFuzzyPIDCCC)
register_policy("pso_fuzzy_pid_ccc_000", PSOFuzzyPIDCCC000)


# ----------------------------------------------------------------------------------------
# paper 003: ACC2PID, 2PID axes plus P contour compensators on the X-Y-Y gantry
# ----------------------------------------------------------------------------------------

TUNED_003 = Path(__file__).parent / "data" / "iabc_acc2pid.json"
"""The shipped run of tuning protocol ``003`` (its best 19 parameters, the command, the history)."""


def hand_tuned_003() -> dict[str, float]:
    """003's hand-tuned ACC2PID in SI, by :data:`agents.tune.ACC2PID_NAMES`.

    The 2PID gains of 003 section 6.3 as the ``xyy_gantry`` preset reads them (Kp per encoder
    count, ``Kp_y2 = 0.0007``) and the compensators ``K_c1x = 0.0895, K_c1y = 0.001, K_c2x =
    0.0488, K_c2y = 0.001`` read as V/mm.
    """
    from agents.tune import ACC2PID_NAMES, acc2pid_hand_tuned

    values = acc2pid_hand_tuned(get_preset("xyy_gantry"))
    return {name: float(v) for name, v in zip(ACC2PID_NAMES, values, strict=True)}


@functools.cache
def tuned_params_003() -> dict[str, float]:
    """The 19 parameters protocol ``003`` found (:data:`TUNED_003`; ``contour-gym tune 003``).

    Raises:
        ValueError: if the file lacks a parameter.
    """
    from agents.tune import ACC2PID_NAMES

    return _shipped_params(TUNED_003, ACC2PID_NAMES)


class ACC2PID(HeldGains):
    """Paper 003's cross-coupled 2PID (``acc2pid``), hand-tuned: 003's published numbers.

    For the X-Y-Y gantry envs (``contour_gym/CCC-XYYGantry-Circle-v0``, ``-ThreeLeaf-v0``).
    Its :attr:`env_kwargs` build the env with 003's 2PID on every axis (``axis_controller
    ="two_dof_pid"`` and ``controller_options`` ``kp, ti, td, alpha, beta`` per axis, SI) and
    the compensators as the CCC's per-axis weights (``ccc_weights`` ``[[K_c1x, K_c1y, 0],
    [K_c2x, K_c2y, 0]]``, V/m); the action holds the PID CCC gains ``(1, 0, 0)``, so each
    contour's CCC is 003's P compensator pair (eqs. 36-37). The hand-tuned point equals the
    preset's own settings, so on the gantry envs ``acc2pid`` runs as ``pid_ccc`` does, and
    003's hand-tuned 2PID without compensators is ``no_ccc`` there.

    Args:
        params: The 19 parameters by :data:`agents.tune.ACC2PID_NAMES` (SI; any left out
            keep their hand-tuned value).

    Raises:
        ValueError: for an unknown name or a value the 2PID rejects (``Kp, TI > 0``,
            ``TD >= 0``, finite).
    """

    name = "acc2pid"

    def __init__(self, params: dict[str, float] | None = None) -> None:
        from agents.tune import acc2pid_rows

        super().__init__((1.0, 0.0, 0.0))
        values = hand_tuned_003()
        unknown = sorted(set(params or {}) - set(values))
        if unknown:
            raise ValueError(f"unknown ACC2PID parameter(s) {unknown}; accepted: {list(values)}")
        values.update({k: float(v) for k, v in (params or {}).items()})
        acc2pid_rows(np.array([list(values.values())]))  # validates
        self.params = values

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """``axis_controller``, ``controller_options`` (SI, per axis) and ``ccc_weights``."""
        from agents.tune import ACC2PID_AXES

        p = self.params
        options = {q: [p[f"{q}_{a}"] for a in ACC2PID_AXES]
                   for q in ("kp", "ti", "td", "alpha", "beta")}
        weights = [[p["kc1x"], p["kc1y"], 0.0], [p["kc2x"], p["kc2y"], 0.0]]
        return {"axis_controller": "two_dof_pid", "controller_options": options,
                "ccc_weights": weights}


class IABCACC2PID(ACC2PID):
    """Paper 003's ACC2PID with its IABC-tuned parameters (``iabc_acc2pid``).

    The 19 parameters are the best of tuning protocol ``003`` (:mod:`agents.tune`: improved
    ABC, 20 employed bees x 200 cycles, 003's eq. 38 averaged over the gantry's dual circle
    and dual three-leaf on the rig), shipped in ``agents/data/iabc_acc2pid.json`` with the
    command that reproduces them, ``contour-gym tune 003 --seed 0``. 003 tunes online, on
    the machine; this is the offline equivalent on the identified model.
    """

    name = "iabc_acc2pid"

    def __init__(self) -> None:
        super().__init__(tuned_params_003())


register_policy("acc2pid", ACC2PID)
register_policy("iabc_acc2pid", IABCACC2PID)
