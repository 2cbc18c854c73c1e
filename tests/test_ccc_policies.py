"""CCC reference policies (agents/ccc_policies.py): no CCC, PID CCC, 000's fuzzy PID CCC."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import agents.ccc_policies  # noqa: F401  (registers the policies and the fuzzy_pid law)
from agents.evaluate import run_policy, run_policy_batch
from agents.policies import POLICIES, make_policy
from contour_gym.paths import Path, from_gcode, parametric

CIRCLE = "contour_gym/CCC-Circle-v0"
NAMES = ("no_ccc", "pid_ccc", "fuzzy_pid_ccc")
FACTORS = ("k_e", "k_de", "k_pf", "k_if", "k_df")
# a small 2-D part: lines and arcs, mm
PROGRAM = """G21 G90 G17
F1200
G1 X10 Y0
G3 X20 Y10 R10
G1 Y20
G2 X10 Y30 R10
G1 X0
M2
"""


def s_curve(t: np.ndarray) -> np.ndarray:
    """An S curve 20 mm long and 5 mm high (a free curve: 000's estimator two_circle)."""
    return np.stack([0.02 * t, 0.0025 * np.sin(2.0 * np.pi * t)], axis=1)


@pytest.fixture(scope="module")
def user_paths() -> dict[str, dict[str, Any]]:
    curve: Path = parametric(s_curve, 0.0, 1.0)
    return {
        "circle": {},
        "parametric": {"path": curve, "estimator": "two_circle"},
        "gcode": {"path": from_gcode(PROGRAM)},
    }


def test_the_policies_are_registered_with_their_parameters() -> None:
    assert set(NAMES) <= set(POLICIES.names())
    assert POLICIES.get("no_ccc").params() == () == POLICIES.get("pid_ccc").params()
    assert POLICIES.get("fuzzy_pid_ccc").params() == (*FACTORS, "base_gains")
    # no factor given: the env's machine makes them (tests/test_ccc_laws.py)
    assert make_policy("fuzzy_pid_ccc").env_kwargs == {"ccc_law": "fuzzy_pid", "ccc_law_params": {}}
    assert make_policy("fuzzy_pid_ccc", k_e=2.0).env_kwargs["ccc_law_params"]["k_e"] == 2.0
    assert make_policy("pid_ccc").env_kwargs == {} == make_policy("no_ccc").env_kwargs
    for name, value in (("k_e", -1.0), ("k_de", float("nan")), ("k_df", float("inf"))):
        with pytest.raises(ValueError, match=rf"fuzzy_pid\.{name} must .*{value}"):
            make_policy("fuzzy_pid_ccc", **{name: value})
    with pytest.raises(ValueError, match="gains"):
        make_policy("fuzzy_pid_ccc", base_gains=(-1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="accepted: none"):
        make_policy("no_ccc", gains=(1.0, 0.0, 0.0))


def test_actions_are_the_gains_the_env_maps() -> None:
    own = (2000.0, 3e4, 5.0)
    venv = gym.make_vec("contour_gym/CCC-v0", num_envs=2, ccc_gains=own)
    obs, _ = venv.reset(seed=0)
    task = venv.unwrapped.task
    expect = {"no_ccc": (0.0, 0.0, 0.0), "pid_ccc": own}
    for name, gains in expect.items():
        policy = make_policy(name)
        policy.reset(venv)
        actions = policy.act(obs)
        assert actions.shape == (2, 3)
        np.testing.assert_allclose(task.action_to_gains(actions)[:, 0], [gains] * 2, rtol=1e-12)
    off = make_policy("no_ccc")
    off.reset(venv)
    assert np.all(off.act(obs) == -1.0)  # exactly 0 gains
    fuzzy = make_policy("fuzzy_pid_ccc", base_gains=(1000.0, 0.0, 0.0))
    fuzzy.reset(venv)
    np.testing.assert_allclose(task.action_to_gains(fuzzy.act(obs))[0, 0], (1000.0, 0.0, 0.0))
    feed = gym.make_vec("contour_gym/Feedrate-v0", num_envs=1)
    for name in NAMES:
        with pytest.raises(ValueError, match="CCC env"):
            make_policy(name).reset(feed)
    venv.close()
    feed.close()


@pytest.mark.parametrize("where", ["circle", "parametric", "gcode"])
@pytest.mark.parametrize("name", NAMES)
def test_each_policy_runs_to_the_end(
    name: str, where: str, user_paths: dict[str, dict[str, Any]]
) -> None:
    m = run_policy(CIRCLE, make_policy(name), **user_paths[where])
    assert m["finished"] and not m["failed"] and not m["truncated"]
    assert np.isfinite(m["max_contour_error"])


@pytest.mark.parametrize("name", NAMES)
def test_members_equal_single_runs(name: str) -> None:
    batch = run_policy_batch(CIRCLE, make_policy(name), num_envs=2, seed=4, randomize=True)
    singles = [run_policy(CIRCLE, make_policy(name), seed=s, randomize=True) for s in (4, 5)]
    for i, single in enumerate(singles):
        assert {k: v[i].item() for k, v in batch.items()} == single
    assert singles[0]["max_contour_error"] != singles[1]["max_contour_error"]


def test_zero_output_factors_are_the_pid_ccc() -> None:
    zero = make_policy("fuzzy_pid_ccc", k_pf=0.0, k_if=0.0, k_df=0.0)
    kwargs = {"seed": 2, "randomize": True}
    pid = run_policy(CIRCLE, make_policy("pid_ccc"), **kwargs)
    assert run_policy(CIRCLE, zero, **kwargs) == pid


def test_the_fuzzy_defaults_lower_the_peak_error_of_no_ccc() -> None:
    fuzzy = run_policy(CIRCLE, make_policy("fuzzy_pid_ccc"))
    none = run_policy(CIRCLE, make_policy("no_ccc"))
    assert fuzzy["finished"] and none["finished"]
    assert fuzzy["max_contour_error"] < none["max_contour_error"]


def test_a_conflicting_ccc_law_argument_raises() -> None:
    with pytest.raises(ValueError, match="ccc_law='pid' conflicts"):
        run_policy(CIRCLE, make_policy("fuzzy_pid_ccc"), ccc_law="pid")
