"""Compiled per-step work of the envs: apply actions, then rewards and observations.

Both kernels read and write the ServoLoop's blobs (``contour_gym._blob``) and the env's own
blob (arrays in the order of ``ENV_ARRAYS``), so a step costs two compiled calls with a
handful of arguments each instead of dozens of small numpy operations.
"""

from __future__ import annotations

import math

import numba

from contour_gym import _loopkernel as LK
from contour_gym._blob import view1, view2, view3
from contour_gym.motion import IP_F, IS_DONE, IS_S, IS_V
from contour_gym.paths._geom import eval_path
from contour_gym.servo._kernel import CP_KD, CP_KI, CP_KP

ENV_ARRAYS = (
    "action", "skip", "log_lo", "log_hi", "lookahead", "eps_prev", "s_before", "obs", "ref", "vel",
    "reward", "terminated", "failure",
)  # fmt: skip
E_ACTION, E_SKIP, E_LOG_LO, E_LOG_HI, E_LOOKAHEAD, E_EPS_PREV, E_S_BEFORE = 0, 1, 2, 3, 4, 5, 6
E_OBS, E_REF, E_VEL, E_REWARD, E_TERMINATED, E_FAILURE = 7, 8, 9, 10, 11, 12

KIND_CCC, KIND_FEEDRATE = 0, 1
TRACKING_SCALE = 1e-3  # m: tracking errors are observed in mm
CURVATURE_SCALE = 0.01  # m: curvature is observed as kappa x 1 cm
FEEDRATE_PENALTY = 10.0  # feedrate env: penalty per tolerance of excess error
OBS_LIMIT = 1e4  # every scaled observation is clipped to +-OBS_LIMIT


@numba.njit(cache=True)
def apply_actions(kind, fb, fl, eb, el, dfeed, f_lo, f_hi):  # type: ignore[no-untyped-def]
    """Clip each live member's action to [-1, 1] and set its CCC gains or feedrate.

    CCC: ``g = exp(lo + (a + 1)/2 (hi - lo))`` per gain (log scale). Feedrate (004 eq. 3.3):
    ``F = clip(F + a dfeed, f_lo, f_hi)``. Also records s at the decision's start.
    """
    action, skip = view2(eb, el, E_ACTION), view1(eb, el, E_SKIP)
    lo, hi, s_before = view1(eb, el, E_LOG_LO), view1(eb, el, E_LOG_HI), view1(eb, el, E_S_BEFORE)
    eps_prev = view2(eb, el, E_EPS_PREV)
    ccc_p, ip_p = view3(fb, fl, LK.I_CCC_P), view2(fb, fl, LK.I_IP_P)
    ip_s, last = view2(fb, fl, LK.I_IP_S), view3(fb, fl, LK.I_LAST)
    for b in range(action.shape[0]):
        if skip[b] != 0.0:
            continue
        s_before[b] = ip_s[b, IS_S]
        for c in range(eps_prev.shape[1]):
            eps_prev[b, c] = last[b, c, LK.LS_EST]
        for j in range(action.shape[1]):
            action[b, j] = min(max(action[b, j], -1.0), 1.0)
        if kind == KIND_FEEDRATE:
            ip_p[b, IP_F] = min(max(ip_p[b, IP_F] + action[b, 0] * dfeed, f_lo), f_hi)
            continue
        for c in range(ccc_p.shape[1]):
            for g, col in ((0, CP_KP), (1, CP_KI), (2, CP_KD)):
                a = action[b, 3 * c + g]
                ccc_p[b, c, col] = math.exp(lo[g] + 0.5 * (a + 1.0) * (hi[g] - lo[g]))


@numba.njit(cache=True)
def _reward(kind, acc, ds, tol, hard, penalty, nominal, failed):  # type: ignore[no-untyped-def]
    total, count, worst = 0.0, 0.0, 0.0
    for c in range(acc.shape[0]):
        total += acc[c, LK.AC_ABS]
        count += acc[c, LK.AC_N]
        worst = max(worst, acc[c, LK.AC_MAX])
    fail = failed or worst > hard
    if fail:
        return -penalty, True
    if kind == KIND_CCC:
        return -(total / max(count, 1.0)) / tol, False
    return ds / nominal - FEEDRATE_PENALTY * max(worst - tol, 0.0) / tol, False


@numba.njit(cache=True)
def _curvature(kind, s0, data, s, dim):  # type: ignore[no-untyped-def]
    _, _, _, tx, ty, tz, kx, ky, kz = eval_path(kind, s0, data, s)
    if dim == 2:  # signed, + = turning left
        return (tx * ky - ty * kx) / max((tx * tx + ty * ty) ** 1.5, 1e-300)
    return math.sqrt(kx * kx + ky * ky + kz * kz)


@numba.njit(cache=True)
def _put(obs, b, col, value):  # type: ignore[no-untyped-def]
    obs[b, col] = min(max(value, -OBS_LIMIT), OBS_LIMIT)
    return col + 1


@numba.njit(cache=True)
def _observe(kind, pk, s0, data, dim, length, b, fb, fl, ib, il, eb, el, tol, f_nom):  # type: ignore[no-untyped-def]
    ip_s, ip_p, last = view2(fb, fl, LK.I_IP_S), view2(fb, fl, LK.I_IP_P), view3(fb, fl, LK.I_LAST)
    y_last, c_off, c_axes = (
        view2(fb, fl, LK.I_Y_LAST),
        view2(fb, fl, LK.I_C_OFF),
        view2(ib, il, LK.I_C_AXES),
    )
    obs, ref, action = view2(eb, el, E_OBS), view2(eb, el, E_REF), view2(eb, el, E_ACTION)
    vel = view2(eb, el, E_VEL)
    eps_prev, ahead = view2(eb, el, E_EPS_PREV), view1(eb, el, E_LOOKAHEAD)
    s, v = ip_s[b, IS_S], ip_s[b, IS_V]
    px, py, pz, tx, ty, tz, _, _, _ = eval_path(pk, s0, data, s)
    n_axes, n_c = y_last.shape[1], c_axes.shape[0]
    for c in range(n_c):
        for j in range(dim):
            a = c_axes[c, j]
            ref[b, a] = (px if j == 0 else (py if j == 1 else pz)) + c_off[c, j]
            vel[b, a] = (tx if j == 0 else (ty if j == 1 else tz)) * v
    col = 0
    for c in range(n_c):
        col = _put(obs, b, col, last[b, c, LK.LS_EST] / tol)
    for c in range(n_c):
        col = _put(obs, b, col, (last[b, c, LK.LS_EST] - eps_prev[b, c]) / tol)
    for a in range(n_axes):
        col = _put(obs, b, col, (ref[b, a] - y_last[b, a]) / TRACKING_SCALE)
    for a in range(n_axes):
        col = _put(obs, b, col, vel[b, a] / f_nom)
    col = _put(obs, b, col, _curvature(pk, s0, data, s, dim) * CURVATURE_SCALE)
    for i in range(ahead.shape[0]):
        col = _put(
            obs, b, col, _curvature(pk, s0, data, min(s + ahead[i], length), dim) * CURVATURE_SCALE
        )
    col = _put(obs, b, col, s / length)
    if kind == KIND_CCC:
        for j in range(action.shape[1]):
            col = _put(obs, b, col, action[b, j])
    else:
        col = _put(obs, b, col, ip_p[b, IP_F] / f_nom)
        col = _put(obs, b, col, v / f_nom)


@numba.njit(cache=True)
def finish_step(  # type: ignore[no-untyped-def]
    kind, pk, s0, data, dim, length, fb, fl, ib, il, eb, el, tol, hard, penalty, nominal, f_nom
):
    """Rewards, termination, failure and observations of every member after a decision.

    Reward (see the env docstrings): CCC ``-mean|eps| / tol``; feedrate
    ``ds / nominal - 10 max(0, max|eps| - tol) / tol``; ``-penalty`` on failure
    (``|eps| > hard`` or a diverged member). Skipped members only get observations.
    """
    acc, status, ip_s = (
        view3(fb, fl, LK.I_ACC_C),
        view1(ib, il, LK.I_STATUS),
        view2(fb, fl, LK.I_IP_S),
    )
    skip, s_before = view1(eb, el, E_SKIP), view1(eb, el, E_S_BEFORE)
    reward, term, fail = (
        view1(eb, el, E_REWARD),
        view1(eb, el, E_TERMINATED),
        view1(eb, el, E_FAILURE),
    )
    for b in range(acc.shape[0]):
        if skip[b] == 0.0:
            failed = status[b] == LK.STATUS_FAILED
            r, f = _reward(
                kind, acc[b], ip_s[b, IS_S] - s_before[b], tol, hard, penalty, nominal, failed
            )
            reward[b], fail[b] = r, 1.0 if f else 0.0
            term[b] = 1.0 if (f or ip_s[b, IS_DONE] >= 0.0) else 0.0
        else:
            reward[b], term[b], fail[b] = 0.0, 0.0, 0.0
        _observe(kind, pk, s0, data, dim, length, b, fb, fl, ib, il, eb, el, tol, f_nom)


@numba.njit(cache=True)
def env_step(  # type: ignore[no-untyped-def]
    kind,
    dfeed,
    f_lo,
    f_hi,
    eb,
    el,
    tol,
    hard,
    penalty,
    nominal,
    f_nom,
    dim,
    n,
    k0,
    ts,
    nsub,
    length,
    record,
    meas_exact,
    ctrl_kind,
    est_kind,
    pk,
    s0,
    data,
    bound,
    fb,
    fl,
    ib,
    il,
    noise,
    rec,
):
    """One env decision in one compiled call: apply actions, run the ticks, finish.

    The arguments from ``n`` on are :meth:`contour_gym.loop.ServoLoop.kernel_args` (passed
    flat: a tuple argument would send numba's dispatcher down its slow typing path).
    Returns False, having changed nothing, when an action is NaN or infinite.
    """
    action = view2(eb, el, E_ACTION)
    for b in range(action.shape[0]):
        for j in range(action.shape[1]):
            if not math.isfinite(action[b, j]):
                return False
    apply_actions(kind, fb, fl, eb, el, dfeed, f_lo, f_hi)
    LK.run_ticks(
        n,
        k0,
        ts,
        nsub,
        length,
        record,
        meas_exact,
        ctrl_kind,
        est_kind,
        pk,
        s0,
        data,
        bound,
        fb,
        fl,
        ib,
        il,
        noise,
        rec,
    )
    finish_step(
        kind, pk, s0, data, dim, length, fb, fl, ib, il, eb, el, tol, hard, penalty, nominal, f_nom
    )
    return True
