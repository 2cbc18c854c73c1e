"""Every batch member on its own path: the loop's path bank and envs on random paths."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import VectorEnv
from numba.core import event

import contour_gym  # noqa: F401  (registers the ids)
from contour_gym import make_scenario
from contour_gym.envs._paths import travel_box
from contour_gym.loop import ServoLoop
from contour_gym.paths import Path, load, random_path
from contour_gym.presets import get_preset

PRESET = "xy_dc_servo"
SHORT = {"length": (0.015, 0.03)}  # short paths: short episodes
# the rig with encoder noise: each member's noise stream must follow it onto its own path
NOISY = {"preset": PRESET, "stage": {"axes": {"x": {"noise_std": 2e-7},
                                              "y": {"noise_std": 2e-7}}}}


def _paths() -> tuple[Path, Path]:
    rng = np.random.default_rng(4)
    plain = random_path(rng, "polyline", length=0.02, within=((-0.1, 0.1), (-0.1, 0.1)))
    fed = random_path(rng, "cam", length=0.025, feed_range=(0.01, 0.04))
    return plain, fed


def _loop(path: Path, batch: int) -> ServoLoop:
    sc = make_scenario(NOISY, path)
    return sc.loop(batch_size=batch, ccc_gains=sc.preset.ccc_gains.as_tuple(), record=True)


def _compiles(fn: Any) -> list[str]:
    with event.install_recorder("numba:compile") as rec:
        fn()
    return [ev.data["dispatcher"].py_func.__qualname__ for _, ev in rec.buffer if ev.is_start]


def test_members_on_different_paths_equal_single_loops_bit_for_bit():
    a, b = _paths()
    pair = _loop(a, 3)
    pair.set_paths([a, b, a])  # the kernel carves a, then b, then a again
    assert pair.paths == (a, b, a) and not pair.shares_path
    np.testing.assert_array_equal(pair.path_lengths, [a.length, b.length, a.length])
    pair.reset([11, 12, 13])
    assert pair.stage.is_random  # rig noise drawn
    both = pair.run(max_time=4.0)
    singles = []
    for path, seed in ((a, 11), (b, 12), (a, 13)):
        one = _loop(path, 1)
        one.reset([seed])
        singles.append((one.run(max_time=4.0), one.trace()))
    trace = pair.trace()
    for i, (metrics, tr) in enumerate(singles):
        assert both["cycle_time"][i] < np.inf  # arrived: a real run, not a cut-off
        for key, value in metrics.items():
            np.testing.assert_array_equal(both[key][i], value[0], err_msg=key)
        n = tr.t.shape[0]
        for field in ("s", "v", "r", "x", "u", "eps", "eps_est"):
            np.testing.assert_array_equal(getattr(trace, field)[i, :n], getattr(tr, field)[0],
                                          err_msg=field)
        assert np.all(np.isnan(trace.x[i, n:]))  # nothing recorded after its end
    assert pair.planned_time() == max(pair.planned_time(member=m) for m in (0, 1, 2))


def test_set_paths_compiles_nothing():
    a, b = _paths()
    loop = _loop(a, 3)
    loop.set_paths([a, b, a])
    loop.reset(0)
    loop.step(20)  # warm-up: the kernel and the path evaluations
    rng = np.random.default_rng(9)
    others = [random_path(rng, fam, length=0.05) for fam in ("spline", "polyline", "rose")]
    counts = [p.table.n_segments for p in (a, b, *others)]
    assert len(set(counts)) > 2  # other segment counts, other lengths

    def change() -> None:
        loop.set_paths(others)
        loop.reset(1)
        loop.step(20)
        loop.set_paths(b, members=[1])
        loop.reset(2, members=[1])
        loop.step(20)

    assert _compiles(change) == []
    assert loop.paths == (others[0], b, others[2])
    assert loop.start_positions(1) == pytest.approx(b.point(0.0))


def test_time_law_paths_are_shared_only():
    a, _ = _paths()
    timed = load("three_leaf")
    loop = _loop(a, 2)
    with pytest.raises(ValueError, match="time law"):
        loop.set_paths([timed, a])
    loop.set_paths(timed)  # every member on it: fine
    assert loop.shares_path and loop.path is timed
    with pytest.raises(ValueError, match="time law"):
        loop.set_paths(a, members=[0])
    with pytest.raises(ValueError, match="one path or 2 paths"):
        loop.set_paths([a])


def _within_travel(path: Path) -> bool:
    stage = get_preset(PRESET).stage
    points = path.point(np.linspace(0.0, path.length, 400))
    for j in range(2):
        lo, hi = stage.axes[stage.contours[0].axes[j]].travel
        if not (np.all(points[:, j] >= lo) and np.all(points[:, j] <= hi)):
            return False
    box = np.array(travel_box(stage))
    return bool(np.all(points >= box[:, 0]) and np.all(points <= box[:, 1]))


def _episode(env: Any, seed: int, steps: int) -> tuple[Path, list[Any]]:
    obs, _ = env.reset(seed=seed)
    path = env.unwrapped.task.loop.path
    out = [obs]
    for _ in range(steps):
        obs, reward, term, trunc, _ = env.step(np.zeros(env.action_space.shape))
        out.append((obs, reward, term, trunc))
        if term or trunc:
            break
    return path, out


def test_single_env_on_random_paths():
    kw = {"path": "random", "path_options": SHORT, "decision_ticks": 50}
    env1, env2 = gym.make("contour_gym/CCC-v0", **kw), gym.make("contour_gym/CCC-v0", **kw)
    p1, run1 = _episode(env1, 3, 8)
    p2, run2 = _episode(env2, 3, 8)
    np.testing.assert_array_equal(p1.table.data, p2.table.data)
    assert data_equivalence(run1, run2)
    drawn = [p1] + [_episode(env1, None, 0)[0] for _ in range(3)]  # type: ignore[arg-type]
    assert len({p.table.data.tobytes() for p in drawn}) == 4  # each reset a new path
    assert all(_within_travel(p) for p in drawn)
    task = env1.unwrapped.task
    assert task.arrays["n_max"][0] == task._step_limit(0)  # its own path's step limit


def test_vector_env_members_equal_single_envs_on_random_paths():
    n, steps = 3, 40
    kw = {"path": "random", "path_options": {**SHORT, "family": "polyline"},
          "decision_ticks": 100}
    venv: VectorEnv = gym.make_vec("contour_gym/CCC-v0", num_envs=n, **kw)
    singles = [gym.make("contour_gym/CCC-v0", **kw).unwrapped for _ in range(n)]
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (steps, n, venv.single_action_space.shape[0]))
    vobs, _ = venv.reset(seed=7)
    obs = [env.reset(seed=7 + i)[0] for i, env in enumerate(singles)]
    paths = venv.unwrapped.task.loop.paths
    assert len({p.table.data.tobytes() for p in paths}) == n
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(paths[i].table.data, env.task.loop.path.table.data)
        assert data_equivalence({k: v[i] for k, v in vobs.items()}, obs[i])
    done, resets = np.zeros(n, bool), 0
    for k in range(steps):
        vobs, vrew, vterm, vtrunc, _ = venv.step(actions[k])
        for i, env in enumerate(singles):
            if done[i]:  # next-step autoreset: reset instead of stepped (a new path)
                o, r, t1, t2 = env.reset()[0], 0.0, False, False
                resets += 1
            else:
                o, r, t1, t2, _ = env.step(actions[k, i])
            done[i] = t1 or t2
            assert data_equivalence({key: v[i] for key, v in vobs.items()}, o), (k, i)
            assert (vrew[i], vterm[i], vtrunc[i]) == (r, t1, t2), (k, i)
    assert resets > 0  # members drew new paths on the way


def test_keep_paths_restarts_ended_members_on_their_paths_and_leaves_first_episodes_alone():
    kw = {"path": "random", "path_options": {**SHORT, "family": "polyline"},
          "decision_ticks": 100}
    runs = {}
    for keep in (False, True, None):  # None: keep_paths, then a full reset without it
        venv: VectorEnv = gym.make_vec("contour_gym/CCC-v0", num_envs=2, **kw)
        task = venv.unwrapped.task
        venv.reset(seed=3, options={"keep_paths": keep is not False})
        if keep is None:
            venv.reset(seed=3)
        first = list(task.loop.paths)
        rewards, starts = [], []
        for _ in range(60):  # past each member's first episode
            _, reward, term, trunc, _ = venv.step(np.zeros((2, venv.single_action_space.shape[0])))
            rewards.append(reward.copy())
            starts.append(term | trunc)
        ended = np.logical_or.reduce(starts)
        assert ended.all()
        same = [a is b for a, b in zip(first, task.loop.paths, strict=True)]
        assert same == ([True, True] if keep else [False, False])
        runs[keep] = np.array(rewards), np.argmax(starts, axis=0)
    with pytest.raises(ValueError, match=r"keep_paths.*got 1"):
        venv.reset(seed=3, options={"keep_paths": 1})
    (plain, ends), (kept, kept_ends) = runs[False], runs[True]
    np.testing.assert_array_equal(ends, kept_ends)
    for b, end in enumerate(ends):  # each member's first episode, bit for bit
        np.testing.assert_array_equal(plain[: end + 1, b], kept[: end + 1, b])


def test_feedrate_env_random_paths_are_programmed_within_the_default_range():
    env = gym.make("contour_gym/Feedrate-v0", path="random", path_options=SHORT)
    top = env.unwrapped.task.preset.max_feedrate
    for seed in range(3):
        env.reset(seed=seed)
        loop = env.unwrapped.task.loop
        feeds = loop.path.segment_feedrates
        assert np.all((feeds >= 0.3 * top) & (feeds <= top))
        program = loop.programs[0]
        assert np.all(program.feed[program.cutting] == feeds)  # run at its own F words
        assert env.unwrapped.task.arrays["f_nom"][0] == pytest.approx(feeds.max())


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"path": "random", "path_options": {"lenght": 0.1}}, "lenght"),
    ({"path": "random", "path_options": {"rng": 1, "dim": 2}}, r"\['dim', 'rng'\]"),
    ({"path": "circle_r10", "path_options": {"length": 0.1}}, "path='random'"),
    ({"path": "random", "laps": 2}, "laps"),
])
def test_bad_path_options_are_refused(kwargs: dict[str, Any], match: str):
    with pytest.raises(ValueError, match=match):
        gym.make("contour_gym/CCC-v0", **kwargs)


def _same_path(a: Path, b: Path) -> bool:
    return a.name == b.name and all(
        np.array_equal(getattr(a.table, k), getattr(b.table, k)) for k in ("kind", "s0", "data"))


def test_kept_draws_equal_fresh_draws_and_leave_the_generator_where_a_draw_would():
    # the env's draws are kept per process (draw_path): a repeated draw is the same path,
    # and the generator continues exactly as after a fresh draw
    from contour_gym.envs._paths import _draw, draw_path

    stage = get_preset("xy_dc_servo").stage
    options = {"within": [[-0.04, 0.04], [-0.03, 0.03]], "family": "lissajous"}
    fresh = np.random.default_rng(11)
    expected = random_path(fresh, dim=2, **options)
    _draw.cache_clear()
    for hits in (0, 1):
        rng = np.random.default_rng(11)
        path = draw_path(rng, stage, options)
        assert _draw.cache_info().hits == hits
        assert _same_path(path, expected)
        assert rng.bit_generator.state == fresh.bit_generator.state
    other = draw_path(np.random.default_rng(12), stage, options)  # another state: drawn anew
    assert _draw.cache_info().misses == 2 and not _same_path(other, expected)
