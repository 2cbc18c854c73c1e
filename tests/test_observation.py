"""The v1 observation: what a controller can know on any path (issue 26)."""

import math

import gymnasium as gym
import numpy as np
import pytest

import contour_gym  # noqa: F401  (registers the ids)
from contour_gym.envs import CCCEnv


def _first_obs(env_id, **kwargs):
    env = gym.make(env_id, **kwargs)
    obs, _ = env.reset(seed=0)
    return env, obs


def test_v1_ids_observe_the_geometry_ahead_and_no_progress():
    env, obs = _first_obs("contour_gym/CCC-Circle-v1")
    assert "progress" not in obs and "reference_velocity" not in obs
    assert set(obs) == {"contour_error", "contour_error_change", "tracking_error", "speed",
                        "curvature", "turning", "corner", "path_end", "gains"}
    preview = env.unwrapped.config.preview
    # 000's circle of radius 10 mm: curvature 100 1/m, observed x 1 cm = 1, everywhere ahead
    np.testing.assert_allclose(obs["curvature"], 1.0, rtol=1e-5)
    # the tangent turns by the arc's angle d / r to each preview distance (left: +)
    np.testing.assert_allclose(obs["turning"], np.array(preview) / 0.01 / math.pi, rtol=1e-5)
    np.testing.assert_array_equal(obs["corner"], [1.0, 0.0])  # no corner on a circle
    assert obs["path_end"][0] == 1.0  # the end lies beyond the horizon
    assert env.observation_space.contains(obs)


def test_the_corner_ahead_is_seen_with_its_distance_and_turn():
    env = gym.make("contour_gym/Feedrate-Corner-v1", decision_ticks=100)
    env.reset(seed=0)
    path, horizon = env.unwrapped.task.path, max(env.unwrapped.config.preview)
    corner = float(path.corners[0])
    seen = []
    for _ in range(400):
        obs, _, terminated, truncated, info = env.step(np.zeros(1))
        s = info["s"]
        if 0 < corner - s < horizon:
            seen.append((corner - s, obs["corner"]))
        if terminated or truncated or s > corner:
            break
    assert seen, "the corner never came within the horizon"
    for distance, (d_obs, turn) in seen:
        # the observation is made at the step's end, where info's s is read
        assert d_obs == pytest.approx(distance / horizon, abs=1e-6)
        assert abs(turn) == pytest.approx(0.5, abs=1e-3)  # 004's corner turns 90 degrees


def test_progress_is_an_option_and_v0_keeps_its_keys():
    env = CCCEnv(plant="xy_dc_servo", path="circle", observe_progress=True)
    obs, _ = env.reset(seed=0)
    assert obs["progress"].shape == (1,) and list(env.task.observe(0))[-1] == "gains"
    _, v0 = _first_obs("contour_gym/CCC-Circle-v0")
    assert set(v0) == {"contour_error", "contour_error_change", "tracking_error",
                       "reference_velocity", "curvature", "progress", "gains"}


def test_curvature_windows_see_the_peak_curvature_ahead():
    edges = (0.0, 0.001, 0.002, 0.005, 0.01)
    env = gym.make("contour_gym/Feedrate-v1", path="random", curvature_windows=edges,
                   decision_ticks=20)
    obs, _ = env.reset(seed=7009)  # a rose with a 0.31 mm radius on its way
    assert obs["curvature_peak"].shape == (4,) and list(obs)[-1] == "feedrate"
    path = env.unwrapped.task.loop.paths[0]
    seen = []
    for _ in range(150):
        s = float(env.unwrapped.task.loop.s[0])
        ahead = s + np.linspace(0.0, 0.01, 81)  # edges and every 0.125 mm between
        kappa = np.abs(np.asarray(path.curvature(np.minimum(ahead, path.length))))
        for j, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
            inside = (ahead - s >= lo - 1e-12) & (ahead - s <= hi + 1e-12)
            want = np.log10(1.0 + kappa[inside].max()) / 4.0
            assert obs["curvature_peak"][j] == pytest.approx(want, rel=1e-5), (s, j)
        seen.append(obs["curvature_peak"].copy())
        obs, _, terminated, truncated, _ = env.step(np.zeros(1))
        if terminated or truncated:
            break
    assert np.ptp(np.array(seen), axis=0).min() > 0.1  # the windows move along the path


@pytest.mark.parametrize("kwargs, match", [
    ({"observation": "v2"}, "unknown observation 'v2'; accepted: v0, v1"),
    ({"preview": (0.01, -0.002)}, "preview must be positive"),
    ({"observe_progress": 1}, "observe_progress must be a bool"),
    ({"curvature_windows": (0.0, 0.002, 0.001)}, "curvature_windows must be >= 2 increasing"),
    ({"curvature_windows": (0.001,)}, r"curvature_windows must be .* got \(0.001,\)"),
    ({"curvature_windows": (0.0, 0.01), "observation": "v0"}, "a v1 observation option"),
    ({"curvature_windows": (0.0, math.nan)}, "curvature_windows"),
])
def test_bad_observation_arguments_are_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CCCEnv(**kwargs)
