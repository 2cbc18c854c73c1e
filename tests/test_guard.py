"""The corner guard: the PID CCC's gains near sharp corners, the agent's elsewhere.

The guarded policy here is ``no_ccc`` (every gain 0), so that the two policies' actions differ
and a vector env must equal single envs bit for bit (a trained agent's float32 network may
round a batch's rows differently from one row's).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from agents.evaluate import evaluate, make_vector_env, run_policy, run_policy_batch
from agents.policies import make_policy
from agents.rl.guard import CappedFeedrate, CornerGuard

POLYLINES = {"id": "contour_gym/CCC-v1", "plant": "xy_dc_servo", "estimator": "two_circle",
             "path": "random", "path_options": {"family": "polyline"}}


def _expected_guarded(corners, curvatures, guard):
    """Per step and member, whether the guard's rule puts the PID CCC in charge (the env's
    previews 1, 2, 5, 10 and 20 mm: the curvature at the reference, 1 and 2 mm is within 2 mm)."""
    left = np.zeros(corners[0].shape[0], dtype=int)
    was_near = np.zeros_like(left, dtype=bool)
    out = []
    for c, k in zip(corners, curvatures, strict=True):
        near = (c[:, 0] * 0.02 < guard.near) & (np.abs(c[:, 1]) * math.pi > guard.angle)
        near |= (np.abs(k[:, :3]) * 100.0 > guard.curvature).any(axis=1)
        left = np.where(was_near & ~near, guard.hold, np.maximum(left - 1, 0))
        was_near = near
        out.append(near | (left > 0))
    return np.array(out)


def _roll_out(env, guard, num_envs, seed, steps):
    """Run ``guard`` for ``steps`` decisions; per step whether it acted as the PID CCC and as
    its agent, and the rule's expected choice (:func:`_expected_guarded`)."""
    venv = make_vector_env(env, guard, num_envs=num_envs)
    try:
        obs, _ = venv.reset(seed=seed)
        guard.reset(venv)
        pid = make_policy("pid_ccc")
        pid.reset(venv)
        corners, curvatures, took_pid, took_agent = [], [], [], []
        for _ in range(steps):
            actions = guard.act(obs)
            corners.append(np.asarray(obs["corner"], dtype=np.float64))
            curvatures.append(np.asarray(obs["curvature"], dtype=np.float64))
            took_pid.append(np.all(actions == pid.act(obs), axis=1))
            took_agent.append(np.all(actions == guard.agent.act(obs), axis=1))
            obs, *_ = venv.step(actions)
    finally:
        venv.close()
    return np.array(took_pid), np.array(took_agent), _expected_guarded(corners, curvatures, guard)


def test_the_guard_acts_as_the_pid_ccc_near_sharp_corners_and_as_the_agent_elsewhere():
    guard = CornerGuard("no_ccc", hold=5)
    took_pid, took_agent, expected = _roll_out(POLYLINES, guard, 3, seed=11, steps=150)
    assert expected.any() and (~expected).any()  # both happen on these polylines
    assert np.all(took_pid[expected])
    assert np.all(took_agent[~expected])


def test_the_guard_takes_over_past_a_near_cusp_where_no_corner_is():
    """On roses (no corners; angle pi guards none) the PID CCC acts exactly where the path
    within 2 mm curves tighter than ``curvature`` and for ``hold`` decisions after."""
    roses = {**POLYLINES, "path_options": {"family": "rose"}}
    guard = CornerGuard("no_ccc", angle=math.pi, hold=3, curvature=5000.0)
    took_pid, _, expected = _roll_out(roses, guard, 2, seed=5, steps=200)
    assert expected.any() and (~expected).any()
    np.testing.assert_array_equal(took_pid, expected)


def test_a_guarded_vector_env_runs_each_member_as_a_single_env_would():
    batch = run_policy_batch(POLYLINES, CornerGuard("no_ccc"), num_envs=2, seed=11)
    for i in range(2):
        single = run_policy(POLYLINES, CornerGuard("no_ccc"), seed=11 + i)
        assert batch["max_contour_error"][i] == single["max_contour_error"]
        assert batch["steps"][i] == single["steps"]
        assert batch["return"][i] == single["return"]
    assert (
        batch["return"][0] != run_policy(POLYLINES, make_policy("no_ccc"), seed=11)["return"]
    )  # the guard acted


def test_the_guard_runs_on_a_single_env_a_user_made():
    """evaluate(guard, env) reads the env's observation setting through the single env."""
    env = gym.make(POLYLINES["id"], **{k: v for k, v in POLYLINES.items() if k != "id"})
    mine = evaluate(CornerGuard("no_ccc"), env, n_episodes=1, seed=11)["episodes"]
    assert mine == [run_policy(POLYLINES, CornerGuard("no_ccc"), seed=11)]
    env.close()


@pytest.mark.parametrize(("kwargs", "named"), [
    ({"near": 0.0}, "near"), ({"near": math.nan}, "near"), ({"angle": 4.0}, "angle"),
    ({"angle": "wide"}, "angle"),
    ({"hold": -1}, "hold"), ({"hold": 2.5}, "hold"), ({"agent": "no_such_agent"}, "no_such_agent"),
    ({"curvature": 0.0}, "curvature"), ({"curvature": "tight"}, "curvature"),
    ({"curvature": math.nan}, "curvature"),
])
def test_the_guard_refuses_bad_settings_naming_them(kwargs, named):
    with pytest.raises(ValueError, match=named):
        CornerGuard(**{"agent": "no_ccc", **kwargs})


def test_the_guard_needs_an_env_and_a_dict_of_the_v1_observation():
    with pytest.raises(ValueError, match="v1 observation"):
        CornerGuard("no_ccc").reset(None)
    venv = make_vector_env(POLYLINES, CornerGuard("no_ccc"), num_envs=1)
    try:
        obs, _ = venv.reset(seed=0)
        guard = CornerGuard("no_ccc")
        with pytest.raises(ValueError, match="call it first"):  # it would never guard
            guard.act(obs)
        guard.reset(venv)
        with pytest.raises(ValueError, match="'corner' key"):
            guard.act({"obs": np.zeros((1, 14))})
    finally:
        venv.close()


def test_a_capped_feedrate_agent_passes_its_agents_actions_up_to_the_cap():
    """Capped at 0 the fuzzy feedrate controller (standing in for an agent) never speeds up,
    and acts as it does wherever it would not."""
    capped = CappedFeedrate("fuzzy_feedrate", cap=0.0)
    venv = make_vector_env({"id": "contour_gym/Feedrate-Corner-v1"}, capped, num_envs=2)
    try:
        obs, _ = venv.reset(seed=3)
        capped.reset(venv)
        free = make_policy("fuzzy_feedrate")
        free.reset(venv)
        raised = False
        for _ in range(60):
            actions, theirs = capped.act(obs), free.act(obs)
            np.testing.assert_array_equal(actions, np.minimum(theirs, 0.0))
            raised |= bool((theirs > 0.0).any())
            obs, *_ = venv.step(actions)
    finally:
        venv.close()
    assert raised  # the cap acted
    assert capped.env_kwargs == free.env_kwargs
    for cap in (1.5, -2.0, math.nan):
        with pytest.raises(ValueError, match="cap"):
            CappedFeedrate("fuzzy_feedrate", cap=cap)
