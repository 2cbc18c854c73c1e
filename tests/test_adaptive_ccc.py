"""Paper 001's adaptive fuzzy PID CCC: the compiled law (agents/ccc_laws.py) and its policy."""

from __future__ import annotations

from typing import Any

import numba
import numpy as np
import pytest
from _law_checks import (
    assert_ccc_params_name_the_bad_value,
    assert_members_equal_single_runs,
    assert_runs_as_the_pid_law,
)

import agents.ccc_policies as P  # noqa: N812  (registers the policies and the laws)
from agents import ccc_laws as L  # noqa: N812
from agents import fuzzy as F  # noqa: N812
from agents.evaluate import run_policy, run_policy_batch
from agents.policies import POLICIES, make_policy
from contour_gym import jit
from contour_gym.api import make_scenario
from contour_gym.ccc import CCC_LAWS
from contour_gym.loop import ServoLoop
from contour_gym.loop.state import WORK_ROW
from contour_gym.paths import parametric

HELIX = "contour_gym/CCC-PMLSM-Helix-v0"
PRESET = make_scenario("xyz_pmlsm").preset
KP0, KI0 = PRESET.ccc_gains.kp, PRESET.ccc_gains.ki
TICKS = 300
BASE = (KP0, 0.2 * KI0, 0.0)
# bold: inputs spanning the basis (errors of a few um on the rig's start, encoder steps in
# de), fast rates so that every gain's weights reach their bounds within TICKS, a Ki bound
# beyond its base and Kd from 0, so that Ki and Kd are clipped at 0 on some ticks
BOLD = {"k_e": 3.0 / 4e-6, "k_de": 3.0 / 2e-3, "gamma_p": 1e15, "gamma_i": 1e19,
        "gamma_d": 1e12, "dkp_max": 0.5 * KP0, "dki_max": 0.5 * KI0, "dkd_max": 5.0}
ZERO_RATES = {"gamma_p": 0.0, "gamma_i": 0.0, "gamma_d": 0.0}
GAINS = ("kp", "ki", "kd")
N_RULES = L.N_RULES_001


def make_loop(law: str, params: dict[str, float], batch: int = 1) -> ServoLoop:
    scenario = make_scenario("xyz_pmlsm", ccc_law=law, ccc_law_params=params)
    loop = scenario.loop(batch_size=batch, ccc_gains=BASE, record=True)
    loop.reset([7] * batch)
    return loop


def thetas(loop: ServoLoop) -> np.ndarray:
    """(B, 3 rows, 3 gains, L) adapted weights of the loop's one contour."""
    a = L.ADAPTIVE_STATE.col
    block = loop.ccc_s[:, 0, :, a.theta_kp_NB_NB :]
    return block.reshape(block.shape[0], 3, 3, N_RULES)


def run_rows(loop: ServoLoop) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One tick at a time: per error row (the 3 signed components), the error the law saw,
    its output U and theta after the commit: (T, 3), (T, 3), (T, 3, 3, L).

    In 3-D row i drives axis i alone, ``w_i U_i`` with ``w = 1``; the commit leaves the
    tick's error in ``e_prev``.
    """
    assert np.all(loop.ccc_w == 1.0)
    e_prev = L.ADAPTIVE_STATE.col.e_prev
    eps, out, theta = np.empty((TICKS, 3)), np.empty((TICKS, 3)), []
    for k in range(TICKS):
        loop.step(1)
        eps[k] = loop.ccc_s[0, 0, :, e_prev]
        out[k] = loop.work[0, WORK_ROW.uccc, :3]
        theta.append(thetas(loop)[0].copy())
    return eps, out, np.array(theta)


def reference_law(
    e: np.ndarray, ts: float, base: tuple[float, ...], p: dict[str, float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The law in plain numpy on one row's recorded error (T,), from theta = 0.

    Returns:
        Outputs U (T,), gains (T, 3) and theta after each tick (T, 3, L).
    """
    system = F.adaptive_fuzzy_001(L.N_SETS_001)
    de = np.concatenate([[0.0], np.diff(e) / ts])
    xi = F.reference_basis(system, np.stack([p["k_e"] * e, p["k_de"] * de], axis=1))
    gamma = np.array([p["gamma_p"], p["gamma_i"], p["gamma_d"]])
    bound = np.array([p["dkp_max"], p["dki_max"], p["dkd_max"]])
    theta = np.zeros((3, N_RULES))
    integral = 0.0
    out, gains, trail = np.empty(len(e)), np.empty((len(e), 3)), np.empty((len(e), 3, N_RULES))
    for k in range(len(e)):
        gains[k] = np.maximum(np.asarray(base) + theta @ xi[k], 0.0)
        phi = np.array([e[k], integral + e[k] * ts, de[k]])
        out[k] = gains[k] @ phi
        theta = np.clip(theta + ts * gamma[:, None] * e[k] * phi[:, None] * xi[k], -bound[:, None],
                        bound[:, None])
        trail[k] = theta
        integral += e[k] * ts
    return out, gains, trail


def test_the_law_is_registered_with_named_state_and_its_basis_table() -> None:
    law = CCC_LAWS.get("adaptive_fuzzy_pid")
    assert law is L.ADAPTIVE_FUZZY_PID and law.params is L.ADAPTIVE_FUZZY_PID_PARAMS
    assert law.params.names[:5] == ("kp", "ki", "kd", "k_e", "k_de")
    names = law.state.names
    assert names[:3] == ("integral", "e_prev", "started")
    theta = [n for n in names if n.startswith("theta_")]
    assert len(theta) == 3 * N_RULES == 75 and theta[0] == "theta_kp_NB_NB"
    assert theta[-1] == "theta_kd_PB_PB" and names[-len(theta) :] == tuple(theta)
    table = L.adaptive_fuzzy_pid_table()
    assert table is L.adaptive_fuzzy_pid_table() and not table.flags.writeable
    np.testing.assert_array_equal(law.table(), table)
    # the table's views feed product_basis_into: the basis of agents.fuzzy, bit for bit
    x = np.random.default_rng(5).uniform(-3.5, 3.5, (500, 2))
    x[:3] = [[-3.0, 3.0], [0.0, 0.0], [9.0, -9.0]]
    np.testing.assert_array_equal(_basis_from_table(table, x),
                                  F.basis(F.adaptive_fuzzy_001(5), x))
    assert (F.initial_theta(F.adaptive_fuzzy_001(5)) == 0.0).all()  # theta starts at 0


@numba.njit(cache=True)
def _basis_from_table(data: np.ndarray, x: np.ndarray) -> np.ndarray:
    mf, meta, ant = L.basis_views(data)
    mu = np.zeros((mf.shape[0], mf.shape[1]))
    out = np.empty((x.shape[0], ant.shape[0]))
    for b in range(x.shape[0]):
        F.product_basis_into(mf, meta, ant, x[b], mu, out[b])
    return out


def test_the_compiled_law_equals_numpy_on_the_recorded_error() -> None:
    loop = make_loop("adaptive_fuzzy_pid", BOLD)
    eps, out, theta = run_rows(loop)
    bound = np.array([BOLD["dkp_max"], BOLD["dki_max"], BOLD["dkd_max"]])
    gains = []
    for i in range(3):
        ref, row_gains, trail = reference_law(eps[:, i], loop.stage.ts, BASE, BOLD)
        gains.append(row_gains)
        np.testing.assert_allclose(out[:, i], ref, rtol=1e-11, atol=1e-11 * np.abs(ref).max())
        for j in range(3):
            np.testing.assert_allclose(theta[:, i, j], trail[:, j], rtol=1e-11,
                                       atol=1e-11 * bound[j])
    assert np.ptp(eps) > 4e-6  # the errors cover the basis, not just its middle
    # the run exercises the bounds and the clip of the gains at 0
    assert (np.abs(theta) == bound[None, None, :, None]).any(axis=(0, 1, 3)).all()
    g = np.concatenate(gains)
    assert (g[:, 1] == 0).any() and (g[:, 2] == 0).any() and (g[:, 2] > 0).any()
    assert (g[:, 0] > KP0).any() and (g[:, 1] > BASE[1]).any()


def test_theta_stays_within_its_bound() -> None:
    loop = make_loop("adaptive_fuzzy_pid", BOLD)
    bound = np.array([BOLD["dkp_max"], BOLD["dki_max"], BOLD["dkd_max"]])[:, None]
    for _ in range(10):
        loop.step(200)
        theta = thetas(loop)[0]
        assert np.all(np.abs(theta) <= bound)
    assert np.all(theta[:, 0] >= 0.0)  # theta_p' = gamma_p e^2 xi only grows
    a = L.ADAPTIVE_STATE.col
    dk = loop.ccc_s[0, 0, :, a.dkp : a.dkp + 3]
    assert np.all(np.abs(dk) <= bound[:, 0] * (1 + 1e-12))  # a convex combination of theta


def test_batch_members_with_their_own_params_equal_single_runs() -> None:
    defaults = {k: float(v or 0.0) for k, v in L.ADAPTIVE_FUZZY_PID_PARAMS.defaults().items()}
    rows = [dict(BOLD), {k: defaults[k] for k in BOLD}, {**BOLD, "gamma_d": 0.0, "k_e": 1e5}]
    assert_members_equal_single_runs(make_loop, "adaptive_fuzzy_pid", rows, TICKS)


def test_zero_rates_are_the_pid_law_bit_for_bit() -> None:
    zero = {**BOLD, **ZERO_RATES}
    adaptive, pid = assert_runs_as_the_pid_law(make_loop, "adaptive_fuzzy_pid", zero, TICKS)
    np.testing.assert_array_equal(adaptive.ccc_s[..., :3], pid.ccc_s)
    assert np.all(thetas(adaptive) == 0.0)


NAMES = L.ADAPTIVE_FUZZY_PID_PARAMS.names


@pytest.mark.parametrize("name", NAMES[:1] + NAMES[3:])
@pytest.mark.parametrize("value", [float("nan"), -1.5, float("inf")])
def test_bad_parameters_raise_naming_the_value(name: str, value: float) -> None:
    assert_ccc_params_name_the_bad_value(L.ADAPTIVE_FUZZY_PID, BASE, name, value)
    if name == "kp":
        return
    with pytest.raises(ValueError, match=rf"adaptive_fuzzy_pid\.{name} must .*{value}"):
        make_scenario(
            "xyz_pmlsm", ccc_law="adaptive_fuzzy_pid", ccc_law_params={name: value}
        ).loop()
    with pytest.raises(ValueError, match=rf"adaptive_fuzzy_pid\.{name} must .*{value}"):
        make_policy("adaptive_fuzzy_pid_ccc", **{name: value})


def test_the_kernel_cache_key_follows_the_fuzzy_module_the_law_calls() -> None:
    key = jit.identity(L.ADAPTIVE_FUZZY_PID.output)
    assert key.startswith("agents.ccc_laws.adaptive_fuzzy_pid_output @ ")
    assert " + agents.fuzzy.kernels @ " in key


# ----------------------------------------------------------------------------------------
# the policy
# ----------------------------------------------------------------------------------------


def lissajous(t: np.ndarray) -> np.ndarray:
    """A 3-D Lissajous curve, 30 x 15 x 5 mm (a user's free curve)."""
    w = 2.0 * np.pi * t
    return np.stack([0.03 * np.sin(w), 0.015 * np.sin(2 * w), 0.005 * np.sin(3 * w)], axis=1)


def test_the_policy_is_registered_with_its_parameters() -> None:
    entry = POLICIES.get("adaptive_fuzzy_pid_ccc")
    assert entry.params() == (*NAMES[3:], "axes", "base_gains")
    assert make_policy("adaptive_fuzzy_pid_ccc").env_kwargs == {  # the machine makes them
        "axis_controller": "smc_dob", "ccc_law": "adaptive_fuzzy_pid", "ccc_law_params": {}}
    pid_axes = make_policy("adaptive_fuzzy_pid_ccc", axes="pid", gamma_d=0.0)
    assert pid_axes.env_kwargs["axis_controller"] == "pid"
    assert pid_axes.env_kwargs["ccc_law_params"]["gamma_d"] == 0.0
    with pytest.raises(ValueError, match="axes.*'smc'"):
        make_policy("adaptive_fuzzy_pid_ccc", axes="smc")
    with pytest.raises(ValueError, match="gains"):
        make_policy("adaptive_fuzzy_pid_ccc", base_gains=(-1.0, 0.0, 0.0))
    assert isinstance(pid_axes, P.AdaptiveFuzzyPIDCCC)


@pytest.mark.parametrize(
    ("axes", "path"), [("smc_dob", None), ("smc_dob", "lissajous"), ("pid", "lissajous")]
)
def test_the_policy_runs_to_the_end(axes: str, path: str | None) -> None:
    kwargs: dict[str, Any] = {} if path is None else {"path": parametric(lissajous, 0.0, 1.0)}
    m = run_policy(HELIX, make_policy("adaptive_fuzzy_pid_ccc", axes=axes), **kwargs)
    assert m["finished"] and not m["failed"] and not m["truncated"]
    assert np.isfinite(m["max_contour_error"])


def test_members_equal_single_runs() -> None:
    policy = make_policy("adaptive_fuzzy_pid_ccc")
    batch = run_policy_batch(HELIX, policy, num_envs=2, seed=4, randomize=True)
    singles = [run_policy(HELIX, policy, seed=s, randomize=True) for s in (4, 5)]
    for i, single in enumerate(singles):
        assert {k: v[i].item() for k, v in batch.items()} == single
    assert singles[0]["max_contour_error"] != singles[1]["max_contour_error"]


def test_zero_rates_are_the_pid_ccc_and_the_defaults_lower_its_mean_error() -> None:
    pid = run_policy(HELIX, make_policy("pid_ccc"), seed=3)
    assert run_policy(HELIX, make_policy("adaptive_fuzzy_pid_ccc", **ZERO_RATES), seed=3) == pid
    adaptive = run_policy(HELIX, make_policy("adaptive_fuzzy_pid_ccc"), seed=3)
    assert adaptive["finished"]
    assert adaptive["mean_contour_error"] < pid["mean_contour_error"]


def adaptive_row(plant: str) -> dict[str, float]:
    """The law's parameters a loop of ``plant`` runs with, by default (no step, no compile)."""
    loop = make_scenario(plant, ccc_law="adaptive_fuzzy_pid").loop(batch_size=1)
    return dict(zip(NAMES, loop.ccc_p[0, 0].tolist(), strict=True))


def test_the_defaults_follow_each_machine_by_001s_rule() -> None:
    on_001 = adaptive_row("xyz_pmlsm")
    defaults = L.ADAPTIVE_FUZZY_PID_PARAMS.defaults()
    assert all(on_001[k] == defaults[k] for k in NAMES[3:])  # bit for bit
    for plant in ("lugre_linear_motor", "xyy_gantry"):  # dimensionless gains; ki0 = 0
        m = make_scenario(plant).preset
        kp0, ki0, tol, ts = m.ccc_gains.kp, m.ccc_gains.ki, m.tolerance, m.stage.ts
        count = min(a.encoder_resolution for a in m.stage.axes)
        row = adaptive_row(plant)
        want = {"k_e": 3.0 / (32.0 * tol), "k_de": ts / count, "dkp_max": kp0 / 4.0,
                "dki_max": ki0 / 2.0, "dkd_max": 6.0 * kp0 * ts,
                "gamma_p": kp0 / 4.0 / (10.0 * tol * tol),
                "gamma_i": ki0 / 2.0 / (tol * tol * kp0 / ki0) if ki0 else 0.0,
                "gamma_d": 6.0 * kp0 * ts / (0.03 * tol * count / ts)}
        assert {k: row[k] for k in want} == pytest.approx(want, rel=1e-12), plant
