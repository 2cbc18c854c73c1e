"""Kernel template: one env decision for every member in one compiled call.

apply the actions (CCC gains or feed override) -> run the ticks (the loop's own specialised
``run_members``, slot ``RUN_MEMBERS``) -> reward components, reward (slot ``REWARD``), the failure
rule, termination and truncation -> observations. A Python reward replaces the middle step:
:func:`env_step` then stops after the components and :func:`apply_rewards` finishes once Python
has filled ``raw``.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba

from contour_gym._blob import borrow, view1, view2
from contour_gym._loopstate import (
    AA,
    AC,
    FT,
    LS,
    STATUS_ARRIVED,
    STATUS_FAILED,
    config,
    loop_arrays,
    path_arrays,
)
from contour_gym._schema import Schema
from contour_gym._slots import REWARD, RUN_MEMBERS
from contour_gym.motion import IP, IS
from contour_gym.paths._geom import eval_path
from contour_gym.plant._kernel import AX, ST
from contour_gym.rewards import COMPONENTS, RC

# reward, terminated, truncated, failure: consecutive (ContourTask.member_result reads them so)
ENV_FLOATS = (
    "action", "skip", "g_max", "g_log", "lookahead", "eps_prev", "s_before", "obs", "ref",
    "vel", "raw", "reward", "terminated", "truncated", "failure", "comp", "weights", "steps",
    "ret", "track", "feedrate",
)  # fmt: skip
E = namedtuple("E", ENV_FLOATS)(*range(len(ENV_FLOATS)))
EnvArrays = namedtuple("EnvArrays", ENV_FLOATS)  # type: ignore[misc]
ENV_CONFIG = Schema(
    "env config", kind=0.0, dovr=0.1, ovr_lo=0.2, ovr_hi=2.0, tol=1e-5, hard=1e-3, penalty=100.0,
    r_lo=-1.0, r_hi=0.0, n_max=1000.0, nominal=1.0, f_nom=1.0, python_reward=0.0, dim=2.0,
    length=1.0, reward=0.0,
)  # fmt: skip
EC = ENV_CONFIG.col

KIND_CCC, KIND_FEEDRATE = 0, 1
TRACKING_SCALE = 1e-3  # m: tracking errors are observed in mm
CURVATURE_SCALE = 0.01  # m: curvature is observed as kappa x 1 cm
OBS_LIMIT = 1e4  # every scaled observation is clipped to +-OBS_LIMIT


@numba.njit(cache=True, inline="always")
def env_arrays(eb, el):
    """The env blob as a named tuple of views."""
    return EnvArrays(
        view2(eb, el, E.action), view1(eb, el, E.skip), view1(eb, el, E.g_max),
        view1(eb, el, E.g_log), view1(eb, el, E.lookahead), view2(eb, el, E.eps_prev),
        view1(eb, el, E.s_before), view2(eb, el, E.obs), view2(eb, el, E.ref),
        view2(eb, el, E.vel), view1(eb, el, E.raw), view1(eb, el, E.reward),
        view1(eb, el, E.terminated), view1(eb, el, E.truncated), view1(eb, el, E.failure),
        view2(eb, el, E.comp), view1(eb, el, E.weights), view1(eb, el, E.steps),
        view1(eb, el, E.ret), view2(eb, el, E.track), view1(eb, el, E.feedrate),
    )  # fmt: skip


@numba.njit(cache=True, inline="always")
def action_to_gain(a, g_max, g_log):
    """The CCC env's gain map: ``g_max (R^((a+1)/2) - 1) / (R - 1)``, ``g_log = ln R``."""
    a = min(max(a, -1.0), 1.0)
    return g_max * (math.exp(0.5 * (a + 1.0) * g_log) - 1.0) / (math.exp(g_log) - 1.0)


@numba.njit(cache=True, inline="always")
def _apply(A, V, ec):
    # clip each live member's action to [-1, 1] and set its CCC gains or feed override
    n_c = A.c_axes.shape[0]
    for b in range(V.action.shape[0]):
        if V.skip[b] != 0.0:
            continue
        V.s_before[b] = A.ip_s[b, IS.s]
        for c in range(n_c):
            V.eps_prev[b, c] = A.last[b * n_c + c, LS.est]
        for j in range(V.action.shape[1]):
            V.action[b, j] = min(max(V.action[b, j], -1.0), 1.0)
        if ec[EC.kind] == KIND_FEEDRATE:
            ovr = A.ip_p[b, IP.ovr] + V.action[b, 0] * ec[EC.dovr]
            A.ip_p[b, IP.ovr] = min(max(ovr, ec[EC.ovr_lo]), ec[EC.ovr_hi])
            continue
        for c in range(n_c):
            for g in range(3):  # every CCC law starts its parameters with kp, ki, kd
                a = V.action[b, 3 * c + g]
                A.ccc_p[b * n_c + c, g] = action_to_gain(a, V.g_max[g], V.g_log[g])


@numba.njit(cache=True, inline="always")
def _components(A, V, ec, b):
    # the decision's reward components (contour_gym.rewards); True when the member failed
    n_c, n_a = A.c_axes.shape[0], A.work.shape[1]
    tol = ec[EC.tol]
    total, count, worst = 0.0, 0.0, 0.0
    for c in range(n_c):
        q = b * n_c + c
        total += A.acc_c[q, AC.abs]
        count += A.acc_c[q, AC.n]
        worst = max(worst, A.acc_c[q, AC.max])
    ticks = A.acc_c[b * n_c, AC.n]
    chatter = 0.0
    for a in range(n_a):
        i = b * n_a + a
        chatter += A.acc_a[i, AA.tv] / (max(ticks, 1.0) * A.ax_p[i, AX.u_max])
    comp = V.comp
    comp[b, RC.contour] = total / max(count, 1.0) / tol
    comp[b, RC.peak] = worst / tol
    comp[b, RC.chatter] = chatter / n_a
    comp[b, RC.progress] = (A.ip_s[b, IS.s] - V.s_before[b]) / ec[EC.nominal]
    comp[b, RC.excess] = max(worst / tol - 1.0, 0.0)
    return A.status[b] == STATUS_FAILED or worst > ec[EC.hard]


@numba.njit(cache=True)
def apply_rewards(eb, el, fb, fl, ib, il, ec):
    """Clip ``raw`` rewards, apply the failure rule, count steps, flag ends (env docstrings).

    Failure rule: a failed member's terminal reward brings its episode return to
    ``n_max r_lo - penalty``, below any completed episode's (each of at most ``n_max`` steps
    earns at least ``r_lo <= 0``).
    """
    # borrowed (contour_gym._blob.borrow): the caller keeps the blobs alive
    _rewards(loop_arrays(borrow(fb), fl, borrow(ib), il), env_arrays(borrow(eb), el), ec)


@numba.njit(cache=True, inline="always")
def _rewards(A, V, ec):
    # apply_rewards on the views
    r_lo, r_hi = ec[EC.r_lo], ec[EC.r_hi]
    for b in range(V.reward.shape[0]):
        if V.skip[b] != 0.0:
            V.reward[b], V.terminated[b], V.truncated[b] = 0.0, 0.0, 0.0
            continue
        r = min(max(V.raw[b], r_lo), r_hi)
        if V.failure[b] != 0.0:
            r = ec[EC.n_max] * r_lo - ec[EC.penalty] - V.ret[b]
        V.reward[b] = r
        V.ret[b] += r
        V.steps[b] += 1.0
        ended = V.failure[b] != 0.0 or A.status[b] == STATUS_ARRIVED
        V.terminated[b] = 1.0 if ended else 0.0
        V.truncated[b] = 1.0 if (not ended and V.steps[b] >= ec[EC.n_max]) else 0.0


@numba.njit(cache=True)
def _point(kind, s0, data, s):
    # called, not inlined: the observation evaluates the path at several places
    return eval_path(kind, s0, data, s)


@numba.njit(cache=True, inline="always")
def _curvature(P, s, dim):
    _, _, _, tx, ty, tz, kx, ky, kz = _point(P.kind, P.s0, P.data, s)
    if dim == 2:  # signed, + = turning left
        return (tx * ky - ty * kx) / max((tx * tx + ty * ty) ** 1.5, 1e-300)
    return math.sqrt(kx * kx + ky * ky + kz * kz)


@numba.njit(cache=True, inline="always")
def _put(obs, b, col, value):
    obs[b, col] = min(max(value, -OBS_LIMIT), OBS_LIMIT)
    return col + 1


@numba.njit(cache=True, inline="always")
def _references(A, P, V, b, dim):
    s, v = A.ip_s[b, IS.s], A.ip_s[b, IS.v]
    px, py, pz, tx, ty, tz, _, _, _ = _point(P.kind, P.s0, P.data, s)
    for c in range(A.c_axes.shape[0]):
        for j in range(dim):
            a = A.c_axes[c, j]
            V.ref[b, a] = (px if j == 0 else (py if j == 1 else pz)) + A.c_off[c, j]
            V.vel[b, a] = (tx if j == 0 else (ty if j == 1 else tz)) * v


@numba.njit(cache=True, inline="always")
def _observe(A, P, V, ec, b):
    # member b's observation row (the env docstrings' table, in key order); the info's
    # tracking errors and feedrate
    dim, length = int(ec[EC.dim]), ec[EC.length]
    _references(A, P, V, b, dim)
    n_c, n_a = A.c_axes.shape[0], A.work.shape[1]
    for a in range(n_a):
        V.track[b, a] = V.ref[b, a] - A.ax_s[b * n_a + a, ST.x]
    V.feedrate[b] = A.ip_p[b, IP.ovr] * P.feed[int(A.ip_s[b, IS.seg])]
    tol, f_nom, obs = ec[EC.tol], ec[EC.f_nom], V.obs
    s = A.ip_s[b, IS.s]
    col = 0
    for c in range(n_c):
        col = _put(obs, b, col, A.last[b * n_c + c, LS.est] / tol)
    for c in range(n_c):
        col = _put(obs, b, col, (A.last[b * n_c + c, LS.est] - V.eps_prev[b, c]) / tol)
    for a in range(n_a):
        col = _put(obs, b, col, (V.ref[b, a] - A.y_last[b, a]) / TRACKING_SCALE)
    for a in range(n_a):
        col = _put(obs, b, col, V.vel[b, a] / f_nom)
    col = _put(obs, b, col, _curvature(P, s, dim) * CURVATURE_SCALE)
    for i in range(V.lookahead.shape[0]):
        ahead = min(s + V.lookahead[i], length)
        col = _put(obs, b, col, _curvature(P, ahead, dim) * CURVATURE_SCALE)
    col = _put(obs, b, col, min(A.foot[b * n_c, FT.progress], length) / length)
    if ec[EC.kind] == KIND_CCC:
        for j in range(V.action.shape[1]):
            col = _put(obs, b, col, V.action[b, j])
    else:
        f_block = P.feed[int(A.ip_s[b, IS.seg])]
        col = _put(obs, b, col, A.ip_p[b, IP.ovr])
        col = _put(obs, b, col, A.ip_s[b, IS.v] / f_block)


@numba.njit(cache=True, inline="always")
def _views(eb, el, fb, fl, ib, il, pk, pb, pl):
    # the loop's, the path's and the env's arrays, borrowed (the caller keeps the blobs alive:
    # views of a borrowed blob count no references, contour_gym._blob.borrow)
    A = loop_arrays(borrow(fb), fl, borrow(ib), il)
    return A, path_arrays(borrow(pk), borrow(pb), pl), env_arrays(borrow(eb), el)


@numba.njit(cache=True)
def observe(eb, el, fb, fl, ib, il, pk, pb, pl, ec, members):
    """Write the observation rows of ``members`` (after a reset and after every step)."""
    A, P, V = _views(eb, el, fb, fl, ib, il, pk, pb, pl)
    for b in members:
        _observe(A, P, V, ec, b)


@numba.njit(cache=True, inline="always")
def _finish(A, P, V, ec):
    # components, failure flags and (compiled reward) raw rewards; observations
    for b in range(V.reward.shape[0]):
        if V.skip[b] == 0.0:
            failed = _components(A, V, ec, b)
            V.failure[b] = 1.0 if failed else 0.0
            if ec[EC.python_reward] == 0.0:
                V.raw[b] = REWARD(int(ec[EC.reward]), V.comp[b], V.weights)
        else:
            V.failure[b] = 0.0
        _observe(A, P, V, ec, b)


@numba.njit(cache=True)
def env_step(eb, el, ec, n, k0, cf, fb, fl, ib, il, pk, pb, pl, noise, rec):
    """One env decision in one compiled call: apply actions, run the ticks, finish.

    The arguments from ``n`` on are the loop's (:meth:`contour_gym.loop.ServoLoop.advance`; passed
    flat: a tuple argument would send numba's dispatcher down its slow typing path).
    Returns False, having changed nothing, when an action is NaN or infinite.
    """
    A, P, V = _views(eb, el, fb, fl, ib, il, pk, pb, pl)  # made once for the whole decision
    for b in range(V.action.shape[0]):
        for j in range(V.action.shape[1]):
            if not math.isfinite(V.action[b, j]):
                return False
    _apply(A, V, ec)
    RUN_MEMBERS(n, k0, config(cf), A, P, borrow(noise), borrow(rec))
    _finish(A, P, V, ec)
    if ec[EC.python_reward] == 0.0:
        _rewards(A, V, ec)
    return True


__all__ = ["COMPONENTS", "E", "ENV_CONFIG", "ENV_FLOATS", "apply_rewards", "env_step", "observe"]
