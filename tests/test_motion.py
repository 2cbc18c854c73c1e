import math

import numpy as np
import pytest

from contour_gym import motion
from contour_gym.motion import IP, IS, Interpolator, build_program, interp_tick
from contour_gym.paths import line

NO_LAW = (np.zeros(1), np.zeros(1))


def profile(length, interp, ts=1e-3, n=None, changes=None, path=None, in_position=True):
    """Run the interpolator kernel; returns arrays s, v, a per tick and the done tick."""
    path = path or line((0.0, 0.0), (length, 0.0))
    prog = build_program(path, interp, ts).arrays()
    p = interp.params(1)
    st = motion.initial_state(1)
    n = n or int(10 * path.length / interp.feedrate / ts) + 1000
    s, v, a = [], [], []
    for k in range(n):
        if changes and k in changes:
            p[0, IP.ovr] = changes[k] / interp.feedrate
        interp_tick(p, st, 0, k, ts, path.table.s0, prog, NO_LAW, 1.0, in_position)
        s.append(st[0, IS.s])
        v.append(st[0, IS.v])
        a.append(st[0, IS.a])
        if st[0, IS.done] >= 0:
            break
    return np.array(s), np.array(v), np.array(a), st[0, IS.done]


def test_constant_feedrate_reproduces_time_parameterised_circle():
    # 000: x = R cos(w t), y = R sin(w t) with w = F / R; no ramp (accel = inf)
    R, F, ts = 0.01, 0.01 * math.pi, 1e-3
    s, _, _, done = profile(2 * math.pi * R, Interpolator(F), ts)
    t = np.arange(len(s)) * ts + ts
    ref = np.column_stack([R * np.cos(s / R), R * np.sin(s / R)])
    paper = np.column_stack([R * np.cos(F / R * t), R * np.sin(F / R * t)])
    assert np.max(np.abs(ref[:-1] - paper[:-1])) < 1e-9
    assert done * ts == pytest.approx(2.0, abs=ts)


def test_ramped_start_is_the_paper_reference_delayed_by_half_the_ramp():
    R, F, A, ts = 0.02, 0.05, 0.5, 1e-3
    s, v, _, _ = profile(2 * math.pi * R, Interpolator(F, accel=A), ts)
    k_end = int(np.argmax(v >= F))  # first tick at full speed
    t = (np.arange(len(s)) + 1) * ts
    shift = t[k_end] - s[k_end] / F
    assert shift == pytest.approx(F / (2 * A), abs=ts)
    cruise = slice(k_end, k_end + 1500)
    ref = R * np.cos(s[cruise] / R)
    paper = R * np.cos(F / R * (t[cruise] - shift))
    assert np.max(np.abs(ref - paper)) < 1e-9


def test_stop_ramp_ends_at_path_end_at_rest_within_limits():
    L, A, ts = 0.05, 0.5, 1e-3
    s, v, a, done = profile(L, Interpolator(0.04, accel=A), ts)
    assert s[-1] == L and v[-1] == 0.0 and done == len(s) - 1
    assert np.all(np.diff(s) >= 0)
    assert np.max(np.abs(np.diff(np.concatenate([[0.0], v])))) <= A * ts * (1 + 1e-9) + 1e-12


def test_jerk_limit_is_respected():
    L, A, J, ts = 0.05, 0.5, 20.0, 1e-3
    s, v, a, done = profile(L, Interpolator(0.04, accel=A, jerk=J), ts)
    assert np.max(np.abs(np.diff(np.concatenate([[0.0], a])))) <= J * ts * (1 + 1e-9)
    assert s[-1] == L and done >= 0


def test_feedrate_change_follows_accel_limit():
    L, A, ts = 0.2, 0.5, 1e-3
    s, v, _, _ = profile(L, Interpolator(0.02, accel=A), ts, changes={200: 0.06})
    assert v[199] == pytest.approx(0.02)
    k = 200 + int(math.ceil((0.06 - 0.02) / (A * ts)))
    assert v[k - 5] < 0.06 and v[k + 1] == pytest.approx(0.06)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(feedrate=0.0),
        dict(feedrate=float("nan")),
        dict(feedrate=0.1, accel=-1.0),
        dict(feedrate=0.1, jerk=0.0),
    ],
)
def test_bad_interpolator_settings(kwargs):
    with pytest.raises(ValueError):
        Interpolator(**kwargs)
