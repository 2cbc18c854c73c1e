import math

import numpy as np
import pytest

from contour_gym import motion
from contour_gym.motion import IP, IS, Interpolator, build_program, interp_tick
from contour_gym.paths import line, polyline

NO_LAW = (np.zeros(1), np.zeros(1))


def profile(length, interp, ts=1e-3, n=None, changes=None, path=None, in_position=True,
            path_control=None):
    """Run the interpolator kernel; returns arrays s, v, a per tick and the done tick."""
    path = path or line((0.0, 0.0), (length, 0.0))
    prog = build_program(path, interp, ts, path_control=path_control).arrays()
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


def _s_curve_time(length, feed, accel, jerk):
    # rest to rest at the feed: each ramp from and to zero acceleration takes T, half of it
    # lost against cruising at the feed (T = 2 sqrt(F / J) or F / A + A / J)
    ramp = 2 * math.sqrt(feed / jerk) if feed <= accel**2 / jerk else feed / accel + accel / jerk
    return length / feed + ramp


@pytest.mark.parametrize(("feed", "jerk"), [(0.04, 20.0), (0.0233, 10.0), (0.2, 10.0)])
def test_a_jerk_limited_stop_takes_the_s_curves_time(feed, jerk):
    # the stop joins an S-curve and arrives: before, it crept up to the end point for 1-2 s
    # (a braking curve ~ room / 0.1 s near the end)
    L, A, ts = 0.1, 0.5, 1e-3
    s, v, a, done = profile(L, Interpolator(feed, accel=A, jerk=jerk), ts)
    ideal = _s_curve_time(L, feed, A, jerk)
    assert ideal - 2 * ts <= done * ts <= 1.12 * ideal
    assert s[-1] == L and v[-1] == 0.0
    assert np.max(np.abs(np.diff(np.concatenate([[0.0], a])))) <= jerk * ts * (1 + 1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_jerk_limited_moves_keep_jerk_and_junction_speeds(seed):
    # polylines under exact stops and blending, with a time constant or an override change
    # mid-move: every tick within J, every junction met (within one tick's jerk, J ts^2),
    # the end reached; a reference still speeding up plans its stop from where its
    # acceleration can end (the last move, 2 mm, is short of its feed at most feeds; seeds 0-3
    # all fail without it, measured)
    rng = np.random.default_rng(seed)
    ts = 1e-3
    pts = np.cumsum(rng.uniform(-0.02, 0.02, size=(5, 2)), axis=0)
    pts[-1] = pts[-2] + [0.002, 0.0]
    path = polyline(pts)
    interp = Interpolator(float(rng.uniform(0.02, 0.2)), accel=float(rng.choice([0.5, 2.0])),
                          jerk=float(rng.choice([5.0, 20.0, 100.0])),
                          time_constant=float(rng.choice([0.0, 0.1])))
    mode = ("G61", "G64")[seed % 2]
    s, v, a, done = profile(path.length, interp, ts, path=path, path_control=mode,
                            changes={300: interp.feedrate * rng.uniform(0.5, 1.5)})
    assert done >= 0 and s[-1] == path.length and v[-1] == 0.0
    assert np.max(np.abs(np.diff(np.concatenate([[0.0], a])))) <= interp.jerk * ts * (1 + 1e-9)
    vj = build_program(path, interp, ts, path_control=mode).vj
    at = np.searchsorted(s, path.table.s0[1:-1] - 1e-12)
    assert np.all(v[at] <= vj[:-1] + interp.jerk * ts**2)


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
        dict(feedrate=0.1, time_constant=-0.1),
    ],
)
def test_bad_interpolator_settings(kwargs):
    with pytest.raises(ValueError):
        Interpolator(**kwargs)


@pytest.mark.parametrize("feed", [0.01, 0.04])
def test_a_time_constant_makes_every_speed_change_take_it_whatever_the_feed(feed):
    # a CNC's acc/dec time constant T: the speed ramps at F / T, so start and stop take T
    T, ts = 0.1, 1e-3
    s, v, a, done = profile(0.05, Interpolator(feed, accel=10.0, time_constant=T), ts)
    moving = np.flatnonzero(v > 0)
    k_full = int(np.argmax(v >= feed * (1 - 1e-12)))
    assert k_full * ts == pytest.approx(T, abs=2 * ts)
    assert np.max(np.abs(a)) == pytest.approx(feed / T, rel=1e-9)
    braking = np.flatnonzero(a < 0)
    assert (braking[-1] - braking[0] + 1) * ts == pytest.approx(T, abs=2 * ts)
    assert s[-1] == 0.05 and v[-1] == 0.0 and done == moving[-1] + 1


def test_a_time_constant_brakes_at_the_feed_it_cruised_at_when_the_feed_drops():
    # the override falls mid-move: the deceleration keeps the rate of the feed it left
    T, ts = 0.1, 1e-3
    _, v, a, _ = profile(0.2, Interpolator(0.04, accel=10.0, time_constant=T), ts,
                         changes={600: 0.01})
    assert a[601] == pytest.approx(-0.04 / T, rel=1e-9)
    assert v[700] == pytest.approx(0.01)


def test_an_explicit_path_control_keeps_a_parts_mandatory_stops():
    from contour_gym.paths import from_gcode

    part = from_gcode("G21 G90 G64\nG0 X0 Y0\nG1 X10 F600\nY10\nG0 X20\nM5\nG1 Y20\nM30")
    interp = Interpolator(0.01, accel=1.0, rapid_rate=0.05)
    own = build_program(part, interp, 1e-3)
    for mode in ("none", "G64", "G61.1"):
        prog = build_program(part, interp, 1e-3, path_control=mode)
        assert np.all(prog.vj[part.mandatory_stops] == 0.0), mode
        assert part.mandatory_stops.sum() >= 3
    # under G64 the cut's own corner (X10 -> Y10) blends, as in the part's own program
    corner = int(np.flatnonzero(~part.rapid)[0])
    assert own.vj[corner] > 0.0
    assert build_program(part, interp, 1e-3, path_control="G64").vj[corner] > 0.0
    assert build_program(part, interp, 1e-3, path_control="G61").vj[corner] == 0.0


def test_curvature_caps_sample_each_segment_as_one_by_one():
    # segment_max_curvature evaluates every segment's 9 samples at once: the same numbers as a
    # segment-by-segment evaluation, bit for bit (the last sample just before the end)
    from contour_gym.motion import segment_max_curvature
    from contour_gym.paths import random_path

    path = random_path(np.random.default_rng(5), "rose")
    t = path.table
    one_by_one = [np.max(path.curvature(np.r_[a + np.linspace(0.0, n, 9)[:-1],
                                               np.nextafter(a + n, -np.inf)]))
                  for a, n in zip(t.s0[:-1], np.diff(t.s0), strict=True)]
    assert np.array_equal(segment_max_curvature(path), one_by_one)


def test_a_line_into_an_arc_keeps_its_own_curvature_cap():
    # a segment's samples are its own: at its end a path gives the next segment's curvature,
    # and a line into a 10 mm arc ran its whole length at the arc's centripetal cap
    from contour_gym.motion import segment_max_curvature
    from contour_gym.paths import from_gcode

    part = from_gcode("G21 G90\nG1 X10 F600\nG3 X20 Y10 R10\nG2 X25 Y15 R5\nG1 Y30\nM30")
    assert np.allclose(segment_max_curvature(part), [0.0, 100.0, 200.0, 0.0], atol=1e-9)
    prog = build_program(part, Interpolator(0.01, accel=1.0), 1e-3, path_control="G64")
    assert math.isinf(prog.vcap[0]) and math.isinf(prog.vcap[3])
    assert prog.vcap[1] == pytest.approx(0.1) and prog.vcap[2] == pytest.approx(math.sqrt(0.005))


@pytest.mark.parametrize("override", [1.0, 0.3])
def test_a_time_constant_stops_at_the_end_of_many_short_segments_at_rest(override):
    # 500 collinear segments of 0.02 mm: braking at F ovr / T takes more of them than the
    # look-ahead's fixed window held (16); the reference must still arrive at rest, never
    # stepping to rest from speed (the axes overshot the end point by 110 um at 0.3)
    from contour_gym.paths import polyline

    T, ts, feed = 0.2, 1e-3, 0.03
    pts = np.stack([np.linspace(0.0, 0.01, 501), np.zeros(501)], axis=1)
    interp = Interpolator(feed, accel=1.0, time_constant=T)
    path = polyline(pts)
    prog = build_program(path, interp, ts).arrays()
    p = interp.params(1)
    p[0, IP.ovr] = override
    st = motion.initial_state(1)
    v = []
    for k in range(20000):
        interp_tick(p, st, 0, k, ts, path.table.s0, prog, NO_LAW, 1.0, True)
        v.append(st[0, IS.v])
        if st[0, IS.done] >= 0:
            break
    v = np.array(v)
    assert st[0, IS.done] >= 0 and st[0, IS.s] == pytest.approx(0.01, abs=1e-12)
    rate = feed * override / T
    assert np.max(np.abs(np.diff(v))) / ts <= rate * (1 + 1e-9)
    assert v.max() == pytest.approx(feed * override)


def test_a_time_constant_keeps_its_braking_rate_while_the_override_falls():
    # the override falls through a stop's deceleration (a feedrate agent turning it down):
    # the stop still brakes at the rate it started at, and arrives at rest (before, the rate
    # followed F ovr / T down, the plan fell behind and the reference stepped to rest)
    T, ts, feed = 0.1, 1e-3, 0.04
    changes = {k: feed * max(0.2, 1.0 - 0.004 * (k - 1180)) for k in range(1180, 3000)}
    s, v, a, done = profile(0.05, Interpolator(feed, accel=10.0, time_constant=T), ts,
                            changes=changes)
    assert done >= 0 and s[-1] == pytest.approx(0.05, abs=1e-12) and v[-1] == 0.0
    assert np.max(np.abs(np.diff(v))) / ts <= feed / T * (1 + 1e-9)


def test_a_time_constant_keeps_its_braking_rate_while_the_override_rises():
    # the override rises to 2.5x once the stop at the path end is under way (what 004's general
    # feedrate agent learned to do): the stop is made at the rate it started at, tick for tick
    # as with the override left alone (before, the rate rose with F ovr / T and the reference
    # braked later at 2.5x the rate: a harder stop, more error at it)
    T, ts, feed = 0.1, 1e-3, 0.04
    interp = Interpolator(feed, accel=10.0, time_constant=T)
    s0, v0, _, done0 = profile(0.05, interp, ts)
    start = int(np.flatnonzero(np.diff(v0) < 0)[0]) + 1  # the first braking tick
    changes = {k: feed * min(2.5, 1.0 + 0.1 * (k - start)) for k in range(start, start + 100)}
    s, v, _, done = profile(0.05, interp, ts, changes=changes)
    assert done == done0 and np.array_equal(s, s0) and np.array_equal(v, v0)
    assert np.max(-np.diff(v)) / ts <= feed / T * (1 + 1e-9)
    # a rise before the stop is planned still counts: the reference speeds up to it
    s, v, _, _ = profile(0.05, interp, ts, changes={start - 200: 2 * feed})
    assert v.max() > feed * 1.5


def test_a_time_constant_keeps_its_braking_rate_into_a_slower_block_before_a_stop():
    # 50 mm at 6000 mm/min, then 4 mm at 3600 mm/min to the end: the stop is planned at
    # 0.1 / T; in the slower block F / T falls to 0.06 / T, at which the 4 mm are too short to
    # stop from 60 mm/s, so the rate holds (before, the reference stepped to rest from 35 mm/s)
    from contour_gym.paths import from_gcode

    path = from_gcode("G21 G90 G17\nG1 X50 F6000\nG1 X54 F3600\nM2\n")
    T, ts = 0.2, 1e-3
    s, v, _, done = profile(0.0, Interpolator(0.1, accel=10.0, time_constant=T), ts, path=path)
    assert done >= 0 and s[-1] == pytest.approx(0.054, abs=1e-12) and v[-1] == 0.0
    assert v.max() == pytest.approx(0.1)
    assert np.max(-np.diff(v)) / ts <= 0.1 / T * (1 + 1e-9)


@pytest.mark.parametrize("action", [-0.2, 0.3])
def test_a_feedrate_task_s_reference_never_brakes_harder_than_its_time_constant(action):
    # random paths of the feedrate task (004's machine: T = 0.212 s, programmed feeds that
    # change from block to block) under an override that falls or rises: the reference's speed
    # never falls faster than the machine's F_max / T, nor steps to rest. Before the braking
    # rate was kept through a stop, path 1007 at -0.2 stepped to rest from 23 mm/s (111 um)
    from agents.evaluate import make_vector_env, run_episodes
    from agents.policies import make

    policy = make("constant", action=[action])
    venv = make_vector_env("contour_gym/Feedrate-v1", policy, num_envs=8, record=True,
                           path="random")
    out, _ = run_episodes(venv, policy, seed=1000)
    loop = venv.unwrapped.task.loop
    p = loop.ip_p
    rate = np.minimum(p[:, IP.a_max], p[:, IP.f_max] / p[:, IP.t_acc])
    trace = loop.trace()
    v, ts = trace.v, trace.t[1] - trace.t[0]
    assert np.all(out["finished"]) and np.all(np.isfinite(rate))
    for b in range(8):
        vb = v[b][np.isfinite(v[b])]
        assert np.max(-np.diff(vb)) <= rate[b] * ts * (1 + 1e-9), b


def test_a_time_constant_plans_each_block_at_its_own_feed():
    # a block's F word sets its own corners: raising the last block's feed leaves the first
    # corner's junction speed as it was, and that corner is planned at F / T of its blocks
    from contour_gym.paths import from_gcode

    def plan(last_feed):
        part = from_gcode(f"G21 G90 G64 P0.01\nG0 X0 Y0\nG1 X10 F300\nY10\nX0 F{last_feed}\nM30")
        interp = Interpolator(last_feed / 60000.0, accel=1.0, time_constant=0.2,
                              max_feedrate=0.1)
        return part, build_program(part, interp, 1e-3)

    part, slow = plan(300)
    _, fast = plan(3000)
    corner = int(np.flatnonzero(~part.rapid)[0])  # X10 -> Y10
    assert fast.vj[corner] == slow.vj[corner] > 0.0
    a = 0.005 / 0.2  # 300 mm/min over T
    t = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    assert slow.vj[corner] == pytest.approx(motion.junction_speed(*t, a, 1e-5))
    assert fast.vj[corner + 1] == slow.vj[corner + 1]  # Y10 -> X0: the slower block's rate


def test_a_starting_override_runs_as_the_program_with_its_feeds_scaled():
    # on a machine with an acc/dec time constant, override k and every F word times k are
    # one motion: the look-ahead plans both at k F / T
    from contour_gym import simulate
    from contour_gym.paths import random_path

    path = random_path(np.random.default_rng(3), "polyline")
    feed, k = 0.02, 1.7
    kw = dict(path_control="G64", path_tolerance=5e-6, ideal=True)
    scaled = simulate("xy_servo_coulomb", path, feedrate=feed * k, **kw)
    override = simulate("xy_servo_coulomb", path, feedrate=feed, feedrate_override=k, **kw)
    for key in ("cycle_time", "max_contour_error"):
        assert override[key] == pytest.approx(scaled[key], rel=1e-6), key
