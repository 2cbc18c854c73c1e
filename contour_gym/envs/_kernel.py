"""Kernel template: one env decision for every member in one compiled call.

apply the actions (the task's slot ``TASK_APPLY``: CCC gains, feed override, ...) -> run the
ticks (the loop's own specialised ``run_members``, slot ``RUN_MEMBERS``) -> reward components,
reward (slot ``REWARD``), the failure rule, termination and truncation -> observations (the
task's own columns last: slot ``TASK_OBSERVE``). A Python reward replaces the middle step:
:func:`env_step` then stops after the components and :func:`apply_rewards` finishes once Python
has filled ``raw``.
"""

from __future__ import annotations

import math

import numba

from contour_gym._blob import borrow
from contour_gym._envstate import CURVATURE_SCALE, EC, OBSERVATION_V0, env_arrays, put
from contour_gym.jit.slots import REWARD, RUN_MEMBERS, TASK_APPLY, TASK_OBSERVE
from contour_gym.loop.member import (
    ARRIVED,
    FAILED,
    loop_and_members,
    member_path,
    members,
    next_path,
    path_bank,
)
from contour_gym.paths._geom import eval_path, eval_segment, find_segment
from contour_gym.rewards import RC

TRACKING_SCALE = 1e-3  # m: v0 observes tracking errors in mm (v1: in tolerances)
CORNER_ANGLE = 0.02  # rad: a segment join turning more than this is a corner (v1)
WINDOW_STEP = 1.25e-4  # m: curvature windows (v1's curvature_peak) are sampled this often


@numba.njit(cache=True, inline="always")
def _apply(m, env, ec, lo, hi):
    # clip each live member's action to [-1, 1]; the task sets what it acts on (m: the loop's
    # Members record, contour_gym.loop.member)
    n_c = m.contour_axes.shape[0]
    for b in range(lo, hi):
        if env.skip[b] != 0.0:
            continue
        env.s_before[b] = m.s[b]
        for c in range(n_c):
            env.eps_prev[b, c] = m.estimate[b, c]
        for j in range(env.action.shape[1]):
            env.action[b, j] = min(max(env.action[b, j], -1.0), 1.0)
        TASK_APPLY(int(ec[EC.task]), m, env, ec, b)


@numba.njit(cache=True, inline="always")
def _components(m, env, ec, b):
    # the decision's reward components (contour_gym.rewards); True when the member failed
    n_c, n_a = m.contour_axes.shape[0], m.position.shape[1]
    tol = ec[EC.tol]
    total, count, worst = 0.0, 0.0, 0.0
    for c in range(n_c):
        total += m.error_sum[b, c]
        count += m.ticks[b, c]
        worst = max(worst, m.error_peak[b, c])
    ticks = m.ticks[b, 0]
    chatter = 0.0
    for a in range(n_a):
        chatter += m.effort_travel[b, a] / (max(ticks, 1.0) * m.effort_max[b, a])
    comp = env.comp
    comp[b, RC.contour] = total / max(count, 1.0) / tol
    comp[b, RC.peak] = worst / tol
    comp[b, RC.chatter] = chatter / n_a
    comp[b, RC.progress] = (m.s[b] - env.s_before[b]) / env.nominal[b]
    comp[b, RC.excess] = max(worst / tol - 1.0, 0.0)
    comp[b, RC.record] = max(worst - env.peak[b], 0.0) / tol
    env.peak[b] = max(env.peak[b], worst)
    return m.status[b] == FAILED or worst > ec[EC.hard]


@numba.njit(cache=True)
def apply_rewards(env_floats, env_layout, floats, float_layout, ints, int_layout, ec):
    """Clip ``raw`` rewards, apply the failure rule, count steps, flag ends (env docstrings).

    Failure rule: a failed member's terminal reward brings its episode return to
    ``n_max r_lo - penalty``, below any completed episode's (each of at most ``n_max`` steps
    earns at least ``r_lo <= 0``).
    """
    # borrowed (contour_gym._blob.borrow): the caller keeps the blobs alive
    m = members(borrow(floats), float_layout, borrow(ints), int_layout)
    env = env_arrays(borrow(env_floats), env_layout)
    _rewards(m, env, ec, 0, env.reward.shape[0])


@numba.njit(cache=True, inline="always")
def _rewards(m, env, ec, lo, hi):
    # apply_rewards on the views of members lo:hi
    r_lo, r_hi = ec[EC.r_lo], ec[EC.r_hi]
    for b in range(lo, hi):
        if env.skip[b] != 0.0:
            env.reward[b], env.terminated[b], env.truncated[b] = 0.0, 0.0, 0.0
            continue
        r = min(max(env.raw[b], r_lo), r_hi)
        if env.failure[b] != 0.0:
            r = env.n_max[b] * r_lo - ec[EC.penalty] - env.ret[b]
        env.reward[b] = r
        env.ret[b] += r
        env.steps[b] += 1.0
        ended = env.failure[b] != 0.0 or m.status[b] == ARRIVED
        env.terminated[b] = 1.0 if ended else 0.0
        env.truncated[b] = 1.0 if (not ended and env.steps[b] >= env.n_max[b]) else 0.0


@numba.njit(cache=True)
def _point(kind, s0, data, s):
    # called, not inlined: the observation evaluates the path at several places
    return eval_path(kind, s0, data, s)


@numba.njit(cache=True, inline="always")
def _curvature(path, s, dim):
    _, _, _, tx, ty, tz, kx, ky, kz = _point(path.kind, path.s0, path.data, s)
    if dim == 2:  # signed, + = turning left
        return (tx * ky - ty * kx) / max((tx * tx + ty * ty) ** 1.5, 1e-300)
    return math.sqrt(kx * kx + ky * ky + kz * kz)


@numba.njit(cache=True)
def _tangent(kind, data, i, t):
    # called, not inlined: segment i's unit tangent at local arc length t
    r = eval_segment(kind, data, i, t)
    norm = max(math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5]), 1e-300)
    return r[3] / norm, r[4] / norm, r[5] / norm


@numba.njit(cache=True, inline="always")
def _turn(ax, ay, az, bx, by, bz, dim):
    # the angle from unit tangent a to unit tangent b, rad (signed in 2-D, + = left)
    dot = min(max(ax * bx + ay * by + az * bz, -1.0), 1.0)
    if dim == 2:
        return math.atan2(ax * by - ay * bx, dot)
    return math.acos(dot)


@numba.njit(cache=True, inline="always")
def _next_corner(path, s, horizon, dim):
    # (distance, turning angle) of the first segment join within ``horizon`` ahead of s whose
    # tangent turns by more than CORNER_ANGLE; (horizon, 0) when there is none
    n = path.kind.shape[0]
    j = find_segment(path.s0, s) + 1
    while j < n and path.s0[j] <= s + horizon:
        if path.s0[j] > s:
            ax, ay, az = _tangent(path.kind, path.data, j - 1, path.s0[j] - path.s0[j - 1])
            bx, by, bz = _tangent(path.kind, path.data, j, 0.0)
            angle = _turn(ax, ay, az, bx, by, bz, dim)
            if abs(angle) > CORNER_ANGLE:
                return path.s0[j] - s, angle
        j += 1
    return horizon, 0.0


@numba.njit(cache=True, inline="always")
def _observe_general(m, path, env, ec, b, col, s, length, dim):
    # the v1 observation after the contour errors (the env docstrings' table): nothing that
    # names the path or the place on it, only what lies ahead
    n_a, tol, obs = m.measured.shape[1], ec[EC.tol], env.obs
    for a in range(n_a):
        col = put(obs, b, col, (env.ref[b, a] - m.measured[b, a]) / tol)
    v = m.v[b]
    col = put(obs, b, col, v / path.feed[int(m.block[b])])
    col = put(obs, b, col, v / ec[EC.f_max])
    col = put(obs, b, col, m.override[b])
    _, _, _, ax, ay, az, _, _, _ = _point(path.kind, path.s0, path.data, s)
    col = put(obs, b, col, _curvature(path, s, dim) * CURVATURE_SCALE)
    for i in range(env.lookahead.shape[0]):
        col = put(obs, b, col, _curvature(path, min(s + env.lookahead[i], length), dim)
                  * CURVATURE_SCALE)
    for i in range(env.lookahead.shape[0]):
        _, _, _, bx, by, bz, _, _, _ = _point(path.kind, path.s0, path.data,
                                              min(s + env.lookahead[i], length))
        col = put(obs, b, col, _turn(ax, ay, az, bx, by, bz, dim) / math.pi)
    horizon = ec[EC.horizon]
    distance, angle = _next_corner(path, s, horizon, dim)
    col = put(obs, b, col, distance / horizon)
    col = put(obs, b, col, angle / math.pi)
    col = put(obs, b, col, min(length - s, horizon) / horizon)
    col = _observe_windows(path, env, b, col, s, length, dim)
    if ec[EC.progress_obs] != 0.0:
        col = put(obs, b, col, min(m.progress[b, 0], length) / length)
    return col


@numba.njit(cache=True, inline="always")
def _observe_windows(path, env, b, col, s, length, dim):
    # curvature_peak: per window [e_j, e_j+1] ahead, its peak curvature as
    # log10(1 + kappa x 1 m) / 4 (nothing with one edge: none)
    edges = env.windows
    for j in range(edges.shape[0] - 1):
        peak = _peak_curvature(path, s, edges[j], edges[j + 1], length, dim)
        col = put(env.obs, b, col, math.log10(1.0 + peak) / 4.0)
    return col


@numba.njit(cache=True)
def _peak_curvature(path, s, lo, hi, length, dim):
    # called, not inlined (one compile for every env step): the largest |curvature| from lo to
    # hi ahead of s, at both ends and every WINDOW_STEP between (curvature_peak, feedrate_limit)
    n = max(int(math.ceil((hi - lo) / WINDOW_STEP - 1e-9)), 1)
    peak = 0.0
    for k in range(n + 1):
        ahead = min(s + min(lo + k * WINDOW_STEP, hi), length)
        peak = max(peak, abs(_curvature(path, ahead, dim)))
    return peak


@numba.njit(cache=True)
def _curvature_limit(path, ec, s, length, dim, feed):
    # called, not inlined (one compile for every env step that observes): EnvConfig's
    # feedrate_limit, the override at which the block's programmed feed meets v^2 kappa = a_c
    # on the tightest curvature within reach (and the speed v_end within end_reach of the
    # path's end, if given), within [t_lo, t_mid]
    peak = _peak_curvature(path, s, 0.0, ec[EC.lim_reach], length, dim)
    speed = math.sqrt(ec[EC.lim_a] / max(peak, 1e-12))
    if length - s < ec[EC.lim_rend]:
        speed = min(speed, ec[EC.lim_vend])
    return min(max(speed / feed, ec[EC.t_lo]), ec[EC.t_mid])


@numba.njit(cache=True, inline="always")
def _observe_v0(m, path, env, ec, b, col, s, length, dim):
    # the v0 observation after the contour errors (the v0 ids' table)
    n_a, obs = m.measured.shape[1], env.obs
    for a in range(n_a):
        col = put(obs, b, col, (env.ref[b, a] - m.measured[b, a]) / TRACKING_SCALE)
    for a in range(n_a):
        col = put(obs, b, col, env.vel[b, a] / env.f_nom[b])
    col = put(obs, b, col, _curvature(path, s, dim) * CURVATURE_SCALE)
    for i in range(env.lookahead.shape[0]):
        ahead = min(s + env.lookahead[i], length)
        col = put(obs, b, col, _curvature(path, ahead, dim) * CURVATURE_SCALE)
    return put(obs, b, col, min(m.progress[b, 0], length) / length)


@numba.njit(cache=True, inline="always")
def _references(m, path, env, b, dim):
    s, v = m.s[b], m.v[b]
    px, py, pz, tx, ty, tz, _, _, _ = _point(path.kind, path.s0, path.data, s)
    for c in range(m.contour_axes.shape[0]):
        for j in range(dim):
            a = m.contour_axes[c, j]
            env.ref[b, a] = (px if j == 0 else (py if j == 1 else pz)) + m.contour_offset[c, j]
            env.vel[b, a] = (tx if j == 0 else (ty if j == 1 else tz)) * v


@numba.njit(cache=True, inline="always")
def _observe(m, path, env, ec, b):
    # member b's observation row (the env docstrings' table, in key order) on its own path
    # ``path``; the info's tracking errors and feedrate
    dim, length = int(ec[EC.dim]), path.length
    _references(m, path, env, b, dim)
    n_c, n_a = m.contour_axes.shape[0], m.position.shape[1]
    for a in range(n_a):
        env.track[b, a] = env.ref[b, a] - m.position[b, a]
    env.feedrate[b] = m.override[b] * path.feed[int(m.block[b])]
    tol, obs = ec[EC.tol], env.obs
    s = m.s[b]
    col = 0
    for c in range(n_c):
        col = put(obs, b, col, m.estimate[b, c] / tol)
    for c in range(n_c):
        col = put(obs, b, col, (m.estimate[b, c] - env.eps_prev[b, c]) / tol)
    if ec[EC.observation] == OBSERVATION_V0:
        col = _observe_v0(m, path, env, ec, b, col, s, length, dim)
    else:
        col = _observe_general(m, path, env, ec, b, col, s, length, dim)
    if ec[EC.lim_a] != 0.0:
        feed = path.feed[int(m.block[b])]
        env.prior[b] = _curvature_limit(path, ec, s, length, dim, feed)
    TASK_OBSERVE(int(ec[EC.task]), m, path, env, ec, b, col)


@numba.njit(cache=True, inline="always")
def _views(
    env_floats, env_layout, floats, float_layout, ints, int_layout, path_kinds, path_floats,
    path_layout, part,
):
    # the loop's views (with part's scratch) and its Members record, the path bank's and the
    # env's arrays, borrowed (the caller keeps the blobs alive: views of a borrowed blob count
    # no references, contour_gym._blob.borrow)
    loop, m = loop_and_members(borrow(floats), float_layout, borrow(ints), int_layout, part)
    bank = path_bank(borrow(path_kinds), borrow(path_floats), path_layout)
    return loop, m, bank, env_arrays(borrow(env_floats), env_layout)


@numba.njit(cache=True)
def observe(
    env_floats, env_layout, floats, float_layout, ints, int_layout, path_kinds, path_floats,
    path_layout, ec, which,
):
    """Write the observation rows of the members ``which`` (after a reset and every step)."""
    _, m, bank, env = _views(env_floats, env_layout, floats, float_layout, ints, int_layout,
                             path_kinds, path_floats, path_layout, 0)
    path, carved = member_path(bank, m.path_at, 0), 0
    for b in which:
        path, carved = next_path(bank, m.path_at, path, carved, b)
        _observe(m, path, env, ec, b)


@numba.njit(cache=True, inline="always")
def _finish(m, bank, env, ec, lo, hi):
    # members lo:hi's components, failure flags and (compiled reward) raw rewards; their
    # observations (each member on its own path: contour_gym.loop.member.next_path)
    path, carved = member_path(bank, m.path_at, lo), lo
    for b in range(lo, hi):
        if env.skip[b] == 0.0:
            failed = _components(m, env, ec, b)
            env.failure[b] = 1.0 if failed else 0.0
            if ec[EC.python_reward] == 0.0:
                env.raw[b] = REWARD(int(ec[EC.reward]), env.comp[b], env.weights)
        else:
            env.failure[b] = 0.0
        path, carved = next_path(bank, m.path_at, path, carved, b)
        _observe(m, path, env, ec, b)


@numba.njit(cache=True, nogil=True)
def env_step(
    env_floats, env_layout, ec, n, k0, config_row, floats, float_layout, ints, int_layout,
    path_kinds, path_floats, path_layout, noise, rec, lo, hi, part,
):
    """One env decision of members ``lo:hi`` in one compiled call: apply actions, run, finish.

    The arguments from ``n`` on are the loop's (:meth:`contour_gym.loop.ServoLoop.advance`; passed
    flat: a tuple argument would send numba's dispatcher down its slow typing path).
    Returns False, having changed nothing, when any member's action (not only ``lo:hi``'s) is
    NaN or infinite, so every part of a decision run on threads agrees.
    """
    # the views, made once for the whole decision
    loop, m, bank, env = _views(env_floats, env_layout, floats, float_layout, ints, int_layout,
                                path_kinds, path_floats, path_layout, part)
    for b in range(env.action.shape[0]):
        for j in range(env.action.shape[1]):
            if not math.isfinite(env.action[b, j]):
                return False
    _apply(m, env, ec, lo, hi)
    RUN_MEMBERS(n, k0, config_row, loop, bank, borrow(noise), borrow(rec), lo, hi)
    _finish(m, bank, env, ec, lo, hi)
    if ec[EC.python_reward] == 0.0:
        _rewards(m, env, ec, lo, hi)
    return True


__all__ = ["apply_rewards", "env_step", "observe"]
