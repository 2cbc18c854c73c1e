"""Paper 000's fuzzy PID CCC law (agents/ccc_laws.py) in the compiled servo loop."""

from __future__ import annotations

import math
from typing import Any

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
from contour_gym import jit
from contour_gym.api import make_scenario
from contour_gym.ccc import CCC_LAWS
from contour_gym.loop import ServoLoop
from contour_gym.loop.state import WORK_ROW

TICKS = 300
PRESET = make_scenario("xy_dc_servo").preset
FUZZY_PID_PARAMS = ccc_laws.FUZZY_PID_PARAMS
FACTORS = FUZZY_PID_PARAMS.names[3:]
KP0, KI0 = PRESET.ccc_gains.kp, PRESET.ccc_gains.ki
BASE = (KP0, KI0, 2e-3 * KP0)  # a derivative too, so that every term is exercised
# inputs spanning the surface on the circle's start (errors of a few um, encoder steps in
# de) and factors large enough that Kp and Kd are clipped at 0 on some ticks
BOLD = {"k_e": 3.0 / 4e-6, "k_de": 3.0 / 2e-3, "k_pf": 0.6 * KP0, "k_if": 0.5 * KI0,
        "k_df": 2e-3 * KP0}


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
    key = jit.identity(ccc_laws.FUZZY_PID.output)
    assert key.startswith("agents.ccc_laws.fuzzy_pid_output @ ")
    assert " + agents.fuzzy.kernels @ " in key
    assert " + " not in jit.identity(CCC_LAWS.get("pid").output)


def law_row(plant: str | dict[str, Any], **options: object) -> dict[str, float]:
    """The fuzzy law's parameters a loop of ``plant`` runs with (no step: nothing compiles)."""
    loop = make_scenario(plant, ccc_law="fuzzy_pid", **options).loop(batch_size=1)
    return dict(zip(FUZZY_PID_PARAMS.names, loop.ccc_p[0, 0].tolist(), strict=True))


def test_the_default_factors_follow_each_machine_by_000s_rule() -> None:
    # 000's machine: the schema's defaults, bit for bit
    on_000 = law_row("xy_dc_servo")
    assert all(on_000[k] == FUZZY_PID_PARAMS.defaults()[k] for k in FACTORS)
    # 002's (pre-compensation, kp0 1): 000's numbers moved Kp by up to 2300 and diverged
    preset = make_scenario("lugre_linear_motor").preset
    row, g = law_row("lugre_linear_motor"), preset.ccc_gains
    assert row["k_pf"] == pytest.approx(g.kp / 8.0, rel=1e-12)
    assert row["k_if"] == pytest.approx(g.ki / 16.0, rel=1e-12)
    assert row["k_e"] == pytest.approx(3.0 / (8.0 * preset.tolerance), rel=1e-12)
    assert row["k_de"] == pytest.approx(3.0 / (3.0 * 1e-7 / preset.stage.ts), rel=1e-12)
    assert row["k_df"] == 0.0


def test_given_factors_stand_or_carry_from_the_machine_they_were_set_on() -> None:
    given = {"k_e": 2e5, "k_de": 500.0, "k_pf": 700.0, "k_if": 9000.0, "k_df": 3.0}
    assert law_row("lugre_linear_motor", ccc_law_params=given) == pytest.approx(
        {**law_row("lugre_linear_motor"), **given}, rel=0)
    carried = {**given, "machine": "xy_dc_servo"}
    assert {k: law_row("xy_dc_servo", ccc_law_params=carried)[k] for k in FACTORS} == given
    target = make_scenario("lugre_linear_motor").preset
    units, home = ccc_laws.fuzzy_pid_units(target), ccc_laws.fuzzy_pid_units(PRESET)
    row = law_row("lugre_linear_motor", ccc_law_params=carried)
    for k in FACTORS:
        assert row[k] == pytest.approx(given[k] * units[k] / home[k], rel=1e-12)


def test_the_tuned_policies_carry_their_factors_and_the_untuned_one_gives_none() -> None:
    from agents.policies import make

    assert make("fuzzy_pid_ccc").env_kwargs["ccc_law_params"] == {}
    assert make("fuzzy_pid_ccc", k_pf=5.0).env_kwargs["ccc_law_params"] == {"k_pf": 5.0}
    for name in ("pso_fuzzy_pid_ccc", "pso_fuzzy_pid_ccc_000"):
        params = make(name).env_kwargs["ccc_law_params"]
        assert params.pop("machine") == "xy_dc_servo" and set(params) == set(FACTORS)


def test_a_machine_without_encoder_runs_given_factors_and_names_the_missing_unit() -> None:
    bare = {"preset": "xy_dc_servo", "stage": {"axes": {"x": {"encoder_resolution": 0.0},
                                                        "y": {"encoder_resolution": 0.0}}}}
    given = {"k_e": 2e5, "k_de": 500.0, "k_pf": 700.0, "k_if": 9000.0, "k_df": 3.0}
    row = law_row(bare, ccc_law_params=given)
    assert {k: row[k] for k in FACTORS} == given
    with pytest.raises(ValueError, match="has no encoder to scale k_de by"):
        law_row(bare)


def test_a_machine_for_a_law_without_units_raises_naming_the_law() -> None:
    with pytest.raises(ValueError, match="'pid' has no machine units"):
        make_scenario("xy_dc_servo", ccc_law_params={"machine": "xy_dc_servo"}).loop()
    with pytest.raises(ValueError, match="unknown plant preset 'nowhere'"):
        law_row("xy_dc_servo", ccc_law_params={"machine": "nowhere"})
