"""Paper 000's fuzzy PID CCC law (agents/ccc_laws.py) in the compiled servo loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _law_checks import (
    assert_ccc_params_name_the_bad_value,
    assert_members_equal_single_runs,
    assert_runs_as_the_pid_law,
)

from agents import ccc_laws
from agents import fuzzy as F  # noqa: N812
from agents.fuzzy import kernels as fuzzy_kernels
from contour_gym import _compile
from contour_gym._loopstate import WORK_ROW
from contour_gym.api import make_scenario
from contour_gym.ccc import CCC_LAWS
from contour_gym.loop import ServoLoop

TICKS = 300
PRESET = make_scenario("xy_dc_servo").preset
KP0, KI0 = PRESET.ccc_gains.kp, PRESET.ccc_gains.ki
BASE = (KP0, KI0, 2e-3 * KP0)  # a derivative too, so that every term is exercised
# inputs spanning the surface on the circle's start (errors of a few um, encoder steps in
# de) and factors large enough that Kp and Kd are clipped at 0 on some ticks
BOLD = {"k_e": 3.0 / 4e-6, "k_de": 3.0 / 2e-3, "k_pf": 0.6 * KP0, "k_if": 0.5 * KI0,
        "k_df": 2e-3 * KP0}  # fmt: skip


def make_loop(law: str, params: dict[str, float], batch: int = 1, **kw: object) -> ServoLoop:
    scenario = make_scenario("xy_dc_servo", ccc_law=law, ccc_law_params=params, **kw)
    loop = scenario.loop(batch_size=batch, ccc_gains=BASE, record=True)
    loop.reset([7] * batch)
    return loop


def run_ccc_outputs(loop: ServoLoop) -> tuple[np.ndarray, np.ndarray]:
    """One tick at a time: the error the CCC saw and its output U, (TICKS,) each.

    The output is read from the CCC share of the axes' control, ``w C U`` with ``w = 1``
    and the unit coupling direction ``C = -n_left`` (2-D): ``|U|`` is its length, the sign
    that of its projection on ``-n_left`` of the reference's direction of travel.
    """
    assert np.all(loop.ccc_w == 1.0)
    eps, out = np.empty(TICKS), np.empty(TICKS)
    for k in range(TICKS):
        loop.step(1)
        ux, uy = loop.work[0, WORK_ROW.uccc, :2]
        vx, vy = loop.work[0, WORK_ROW.rdot, :2]
        eps[k] = loop.contour_error_estimate[0, 0]
        out[k] = math.copysign(math.hypot(ux, uy), vy * ux - vx * uy)
    return eps, out


def reference_law(
    eps: np.ndarray, ts: float, base: tuple[float, ...], **f: float
) -> tuple[np.ndarray, np.ndarray]:
    """The fuzzy PID law in plain numpy from the recorded error: outputs U and gains (T, 3)."""
    de = np.concatenate([[0.0], np.diff(eps) / ts])
    x = np.stack([f["k_e"] * eps, f["k_de"] * de], axis=1)
    dk = F.evaluate(F.fuzzy_pid_000(), x, method="surface")
    kp = np.maximum(base[0] + f["k_pf"] * dk[:, 0], 0.0)
    ki = np.maximum(base[1] + f["k_if"] * dk[:, 1], 0.0)
    kd = np.maximum(base[2] + f["k_df"] * dk[:, 2], 0.0)
    integral = np.concatenate([[0.0], np.cumsum(eps * ts)[:-1]])
    return kp * eps + ki * (integral + eps * ts) + kd * de, np.stack([kp, ki, kd], axis=1)


def test_the_flat_table_reads_the_surface_bit_for_bit() -> None:
    system = F.fuzzy_pid_000()
    x = np.random.default_rng(3).uniform(-3.5, 3.5, (2000, 2))
    x[:4] = [[np.nan, 0.0], [0.0, np.nan], [-9.0, 9.0], [3.0, -3.0]]
    table = ccc_laws.fuzzy_pid_table()
    assert table is ccc_laws.fuzzy_pid_table() and not table.flags.writeable
    flat = np.empty((len(x), 3))
    fuzzy_kernels._surface_flat_batch(table, x, flat)
    np.testing.assert_array_equal(flat[4:], F.evaluate(system, x[4:], method="surface"))
    assert np.isnan(flat[:2]).all()
    assert CCC_LAWS.get("fuzzy_pid") is ccc_laws.FUZZY_PID
    np.testing.assert_array_equal(ccc_laws.FUZZY_PID.table(), table)


def test_the_compiled_law_equals_numpy_on_the_recorded_error() -> None:
    loop = make_loop("fuzzy_pid", BOLD)
    eps, out = run_ccc_outputs(loop)
    ref, gains = reference_law(eps, loop.stage.ts, BASE, **BOLD)
    assert np.ptp(eps) > 2e-6  # the inputs cover the surface, not just its middle
    assert (gains[:, 0] == 0).any() and (gains[:, 2] == 0).any() and (gains[:, 0] > KP0).any()
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12 * np.abs(ref).max())


def test_batch_members_with_their_own_factors_equal_single_runs() -> None:
    defaults = {k: float(v or 0.0) for k, v in ccc_laws.FUZZY_PID_PARAMS.defaults().items()}
    rows = [dict(BOLD), {k: defaults[k] for k in BOLD}, {**BOLD, "k_e": 1e5, "k_if": 0.0}]
    assert_members_equal_single_runs(make_loop, "fuzzy_pid", rows, TICKS)


def test_zero_output_factors_are_the_pid_law_bit_for_bit() -> None:
    zero = {**BOLD, "k_pf": 0.0, "k_if": 0.0, "k_df": 0.0}
    fuzzy, pid = assert_runs_as_the_pid_law(make_loop, "fuzzy_pid", zero, TICKS)
    np.testing.assert_array_equal(fuzzy.ccc_s, pid.ccc_s)


@pytest.mark.parametrize("name", ["kp", "k_e", "k_de", "k_pf", "k_if", "k_df"])
@pytest.mark.parametrize("value", [float("nan"), -1.5, float("inf")])
def test_bad_parameters_raise_naming_the_value(name: str, value: float) -> None:
    assert_ccc_params_name_the_bad_value(ccc_laws.FUZZY_PID, BASE, name, value)
    if name != "kp":
        with pytest.raises(ValueError, match=rf"fuzzy_pid\.{name} must"):
            make_scenario("xy_dc_servo", ccc_law="fuzzy_pid", ccc_law_params={name: value}).loop()


def test_the_kernel_cache_key_follows_the_fuzzy_module_the_law_calls() -> None:
    # the law's surface code lives in agents/fuzzy/kernels.py: editing it must recompile the loop
    key = _compile.identity(ccc_laws.FUZZY_PID.output)
    assert key.startswith("agents.ccc_laws.fuzzy_pid_output @ ")
    assert " + agents.fuzzy.kernels @ " in key
    assert " + " not in _compile.identity(CCC_LAWS.get("pid").output)
