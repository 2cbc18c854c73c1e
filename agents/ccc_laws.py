"""Compiled CCC laws of the papers beyond the built-in PID: 000's fuzzy PID, 001's adaptive one.

Importing this module registers the laws with :func:`contour_gym.ccc.register_ccc_law`; the
servo loop then binds them into its specialised kernel like a built-in component (build an
env or a loop with ``ccc_law="fuzzy_pid"`` and ``ccc_law_params={...}``).

``fuzzy_pid`` (paper 000, "Variable gain fuzzy cross-coupled control strategy", its eq. (11),
lost in extraction but defined by the text around it: ``K = K0 + dK`` with
``dKp = k_pf dKpf`` etc.). Every servo tick, on the contour error ``e`` the CCC sees (the
estimator's) and its backward difference ``de = (e - e_prev) / ts`` (0 on the first tick:
the one :func:`contour_gym.servo.pid.pid_terms` differentiates)::

    dKpf, dKif, dKdf = F(clip(k_e e, -3, 3), clip(k_de de, -3, 3))
    Kp = max(kp + k_pf dKpf, 0),  Ki = max(ki + k_if dKif, 0),  Kd = max(kd + k_df dKdf, 0)
    U  = Kp e + Ki (I + e ts) + Kd de                     (I: the integral of e so far)

``F`` is the Mamdani system :func:`agents.fuzzy.fuzzy_pid_000` (7 triangles per variable on
[-3, 3], min/max, centroid; outputs in [-8/3, 8/3]). 000's rule tables 1-3 were lost in
extraction: its rules are Liu Jinkun's classic self-tuning fuzzy PID tables
(:data:`agents.fuzzy.PID_TABLES_000`), evaluated through the precomputed surface
(:func:`agents.fuzzy.surface_eval_flat`; within 2.4e-4 of the output range of the exact
inference). The clip of each gain at 0 is ours (000 does not say; a negative gain would
push the tool away from the path). The integral is the PID's (every tick, the axis
controllers handle saturation), multiplied by the scheduled ``Ki`` of this tick, as in
positional fuzzy PID.

Parameters (:data:`FUZZY_PID_PARAMS`): ``kp, ki, kd`` are 000's ``Kp0, Ki0, Kd0`` (what the
CCC env's action sets); ``k_e`` (1/m) and ``k_de`` (s/m) are 000's quantisation factors
``k_eps, k_deps``; ``k_pf, k_if, k_df`` its proportional factors, in the units of kp, ki, kd.
All must be finite and >= 0.

**Defaults.** 000's PSO-optimised values ``(k_eps, k_deps, k_pf, k_if, k_df) = (1, 1.2, 87,
8.5, 4)`` (section "Circular trajectory simulation") come without units, base gains or
sample time, for a Simulink model whose CCC output units are not given, so they do not
carry over: read in mm, ``k_e = 1 /mm`` puts 000's own 0.049 mm error at 0.049 of the
universe's 3, where the outputs hardly move. The defaults are chosen for 000's machine
(preset ``xy_dc_servo``, ``contour_gym/CCC-Circle-v0``) from its tolerance ``tol``
(7.6 um), its 1 um encoder and its PID CCC gains ``kp0, ki0`` (6.9e3 A/m, 20 kp0 per s),
and are computed from the preset at import:

- ``k_e = 3 / (8 tol) = 4.9e4`` 1/m: the error input reaches the universe's end at 8
  tolerances (61 um), above the machine's uncompensated peak (50.6 um), so it does not
  saturate on 000's circle even without compensation.
- ``k_de = 3 / (3 mm/s) = 1000`` s/m: one encoder count per tick (1 mm/s) moves the de
  input by 1 of 3, so quantisation noise alone does not saturate it.
- ``k_pf = kp0 / 8, k_if = ki0 / 16, k_df = 0``: the fuzzy terms move Kp by at most a
  third and Ki by at most a sixth of the base gains (the outputs reach 8/3); kd stays at
  the preset's 0 (``Kd = max(0 + k_df dKdf, 0)`` would be a derivative on one side only).

Chosen conservatively from a coarse sweep on 000's machine (circle, "infinity" and trident,
rig and ideal); the sweep and what it showed are in the documentation's "Measurements and
design notes", the resulting table in :mod:`agents.ccc_policies`.

**On every machine.** The rules above, not their numbers on 000's machine, are the law's
defaults: on another preset, a factor not given is made by the same rule from that machine's
tolerance, encoder count per tick and PID CCC gains (:func:`fuzzy_pid_units`: the law is
registered with ``home="xy_dc_servo"`` and these units; :meth:`contour_gym.ccc.CCCLaw.params_for`).
On 002's machine (``lugre_linear_motor``, pre-compensation: its gains are dimensionless, kp0 1)
000's numbers would move Kp by up to 2300 and the CCC diverged on every path; by the rule the
fuzzy terms move it by up to a third of kp0 there too. A factor set tuned on one machine
carries to another in the same units (``ccc_law_params={..., "machine": "xy_dc_servo"}``).

``adaptive_fuzzy_pid`` (paper 001, "Adaptive fuzzy PID cross coupled control for multi-axis
motion system based on sliding mode disturbance observation", section "Design of CCC based
on adaptive fuzzy PID"). What survived extraction: adaptive fuzzy systems approximate the
PID gains (eqs. 23-25), built from the contour error and its derivative (membership figure
and rule table 1 lost) with singleton fuzzifier, product inference and centre-average
defuzzifier, so each gain is ``theta^T xi(x)``; "for the adaptive controllers (23-25), the
adaptive weights" follow update laws whose equations (after eq. 25, presumably 26-28) and
rates were lost. Reconstructed here in the standard form, Wang's direct adaptive fuzzy
law ``theta' = gamma e xi`` with each gain's regressor ``dU/dK`` (the MIT gradient rule on
``e^2 / 2`` for a plant of positive gain, which a CCC is: a positive gain pushes the tool
back onto the path)::

    xi = basis(k_e e, k_de de)                                 (25 rules, sums to 1)
    Kp = max(kp + theta_p . xi, 0),  Ki = max(ki + theta_i . xi, 0),  Kd = max(kd + theta_d . xi, 0)
    U  = Kp e + Ki (I + e ts) + Kd de                          (the PID's terms, as fuzzy_pid)
    theta_p' = gamma_p e e xi,   theta_i' = gamma_i e (I + e ts) xi,   theta_d' = gamma_d e de xi

``e`` is the error the CCC sees (in 3-D each signed component, its own state row), ``de``
its backward difference (0 on the first tick), ``I`` its integral so far. ``basis`` is
:func:`agents.fuzzy.adaptive_fuzzy_001` with 5 Gaussian sets per input on [-3, 3] (001's
sets were lost: chosen there), evaluated by :func:`agents.fuzzy.product_basis_into` on the
sampled sets the law's data table holds. Its consequents are all ``ZO`` (``initial_theta``
is 0), so theta starts at 0 with the rest of the state and the gains start at the base gains:
001's PID CCC, which the adaptation then moves.

**Discretisation** (ours), every servo tick ``ts``: the output uses theta(k); the commit
takes one forward Euler step with the tick's ``e``, regressor and basis (the ones the output
used, kept in the state row's scratch columns), then projects::

    theta_j(k+1) = clip(theta_j(k) + ts gamma_j e(k) phi_j(k) xi(k), -dk_max_j, dk_max_j)

with ``phi = (e, I + e ts, de)``, then the PID state (integral, previous error) as ``pid``.

**Projection** (ours: 001 gives no bound, and a controller must not adapt gains without
one): every weight of gain ``j`` is kept in the box ``[-dkj_max, dkj_max]`` (the Euclidean
projection onto it, the standard parameter projection); the basis is a convex combination,
so ``|K_j - K0_j| <= dkj_max``. Without it the gains run away: ``theta_p' = gamma_p e^2 xi
>= 0`` only grows, and the sampled ``e de = (e^2 - e_prev^2) / (2 ts) + (e - e_prev)^2 /
(2 ts)`` has a non-negative part that encoder quantisation alone feeds, so ``theta_d``
drifts up as well. The bound is what keeps the loop stable (the documentation's
"Measurements and design notes": a larger Kd bound diverged on the rig).

Parameters (:data:`ADAPTIVE_FUZZY_PID_PARAMS`, all finite and >= 0): ``kp, ki, kd`` the base
gains (the CCC env's action); ``k_e`` (1/m), ``k_de`` (s/m) the input scalings;
``gamma_p`` (kp / (s m^2)), ``gamma_i`` (ki / (s^2 m^2)), ``gamma_d`` (kd / m^2) the
adaptation rates; ``dkp_max, dki_max, dkd_max`` the projection bounds, in the units of kp,
ki, kd. State per error row (:data:`ADAPTIVE_STATE`): the PID's ``integral, e_prev,
started``, the tick's scratch ``x_e, x_de, mu_<input>_<set>, xi_<rule>, dkp, dki, dkd``, then
``theta_<gain>_<rule>`` (rule ``<set of e>_<set of de>``, e.g. ``theta_kd_PS_NB``).

**Defaults**, computed from 001's preset (``xyz_pmlsm``: tolerance ``tol`` 2.9 um, PID CCC
gains ``kp0 = 3000`` A/m, ``ki0 = 10 kp0`` per s, ``kd0 = 0``, ts 1 ms) at import:

- ``k_e = 3 / (32 tol) = 3.2e4`` 1/m: the error input reaches the universe's end at 92 um,
  above the rig's peaks.
- ``k_de = 3 / (3 mm/s) = 1000`` s/m, as fuzzy_pid's (one encoder count per tick is 1 of 3).
- bounds ``dkp_max = kp0 / 4``, ``dki_max = ki0 / 2``, ``dkd_max = 6 kp0 ts = 18`` A s/m.
- rates from adaptation times ``T = (10, 1, 0.03)`` s, the time a regressor at its reference
  value takes to move a weight by its bound: ``gamma_p = dkp_max / (T_p tol^2)``,
  ``gamma_i = dki_max / (T_i tol I_ref)``, ``gamma_d = dkd_max / (T_d tol de_ref)`` with
  ``I_ref = tol kp0 / ki0`` (the PI corner) and ``de_ref = 1`` mm/s.

Chosen by a sweep on 001's machine (``CCC-PMLSM-Helix-v0`` on ``smc_dob`` axes, rig and ideal):
the gain comes from the derivative. The sweep, its figures and the comparison with a fixed
PID CCC are in the documentation's "Measurements and design notes"; the resulting table in
:class:`agents.ccc_policies.AdaptiveFuzzyPIDCCC`. On another machine a parameter not given is
made by the same rule from that machine's tolerance, encoder and PID CCC gains
(:func:`adaptive_fuzzy_pid_units`; ``home="xyz_pmlsm"``), as ``fuzzy_pid``'s are.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

from agents.fuzzy import (
    CompiledMamdani,
    CompiledProduct,
    adaptive_fuzzy_001,
    fuzzy_pid_000,
    product_basis_into,
    product_output_into,
    surface_eval_flat,
    surface_table,
)
from contour_gym.ccc import PID_PARAMS, CCCLaw, pid_commit, register_ccc_law, release_integral
from contour_gym.params import Param, Schema, non_negative, state_schema
from contour_gym.presets import Preset, get_preset
from contour_gym.servo.pid import STATE as PID_STATE
from contour_gym.servo.pid import pid_terms

# defaults on 000's machine (module docstring): its tolerance and PID CCC gains
_MACHINE_000 = get_preset("xy_dc_servo")
UNIVERSE = 3.0  # the inputs' and outputs' universes are [-3, 3] (fuzzy_pid_000)
E_SATURATES = 8.0  # k_e: the error input saturates at this many tolerances
DE_SATURATES = 3e-3  # k_de: the de/dt input saturates here, m/s (3 encoder counts per tick)
K_E_000 = UNIVERSE / (E_SATURATES * _MACHINE_000.tolerance)
K_DE_000 = UNIVERSE / DE_SATURATES
K_PF_000 = _MACHINE_000.ccc_gains.kp / 8.0
K_IF_000 = _MACHINE_000.ccc_gains.ki / 16.0
K_DF_000 = 0.0

FUZZY_PID_PARAMS = Schema(
    "ccc fuzzy_pid",
    kp=Param(0.0, non_negative, "base proportional gain Kp0 per m of contour error"),
    ki=Param(0.0, non_negative, "base integral gain Ki0 per m s"),
    kd=Param(0.0, non_negative, "base derivative gain Kd0, s per m"),
    k_e=Param(K_E_000, non_negative, "quantisation factor of the error input, 1/m"),
    k_de=Param(K_DE_000, non_negative, "quantisation factor of the de/dt input, s/m"),
    k_pf=Param(K_PF_000, non_negative, "proportional factor of dKp (units of kp)"),
    k_if=Param(K_IF_000, non_negative, "proportional factor of dKi (units of ki)"),
    k_df=Param(K_DF_000, non_negative, "proportional factor of dKd (units of kd)"),
)
_C, _S = FUZZY_PID_PARAMS.col, PID_STATE.col


@numba.njit(cache=True, inline="always")
def error_rate(s, row, e, ts):
    """``de/dt`` of the contour error as the PID differentiates it (0 on the first tick).

    Args:
        s (numpy.ndarray): (rows, n) state rows starting with the PID state
            (:data:`PID_STATE`).
        row (int): State row.
        e (float): Contour error of this tick, m.
        ts (float): Sample time, s.
    """
    return (e - s[row, _S.e_prev]) / ts if s[row, _S.started] > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def fuzzy_pid_gains(p, s, data, q, row, e, ts):
    """``(Kp, Ki, Kd)`` of this tick: the base gains plus the scaled fuzzy outputs, >= 0.

    Args:
        p (numpy.ndarray): (rows, FUZZY_PID_PARAMS.size) parameter rows.
        s (numpy.ndarray): (rows, PID state size) state rows.
        data (numpy.ndarray): The flattened fuzzy_pid_000 surface
            (:func:`agents.fuzzy.surface_table`).
        q (int): Parameter row.
        row (int): State row.
        e (float): Contour error, m.
        ts (float): Sample time, s.
    """
    de = error_rate(s, row, e, ts)
    x0, x1 = p[q, _C.k_e] * e, p[q, _C.k_de] * de
    kp = max(p[q, _C.kp] + p[q, _C.k_pf] * surface_eval_flat(data, 0, x0, x1), 0.0)
    ki = max(p[q, _C.ki] + p[q, _C.k_if] * surface_eval_flat(data, 1, x0, x1), 0.0)
    kd = max(p[q, _C.kd] + p[q, _C.k_df] * surface_eval_flat(data, 2, x0, x1), 0.0)
    return kp, ki, kd


@numba.njit(cache=True, inline="always")
def fuzzy_pid_output(p, s, data, q, row, e, ts):
    """PID on the contour error with the fuzzy-scheduled gains (module docstring)."""
    kp, ki, kd = fuzzy_pid_gains(p, s, data, q, row, e, ts)
    return pid_terms(kp, ki, kd, s, row, e, ts)


@functools.cache
def fuzzy_pid_table() -> np.ndarray:
    """The law's constant data: the fuzzy_pid_000 surface as one float64 vector (cached)."""
    compiled = fuzzy_pid_000().compiled
    assert isinstance(compiled, CompiledMamdani) and compiled.surface is not None
    table = surface_table(compiled.surface)
    table.setflags(write=False)
    return table


def fuzzy_pid_units(machine: Preset) -> dict[str, float]:
    """The units the fuzzy PID's factors scale with on a machine (module docstring).

    ``k_e`` in 1 / tolerance, ``k_de`` in ticks per encoder count (the finest axis's), ``k_pf``
    and ``k_if`` in the PID CCC gains kp0 and ki0, ``k_df`` in kp0 times one tick.

    Raises:
        ValueError: for a machine without an encoder on any axis.
    """
    stage, gains = machine.stage, machine.ccc_gains
    counts = [a.encoder_resolution for a in stage.axes if a.encoder_resolution > 0.0]
    if not counts:
        raise ValueError(f"fuzzy_pid: machine {machine.name!r} has no encoder to scale k_de by")
    return {"k_e": 1.0 / machine.tolerance, "k_de": stage.ts / min(counts),
            "k_pf": gains.kp, "k_if": gains.ki, "k_df": gains.kp * stage.ts}


FUZZY_PID = register_ccc_law(
    CCCLaw(
        "fuzzy_pid", FUZZY_PID_PARAMS, PID_STATE, fuzzy_pid_output, pid_commit,
        data=fuzzy_pid_table,
        doc="fuzzy PID on the contour error, gains K0 + k_f dK(k_e e, k_de de) (paper 000)",
        inline=False,  # called: the kernel compiles faster, protocol 000 runs as fast
        home=_MACHINE_000.name, units=fuzzy_pid_units, release=release_integral,
    )
)


# ----------------------------------------------------------------------------------------
# paper 001: adaptive fuzzy PID
# ----------------------------------------------------------------------------------------

# defaults on 001's machine (module docstring): its tolerance and PID CCC gains
_MACHINE_001 = get_preset("xyz_pmlsm")
_G0_001 = _MACHINE_001.ccc_gains
N_SETS_001 = 5  # Gaussian sets per input (agents.fuzzy.adaptive_fuzzy_001): L = 25 rules
E_SATURATES_001 = 32.0  # k_e: the error input saturates at this many tolerances
DE_SATURATES_001 = 3e-3  # k_de: the de/dt input saturates here, m/s (3 encoder counts per tick)
KD_UNIT_001 = _G0_001.kp * _MACHINE_001.stage.ts  # a derivative gain of kp0 times one tick
DK_MAX_001 = (0.25, 0.5, 6.0)  # projection bounds in units of kp0, ki0 and KD_UNIT_001
T_ADAPT_001 = (10.0, 1.0, 0.03)  # s: a regressor at its reference moves a weight by its bound
E_REF_001 = _MACHINE_001.tolerance  # reference error, m
I_REF_001 = E_REF_001 * _G0_001.kp / _G0_001.ki  # reference integral: tol over the PI corner, m s
DE_REF_001 = DE_SATURATES_001 / UNIVERSE  # reference de/dt: one count per tick, m/s
K_E_001 = UNIVERSE / (E_SATURATES_001 * _MACHINE_001.tolerance)
K_DE_001 = UNIVERSE / DE_SATURATES_001
DKP_MAX_001 = DK_MAX_001[0] * _G0_001.kp
DKI_MAX_001 = DK_MAX_001[1] * _G0_001.ki
DKD_MAX_001 = DK_MAX_001[2] * KD_UNIT_001
GAMMA_P_001 = DKP_MAX_001 / (T_ADAPT_001[0] * E_REF_001 * E_REF_001)
GAMMA_I_001 = DKI_MAX_001 / (T_ADAPT_001[1] * E_REF_001 * I_REF_001)
GAMMA_D_001 = DKD_MAX_001 / (T_ADAPT_001[2] * E_REF_001 * DE_REF_001)

ADAPTIVE_FUZZY_PID_PARAMS = Schema(
    "ccc adaptive_fuzzy_pid",
    **PID_PARAMS.params,  # the base gains kp, ki, kd: the pid law's
    k_e=Param(K_E_001, non_negative, "scaling of the error input, 1/m"),
    k_de=Param(K_DE_001, non_negative, "scaling of the de/dt input, s/m"),
    gamma_p=Param(GAMMA_P_001, non_negative, "adaptation rate of theta_kp, kp / (s m^2)"),
    gamma_i=Param(GAMMA_I_001, non_negative, "adaptation rate of theta_ki, ki / (s^2 m^2)"),
    gamma_d=Param(GAMMA_D_001, non_negative, "adaptation rate of theta_kd, kd / m^2"),
    dkp_max=Param(DKP_MAX_001, non_negative, "bound on |theta_kp|, i.e. on the Kp change"),
    dki_max=Param(DKI_MAX_001, non_negative, "bound on |theta_ki|, i.e. on the Ki change"),
    dkd_max=Param(DKD_MAX_001, non_negative, "bound on |theta_kd|, i.e. on the Kd change"),
)
ADAPTED = ("kp", "ki", "kd")  # the adapted gains, in the order of the theta blocks
_SYSTEM_001 = adaptive_fuzzy_001(N_SETS_001)
_RULES_001 = tuple("_".join(rule.when) for rule in _SYSTEM_001.rules)
_INPUTS_001 = tuple(v.name for v in _SYSTEM_001.inputs)


def adaptive_state_schema() -> Schema:
    """The law's state per error row: the PID's, the tick's scratch, then theta (3 x L).

    The scratch (the tick's inputs, memberships, basis and gain changes) is written by the
    output and read by the commit, so the adaptation uses the basis the gains used.

    Columns: ``integral, e_prev, started`` (the PID's), ``x_e, x_de`` (the scaled inputs),
    ``mu_<input>_<set>`` (memberships), ``xi_<set e>_<set de>`` (the basis, one per rule),
    ``dkp, dki, dkd`` (``theta^T xi``), ``theta_<gain>_<set e>_<set de>`` (the adapted
    weights, gain-major).
    """
    sets = _SYSTEM_001.inputs[0].set_names
    columns = (
        *PID_STATE.names,
        *(f"x_{v}" for v in _INPUTS_001),
        *(f"mu_{v}_{name}" for v in _INPUTS_001 for name in sets),
        *(f"xi_{rule}" for rule in _RULES_001),
        *(f"d{g}" for g in ADAPTED),
        *(f"theta_{g}_{rule}" for g in ADAPTED for rule in _RULES_001),
    )
    return state_schema("ccc adaptive_fuzzy_pid state", *columns)


ADAPTIVE_STATE = adaptive_state_schema()
_A, _P = ADAPTIVE_STATE.col, ADAPTIVE_FUZZY_PID_PARAMS.col
N_IN_001, N_RULES_001 = len(_INPUTS_001), len(_RULES_001)
_X0, _MU0, _XI0 = _A.x_e, _A.mu_e_NB, _A.xi_NB_NB
_DK0, _TH0 = _A.dkp, _A.theta_kp_NB_NB
assert ADAPTIVE_STATE.names[: PID_STATE.size] == PID_STATE.names
assert _TH0 + len(ADAPTED) * N_RULES_001 == ADAPTIVE_STATE.size


@functools.cache
def adaptive_fuzzy_pid_table() -> np.ndarray:
    """The law's constant data: 001's basis as one float64 vector (cached, read-only).

    Header ``n_in, S, N, L``, then the input universes ``meta`` (n_in, 5), the sampled sets
    ``mf`` (n_in, S, N) and the rules' antecedent set indices ``ant`` (L, n_in, as whole
    floats), each in C order: the arrays :func:`agents.fuzzy.product_basis_into` reads
    (:class:`agents.fuzzy.SampledVariables`), views of which :func:`basis_views` returns.
    """
    compiled = _SYSTEM_001.compiled
    assert isinstance(compiled, CompiledProduct)
    mf, meta, ant = compiled.inputs.mf, compiled.inputs.meta, compiled.ant
    head = np.array([mf.shape[0], mf.shape[1], mf.shape[2], ant.shape[0]], dtype=np.float64)
    parts = (head, meta, mf, ant)
    table = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in parts])
    table.setflags(write=False)
    return table


BASIS_HEADER = 4


@numba.njit(cache=True, inline="always")
def basis_views(data):
    """``mf, meta, ant`` of an :func:`adaptive_fuzzy_pid_table` vector, as views (no copy)."""
    n_in, n_s, n_p, n_r = int(data[0]), int(data[1]), int(data[2]), int(data[3])
    a = BASIS_HEADER
    meta = data[a : a + 5 * n_in].reshape((n_in, 5))
    a += 5 * n_in
    mf = data[a : a + n_in * n_s * n_p].reshape((n_in, n_s, n_p))
    a += n_in * n_s * n_p
    ant = data[a : a + n_r * n_in].reshape((n_r, n_in))
    return mf, meta, ant


@numba.njit(cache=True, inline="always")
def adaptive_fuzzy_pid_gains(p, s, data, q, row, e, ts):
    """``(Kp, Ki, Kd)`` of this tick: base gains plus ``theta^T xi(k_e e, k_de de)``, >= 0.

    Writes the tick's inputs, memberships, basis and gain changes into the state row's
    scratch columns (:func:`adaptive_state_schema`), which the commit reads.

    Args:
        p (numpy.ndarray): (rows, ADAPTIVE_FUZZY_PID_PARAMS.size) parameter rows.
        s (numpy.ndarray): (rows, ADAPTIVE_STATE.size) state rows.
        data (numpy.ndarray): :func:`adaptive_fuzzy_pid_table`.
        q (int): Parameter row.
        row (int): State row.
        e (float): Contour error, m.
        ts (float): Sample time, s.
    """
    s[row, _A.x_e] = p[q, _P.k_e] * e
    s[row, _A.x_de] = p[q, _P.k_de] * error_rate(s, row, e, ts)
    mf, meta, ant = basis_views(data)
    mu = s[row, _MU0 : _MU0 + mf.shape[0] * mf.shape[1]].reshape((mf.shape[0], mf.shape[1]))
    xi = s[row, _XI0 : _XI0 + N_RULES_001]
    product_basis_into(mf, meta, ant, s[row, _X0 : _X0 + N_IN_001], mu, xi)
    theta = s[row, _TH0 : _TH0 + 3 * N_RULES_001].reshape((3, N_RULES_001))
    dk = s[row, _DK0 : _DK0 + 3]
    product_output_into(theta, xi, dk)
    kp = max(p[q, _P.kp] + dk[0], 0.0)
    ki = max(p[q, _P.ki] + dk[1], 0.0)
    kd = max(p[q, _P.kd] + dk[2], 0.0)
    return kp, ki, kd


@numba.njit(cache=True, inline="always")
def adaptive_fuzzy_pid_output(p, s, data, q, row, e, ts):
    """PID on the contour error with the adapted gains (module docstring)."""
    kp, ki, kd = adaptive_fuzzy_pid_gains(p, s, data, q, row, e, ts)
    return pid_terms(kp, ki, kd, s, row, e, ts)


@numba.njit(cache=True, inline="always")
def _adapt(s, row, first, rate, bound):
    # theta <- clip(theta + rate xi, -bound, bound) for one gain's L weights
    for rule in range(N_RULES_001):
        theta = s[row, first + rule] + rate * s[row, _XI0 + rule]
        s[row, first + rule] = min(max(theta, -bound), bound)


@numba.njit(cache=True, inline="always")
def adaptive_fuzzy_pid_commit(p, s, data, q, row, e, ts, out, saturated):
    """Adapt theta (projected Euler step of 001's law, module docstring), then the PID state."""
    de = error_rate(s, row, e, ts)
    integral = s[row, _S.integral] + e * ts
    _adapt(s, row, _TH0, ts * p[q, _P.gamma_p] * e * e, p[q, _P.dkp_max])
    _adapt(s, row, _TH0 + N_RULES_001, ts * p[q, _P.gamma_i] * e * integral, p[q, _P.dki_max])
    _adapt(s, row, _TH0 + 2 * N_RULES_001, ts * p[q, _P.gamma_d] * e * de, p[q, _P.dkd_max])
    pid_commit(p, s, data, q, row, e, ts, out, saturated)


def adaptive_fuzzy_pid_units(machine: Preset) -> dict[str, float]:
    """The units the adaptive law's parameters scale with on a machine (module docstring).

    Those of the defaults' rule: ``k_e``, ``k_de`` as :func:`fuzzy_pid_units`; the bounds in
    kp0, ki0 and kp0 times one tick; each rate in its bound over the error reference (the
    tolerance) times its regressor's reference (the tolerance, the integral reference
    ``tol kp0 / ki0``, one encoder count per tick).

    Raises:
        ValueError: for a machine without an encoder on any axis.
    """
    units = fuzzy_pid_units(machine)
    kp0, ki0, tol = machine.ccc_gains.kp, machine.ccc_gains.ki, machine.tolerance
    kd_unit, de_ref = units["k_df"], 1.0 / units["k_de"]  # kp0 ts; one count per tick
    # gamma_i: ki0 over tol times the integral reference tol kp0 / ki0 (inf without kp0)
    gamma_i = ki0 * ki0 / (kp0 * tol * tol) if kp0 > 0.0 else math.inf * ki0
    return {"k_e": units["k_e"], "k_de": units["k_de"],
            "gamma_p": kp0 / (tol * tol), "gamma_i": gamma_i,
            "gamma_d": kd_unit / (tol * de_ref),
            "dkp_max": kp0, "dki_max": ki0, "dkd_max": kd_unit}


ADAPTIVE_FUZZY_PID = register_ccc_law(
    CCCLaw(
        "adaptive_fuzzy_pid", ADAPTIVE_FUZZY_PID_PARAMS, ADAPTIVE_STATE,
        adaptive_fuzzy_pid_output, adaptive_fuzzy_pid_commit, data=adaptive_fuzzy_pid_table,
        doc="adaptive fuzzy PID on the contour error, gains K0 + theta^T xi(k_e e, k_de de), "
        "theta adapted by the error (paper 001)",
        inline=False,  # called, not inlined (as fuzzy_pid)
        home=_MACHINE_001.name, units=adaptive_fuzzy_pid_units, release=release_integral,
    )
)
