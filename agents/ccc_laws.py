"""Compiled CCC laws of the papers beyond the built-in PID: paper 000's fuzzy PID.

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
rig and ideal): the classic tables raise Ki whenever e > 0 and lower it when e < 0, so a
larger ``k_if`` (Ki up to several times ki0) cuts the circle's transients by a third but
more than doubles the peak on the free curves. These defaults lower the circle's peak and
mean against the PID CCC by a few percent and stay within a few percent of it on the free
curves (measured: the table in :mod:`agents.ccc_policies`).
"""

from __future__ import annotations

import functools

import numba
import numpy as np

from agents.fuzzy import CompiledMamdani, fuzzy_pid_000, surface_eval_flat, surface_table
from contour_gym._schema import Param, Schema
from contour_gym._validate import non_negative
from contour_gym.ccc import CCCLaw, pid_commit, register_ccc_law
from contour_gym.presets import get_preset
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
def fuzzy_pid_gains(p, s, data, q, row, e, ts):
    """``(Kp, Ki, Kd)`` of this tick: the base gains plus the scaled fuzzy outputs, >= 0.

    Args:
        p: (rows, FUZZY_PID_PARAMS.size) parameter rows.
        s: (rows, PID state size) state rows.
        data: The flattened fuzzy_pid_000 surface (:func:`agents.fuzzy.surface_table`).
        q: Parameter row.
        row: State row.
        e: Contour error, m.
        ts: Sample time, s.
    """
    de = (e - s[row, _S.e_prev]) / ts if s[row, _S.started] > 0.0 else 0.0
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


FUZZY_PID = register_ccc_law(
    CCCLaw(
        "fuzzy_pid", FUZZY_PID_PARAMS, PID_STATE, fuzzy_pid_output, pid_commit,
        data=fuzzy_pid_table,
        doc="fuzzy PID on the contour error, gains K0 + k_f dK(k_e e, k_de de) (paper 000)",
    )
)  # fmt: skip
