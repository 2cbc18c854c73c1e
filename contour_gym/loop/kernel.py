"""Kernel template: the compiled closed loop, servo ticks for every batch member (DESIGN.md).

One tick of member b (local tick k)::

    interpolator -> s, reference r (per axis, contour offsets added)
    encoder: y = quantise(x) + noise                        (rig; exact with ideal=True)
    per contour: true error eps (the nearest point of the branch from the machine's previous
                 foot point to the reference: contour_gym.paths._branch),
                 estimate from y (the registered estimator), CCC law -> U (standing aside
                 while the estimate's foot retraces a leg against the reference: contour_gym.ccc),
                 distributed by the coupling gains: into the control (u += w C U) or into the
                 commanded position (r += w C U, 002's pre-compensation)
    per axis: u = controller(r, y) + friction compensation + CCC share, saturated
    plant: driven by the command of tick k - 1 on the rig (one-tick computation delay), of
           tick k with ideal=True
    metrics: sums while the member runs and its foot is on a cutting segment
    end: in position at the path end (reference done, foot at the end, axes within the band
         and slow) -> ARRIVED; diverged, or not in position ``settle_ticks`` after the
         reference ended -> FAILED

This module is a template (:mod:`contour_gym.jit`): its slots (the axis controller, the
estimator, the friction laws, the friction compensation, the CCC law) are bound per run to the
registered components, so numba compiles and inlines exactly what the run uses. The exact
nearest-point search and the estimators' foot functions are called, not inlined: compiled
once, they are shared by every specialised kernel. Per-tick helpers are ``inline="always"``
(a call per tick with this many arguments cost more than the tick), and :func:`member_run` is
compiled without numba's reference counting (its private ``_nrt=False`` option): the arrays
are borrowed views (:func:`contour_gym._blob.borrow`), nothing allocates, nothing escapes.
"""

from __future__ import annotations

from typing import Any

import numba

from contour_gym._blob import borrow
from contour_gym.contour._history import eval_path_memo
from contour_gym.contour._kernel import ground_truth_from, history_push, resolve
from contour_gym.jit.slots import (
    CCC_COMMIT,
    CCC_OUTPUT,
    CCC_RELEASE,
    COMP_COMMIT,
    COMP_OUTPUT,
    CTRL_COMMIT,
    CTRL_CONTROL,
    EST_FOOT,
    FRICTION,
)
from contour_gym.loop.state import (
    FT,
    LS,
    MEM_COL,
    REASON_DIVERGED,
    REASON_NOT_IN_POSITION,
    REASON_OVER_LIMIT,
    STATE_LIMIT,
    STATUS_ARRIVED,
    STATUS_FAILED,
    STATUS_OK,
    WORK_ROW,
    config,
    loop_arrays,
    member_path,
    next_path,
    path_bank,
)
from contour_gym.metrics import AA, AC
from contour_gym.motion import CUTTING, IS, interp_tick
from contour_gym.paths._geom import eval_path, find_segment
from contour_gym.plant._kernel import AX, ST, disturbance_force, measure, ripple_force


@numba.njit(cache=True, inline="always")
def axis_tick(ax, fr, rip, dist, ad, bd, st, i, u, t, ts, nsub, w):
    """Advance axis row ``i`` by one tick ``ts`` with the control ``u`` held (ZOH).

    The disturbance (random part advanced with normal ``w``) is held over the tick; the
    ripple and the axis' friction law (its code ``AX.law``) act every substep.
    """
    d = disturbance_force(dist, st, i, t, w)
    h = ts / nsub
    law = int(ax[i, AX.law])
    nrip = int(ax[i, AX.nrip])
    harmonic = ax[i, AX.harm] > 0.0
    for _ in range(nsub):
        f_ext = d
        if nrip > 0:
            f_ext -= ripple_force(rip, i, nrip, harmonic, st[i, ST.x])
        FRICTION(law, ax, fr, ad, bd, st, i, u, f_ext, h)
    if ax[i, AX.tau] == 0.0:
        st[i, ST.i] = u


@numba.njit(cache=True)
def drive_axis(ax, fr, rip, dist, ad, bd, st, u, t0, ts, nsub, w, xs, vs):
    """Drive axis row 0 with the control sequence ``u`` (open loop); positions, velocities."""
    for k in range(u.shape[0]):
        axis_tick(ax, fr, rip, dist, ad, bd, st, 0, u[k], t0 + k * ts, ts, nsub, w[k])
        xs[k], vs[k] = st[0, ST.x], st[0, ST.v]


@numba.njit(cache=True, inline="always")
def _reference(loop, path, s, v, acc, hist):
    # r = P(s) + offset, r' = P'(s) v, r'' = P''(s) v^2 + P'(s) a, written per axis; P(s)
    # remembered in the member's history row (its estimator asks for it again this tick)
    px, py, pz, tx, ty, tz, kx, ky, kz = eval_path_memo(path.kind, path.s0, path.data, s, hist)
    work, c_axes = loop.work, loop.c_axes
    for c in range(c_axes.shape[0]):
        for j in range(3):
            a = c_axes[c, j]
            if a < 0:
                continue
            p, t, k = (px, tx, kx) if j == 0 else ((py, ty, ky) if j == 1 else (pz, tz, kz))
            work[WORK_ROW.r0, a] = p + loop.c_off[c, j]
            work[WORK_ROW.r, a] = work[WORK_ROW.r0, a]
            work[WORK_ROW.rdot, a] = t * v
            work[WORK_ROW.rddot, a] = k * v * v + t * acc


@numba.njit(cache=True, inline="always")
def _coords(loop, c, row):
    # contour c's coordinates of the axis values in work row ``row``, offset removed
    c_axes, c_off, work = loop.c_axes, loop.c_off, loop.work
    dim = 2 if c_axes[c, 2] < 0 else 3
    p0 = work[row, c_axes[c, 0]] - c_off[c, 0]
    p1 = work[row, c_axes[c, 1]] - c_off[c, 1]
    p2 = work[row, c_axes[c, 2]] - c_off[c, 2] if dim == 3 else 0.0
    return dim, p0, p1, p2


@numba.njit(cache=True, inline="always")
def _track_foot(loop, path, cfg, q, s, p0, p1, p2):
    # the true error: the nearest point of the branch from the machine's previous foot to the
    # reference s (contour_gym.paths._branch); the foot's progress is kept unwrapped on closed
    # paths (a lap past the end continues beyond the length)
    foot = loop.foot
    sf_prev = foot[q, FT.s]
    eps, g0, g1, g2, sf, qx, qy, qz = ground_truth_from(
        path.kind, path.s0, path.data, path.bound, cfg.dim, p0, p1, p2, sf_prev, foot[q, FT.qx],
        foot[q, FT.qy], foot[q, FT.qz], s,
    )
    step = _step(path, sf, sf_prev)
    foot[q, FT.progress] += step
    foot[q, FT.s], foot[q, FT.qx], foot[q, FT.qy], foot[q, FT.qz] = sf, qx, qy, qz
    foot[q, FT.seg] = find_segment(path.s0, sf)
    return eps, g0, g1, g2, (sf if step < 0.0 else -1.0)


@numba.njit(cache=True, inline="always")
def _step(path, sf, sf_prev):
    # how far a foot point moved along the path, across a closed path's seam the short way
    step = sf - sf_prev
    if path.closed and step < -0.5 * path.length:
        step += path.length
    elif path.closed and step > 0.5 * path.length:
        step -= path.length
    return step


@numba.njit(cache=True, inline="always")
def _estimate(loop, path, cfg, q, c, s, eps, g0, g1, g2, back):
    # the contour error the CCC sees: from the encoder readings, by the run's estimator, and
    # where its foot point moved backward this tick (-1: it did not, or is not tracked)
    if cfg.meas_exact and cfg.search:
        return eps, g0, g1, g2, back  # the exact search on the exact position: already known
    dim, p0, p1, p2 = _coords(loop, c, WORK_ROW.y)
    b = q // loop.c_axes.shape[0]
    if cfg.search:
        # an exact-search estimator tracks its own foot point from tick to tick (the reading's,
        # never the truth's): the same definition on the reading
        f = loop.foot
        sf_prev = f[q, FT.e_s]
        e, c0, c1, c2, sf, qx, qy, qz = ground_truth_from(
            path.kind, path.s0, path.data, path.bound, dim, p0, p1, p2, sf_prev, f[q, FT.e_qx],
            f[q, FT.e_qy], f[q, FT.e_qz], s,
        )
        f[q, FT.e_s], f[q, FT.e_qx], f[q, FT.e_qy], f[q, FT.e_qz] = sf, qx, qy, qz
        return e, c0, c1, c2, (sf if _step(path, sf, sf_prev) < 0.0 else -1.0)
    foot = EST_FOOT(cfg.est, loop.est_p, path.kind, path.s0, path.data, path.bound, p0, p1, p2,
                    s, loop.hist[b])
    e, c0, c1, c2, _ = resolve(foot, path.kind, path.s0, path.data, path.bound, dim, p0, p1, p2, s)
    return e, c0, c1, c2, -1.0


@numba.njit(cache=True, inline="always")
def _retracing(loop, path, c, back):
    # the foot point the CCC acts on moved backward (to ``back``) on a stretch of the path
    # that runs against the reference (tangents over 90 degrees apart): the machine retraces
    # a leg it has left after a reversal (contour_gym.ccc, "Standing aside")
    if back < 0.0:
        return False
    _, _, _, tx, ty, tz, _, _, _ = eval_path(path.kind, path.s0, path.data, back)
    axes, work = loop.c_axes, loop.work
    dot = tx * work[WORK_ROW.rdot, axes[c, 0]] + ty * work[WORK_ROW.rdot, axes[c, 1]]
    if axes[c, 2] >= 0:
        dot += tz * work[WORK_ROW.rdot, axes[c, 2]]
    return dot < 0.0


@numba.njit(cache=True, inline="always")
def _waiting(loop, b):
    # the reference waits for the axes to be in position: an exact stop, or the path's end
    return loop.ip_s[b, IS.done] >= 0.0 or loop.ip_s[b, IS.wait] > 0.0


@numba.njit(cache=True, inline="always")
def _ccc(loop, cfg, q, c, dim, eps, g0, g1, g2, waiting, aside):
    # Contour row q = b * C + c; its state rows are 3 q + i. 2-D: the law on the signed eps,
    # distributed by C (state row 3 q). 3-D: the law on each signed component C_i eps.
    # waiting: the reference waits for the axes (the law releases); aside: the law stands
    # aside, no output, released (contour_gym.ccc)
    row = WORK_ROW.r if cfg.inj_ref else WORK_ROW.uccc
    axes, w, work = loop.c_axes, loop.ccc_w, loop.work
    if aside:
        for i in range(1 if dim == 2 else 3):
            CCC_RELEASE(cfg.ccc, loop.ccc_p, loop.ccc_s, loop.ccc_data, q, 3 * q + i, cfg.ts)
        return
    for i in range(1 if dim == 2 else 3):
        g = g0 if i == 0 else (g1 if i == 1 else g2)
        e_i = eps if dim == 2 else g * eps
        out = CCC_OUTPUT(cfg.ccc, loop.ccc_p, loop.ccc_s, loop.ccc_data, q, 3 * q + i, e_i, cfg.ts)
        if dim == 2:
            work[row, axes[c, 0]] += w[q, 0] * g0 * out
            work[row, axes[c, 1]] += w[q, 1] * g1 * out
        else:
            work[row, axes[c, i]] += w[q, i] * out
        CCC_COMMIT(cfg.ccc, loop.ccc_p, loop.ccc_s, loop.ccc_data, q, 3 * q + i, e_i, cfg.ts, out,
                   False)
        if waiting:
            CCC_RELEASE(cfg.ccc, loop.ccc_p, loop.ccc_s, loop.ccc_data, q, 3 * q + i, cfg.ts)


@numba.njit(cache=True, inline="always")
def _contours(loop, path, cfg, b, s, n_axes):
    n_c = loop.c_axes.shape[0]
    for a in range(n_axes):
        loop.work[WORK_ROW.uccc, a] = 0.0
    waiting = _waiting(loop, b)
    for c in range(n_c):
        q = b * n_c + c
        dim, p0, p1, p2 = _coords(loop, c, WORK_ROW.x)
        eps, g0, g1, g2, back = _track_foot(loop, path, cfg, q, s, p0, p1, p2)
        eh, h0, h1, h2, back = _estimate(loop, path, cfg, q, c, s, eps, g0, g1, g2, back)
        aside = _retracing(loop, path, c, back)
        _ccc(loop, cfg, q, c, dim, eh, h0, h1, h2, waiting, aside)
        loop.last[q, LS.true], loop.last[q, LS.est] = eps, eh
    history_push(loop.hist[b], s)


@numba.njit(cache=True, inline="always")
def _axes(loop, cfg, b, n_axes):
    # control, compensation and CCC share; saturate; the command that drives the plant
    work, ts = loop.work, cfg.ts
    for a in range(n_axes):
        i = b * n_axes + a
        r, rd = work[WORK_ROW.r, a], work[WORK_ROW.rdot, a]
        rdd, y = work[WORK_ROW.rddot, a], work[WORK_ROW.y, a]
        u_comp = COMP_OUTPUT(cfg.comp, loop.comp_p, loop.comp_s, i, rd, y, ts)
        u = CTRL_CONTROL(cfg.ctrl, loop.ctrl_p, loop.ctrl_s, i, r, rd, rdd, y, ts)
        u += u_comp + work[WORK_ROW.uccc, a]
        u_max = loop.ax_p[i, AX.u_max]
        u_sat = min(max(u, -u_max), u_max)
        applied = loop.u_cmd[b, a] if cfg.delay else u_sat
        CTRL_COMMIT(cfg.ctrl, loop.ctrl_p, loop.ctrl_s, i, r, rd, rdd, y, ts, u, applied, u_comp,
                    u_max)
        COMP_COMMIT(cfg.comp, loop.comp_p, loop.comp_s, i, rd, y, ts)
        work[WORK_ROW.u, a], work[WORK_ROW.ua, a] = u_sat, applied


@numba.njit(cache=True, inline="always")
def _sums_contour(acc, q, eps, sampled):
    acc[q, AC.abs] += abs(eps)
    acc[q, AC.sq] += eps * eps
    acc[q, AC.max] = max(acc[q, AC.max], abs(eps))
    acc[q, AC.n] += 1.0
    if sampled:
        acc[q, AC.s_abs] += abs(eps)
        acc[q, AC.s_n] += 1.0


@numba.njit(cache=True, inline="always")
def _sums_axis(acc, i, e, du, sampled):
    acc[i, AA.abs] += abs(e)
    acc[i, AA.sq] += e * e
    acc[i, AA.max] = max(acc[i, AA.max], abs(e))
    acc[i, AA.tv] += abs(du)
    if sampled:
        acc[i, AA.s_abs] += abs(e)


@numba.njit(cache=True, inline="always")
def _accumulate(loop, path, cfg, b, k, n_axes):
    # metrics count the ticks whose foot lies on a cutting segment while the reference is on one
    # (at a stop: the block that ended there): a rapid's arrival, with the machine overshooting
    # past the next cut's start before that cut begins, cuts nothing; so does a rapid's start
    n_c = loop.c_axes.shape[0]
    if (int(path.flags[int(loop.foot[b * n_c, FT.seg])]) & CUTTING) == 0:
        return
    seg = int(loop.ip_s[b, IS.seg])
    if seg > 0 and (loop.ip_s[b, IS.wait] > 0.0 or loop.ip_s[b, IS.hold] > 0.0):
        seg -= 1
    if (int(path.flags[seg]) & CUTTING) == 0:
        return
    sampled = k % cfg.sample_every == 0
    for c in range(n_c):
        q = b * n_c + c
        _sums_contour(loop.acc_c, q, loop.last[q, LS.true], sampled)
        _sums_contour(loop.ep_c, q, loop.last[q, LS.true], sampled)
    for a in range(n_axes):
        i = b * n_axes + a
        e = loop.work[WORK_ROW.r0, a] - loop.work[WORK_ROW.x, a]
        du = loop.work[WORK_ROW.u, a] - loop.u_cmd[b, a]
        _sums_axis(loop.acc_a, i, e, du, sampled)
        _sums_axis(loop.ep_a, i, e, du, sampled)


@numba.njit(cache=True, inline="always")
def _over_limit(loop, cfg, b):
    # the run's stop_above (a tuner's hard limit): the episode's max contour error past it
    n_c = loop.c_axes.shape[0]
    for c in range(n_c):  # noqa: SIM110 (numba compiles no generator)
        if loop.ep_c[b * n_c + c, AC.max] > cfg.stop_above:
            return True
    return False


@numba.njit(cache=True, inline="always")
def _record(loop, b, j, s, v, rec, n_axes):
    work = loop.work
    rec[b, j, 0], rec[b, j, 1] = s, v
    for a in range(n_axes):
        rec[b, j, 2 + a] = work[WORK_ROW.r0, a]
        rec[b, j, 2 + n_axes + a] = work[WORK_ROW.x, a]
        rec[b, j, 2 + 2 * n_axes + a] = work[WORK_ROW.u, a]
    base = 2 + 3 * n_axes
    n_c = loop.c_axes.shape[0]
    for c in range(n_c):
        rec[b, j, base + 2 * c] = loop.last[b * n_c + c, LS.true]
        rec[b, j, base + 1 + 2 * c] = loop.last[b * n_c + c, LS.est]


@numba.njit(cache=True, inline="always")
def _plant(loop, cfg, b, k, noise, j, n_axes, has_noise):
    # advance every axis with the applied command; False if the state left the physical range
    # (j: the member's row in the noise buffer)
    ok = True
    for a in range(n_axes):
        i = b * n_axes + a
        loop.u_cmd[b, a] = loop.work[WORK_ROW.u, a]
        w = noise[b, j, a] if has_noise else 0.0
        axis_tick(loop.ax_p, loop.fr_p, loop.rip, loop.dist, loop.ad, loop.bd, loop.ax_s, i,
                  loop.work[WORK_ROW.ua, a], k * cfg.ts, cfg.ts, cfg.nsub, w)
        x, v = loop.ax_s[i, ST.x], loop.ax_s[i, ST.v]
        if not (abs(x) < STATE_LIMIT and abs(v) < STATE_LIMIT):
            ok = False
    return ok


@numba.njit(cache=True, inline="always")
def _in_position(loop, cfg, b, k, n_axes):
    # a CNC's in-position check on the encoder (noise-free): following error within the band,
    # and slow (the reading's change over the axis's last AX.in_ticks ticks: one count over
    # them is no faster than in_speed); asked only while something waits on it (an exact
    # stop, or the path end: see member_run)
    if not _waiting(loop, b):
        return False
    inpos = True
    w = loop.x_ring.shape[1]
    for a in range(n_axes):
        i = b * n_axes + a
        y = measure(loop.ax_p, i, loop.ax_s[i, ST.x], 0.0)
        n = int(loop.ax_p[i, AX.in_ticks])
        then = measure(loop.ax_p, i, loop.x_ring[b, (k - n + w) % w, a], 0.0)
        speed = abs(y - then) / (n * cfg.ts)
        near = abs(loop.work[WORK_ROW.r0, a] - y) <= cfg.in_band
        inpos = inpos and near and speed <= cfg.in_speed
    return inpos


@numba.njit(cache=True, inline="always")
def _arrived(loop, path, cfg, b, inpos):
    if not (inpos and loop.ip_s[b, IS.done] >= 0.0):
        return False
    n_c = loop.c_axes.shape[0]
    band = 2.0 * cfg.in_band
    for c in range(n_c):
        f = b * n_c + c
        if loop.foot[f, FT.progress] >= path.length - band - 1e-9:
            continue
        # a part whose moves retrace each other (a retract, then the return over the same
        # line): the foot may lie on the earlier pass, at the end point all the same
        ex, ey, ez = eval_path(path.kind, path.s0, path.data, path.length)[:3]
        dx, dy, dz = loop.foot[f, FT.qx] - ex, loop.foot[f, FT.qy] - ey, loop.foot[f, FT.qz] - ez
        if dx * dx + dy * dy + dz * dz > band * band:
            return False
    return True


@numba.njit(cache=True, inline="always")
def _sense(loop, cfg, b, noise, j, n_axes, has_noise):
    work = loop.work
    for a in range(n_axes):
        i = b * n_axes + a
        work[WORK_ROW.x, a], work[WORK_ROW.v, a] = loop.ax_s[i, ST.x], loop.ax_s[i, ST.v]
        if cfg.meas_exact:
            work[WORK_ROW.y, a] = work[WORK_ROW.x, a]
        else:
            w = noise[b, j, n_axes + a] if has_noise else 0.0
            work[WORK_ROW.y, a] = measure(loop.ax_p, i, work[WORK_ROW.x, a], w)


# numba's private ``_nrt`` option: compiled without reference counting (module docstring)
_NO_REFCOUNT: dict[str, Any] = {"cache": True, "_nrt": False}


@numba.njit(**_NO_REFCOUNT)
def member_run(b, n, k0, cfg, loop, path, noise, rec):
    """Run ``n`` servo ticks of member ``b`` from its local tick ``k0``; returns its status.

    ``path`` is the member's own path (:func:`contour_gym.loop.state.member_path`).
    """
    n_axes = loop.work.shape[1]
    has_noise = noise.shape[1] > 0
    row = loop.noise_at[b]  # the member's noise row of tick k0
    prog = (path.feed, path.flags, path.vcap, path.vj, path.wait, path.dwell)
    law = (path.law_s, path.law_v)
    for j in range(n):
        k = k0 + j
        in_pos = loop.mem[b, MEM_COL.in_pos] > 0.0
        interp_tick(loop.ip_p, loop.ip_s, b, k, cfg.ts, path.s0, prog, law, cfg.law_dt, in_pos)
        s = loop.ip_s[b, IS.s]
        _reference(loop, path, s, loop.ip_s[b, IS.v], loop.ip_s[b, IS.a], loop.hist[b])
        _sense(loop, cfg, b, noise, row + j, n_axes, has_noise)
        _contours(loop, path, cfg, b, s, n_axes)
        _axes(loop, cfg, b, n_axes)
        _accumulate(loop, path, cfg, b, k, n_axes)
        if _over_limit(loop, cfg, b):
            loop.mem[b, MEM_COL.reason], loop.mem[b, MEM_COL.end] = REASON_OVER_LIMIT, k + 1
            return STATUS_FAILED
        if cfg.record:
            _record(loop, b, j, s, loop.ip_s[b, IS.v], rec, n_axes)
        if not _plant(loop, cfg, b, k, noise, row + j, n_axes, has_noise):
            loop.mem[b, MEM_COL.reason], loop.mem[b, MEM_COL.end] = REASON_DIVERGED, k + 1
            return STATUS_FAILED
        inpos = _in_position(loop, cfg, b, k, n_axes)
        w = loop.x_ring.shape[1]
        for a in range(n_axes):
            loop.y_last[b, a] = loop.work[WORK_ROW.y, a]
            loop.x_ring[b, k % w, a] = loop.ax_s[b * n_axes + a, ST.x]  # after tick k
        loop.mem[b, MEM_COL.in_pos] = 1.0 if inpos else 0.0
        if _arrived(loop, path, cfg, b, inpos):
            loop.mem[b, MEM_COL.arrival], loop.mem[b, MEM_COL.end] = k + 1, k + 1
            return STATUS_ARRIVED
        done = loop.ip_s[b, IS.done]
        if done >= 0.0 and k - done > cfg.settle_ticks:
            loop.mem[b, MEM_COL.reason], loop.mem[b, MEM_COL.end] = REASON_NOT_IN_POSITION, k + 1
            return STATUS_FAILED
    return STATUS_OK


@numba.njit(cache=True, nogil=True)
def run_ticks(
    n, k0, config_row, floats, float_layout, ints, int_layout, path_kinds, path_floats,
    path_layout, noise, rec, lo, hi, part,
):
    """Run ``n`` ticks for members ``lo:hi`` whose status is OK; ends are flagged in ``status``.

    ``config_row`` is the run's :data:`~contour_gym.loop.state.CONFIG` row; ``floats`` and
    ``ints`` the loop's float and int blobs with their layouts; ``path_kinds``, ``path_floats``
    and ``path_layout`` the path bank's segment kinds and float blob (every member's path:
    :mod:`contour_gym.loop.state`). The blobs' views are made here, and the members run here
    (:func:`run_members`' body, inlined). ``part`` names the scratch the call uses: calls on
    disjoint member ranges and other parts may run at once (on threads: the kernel holds no
    GIL).
    """
    # borrowed: the views made here and in the callees carry no owner to count
    bank = path_bank(borrow(path_kinds), borrow(path_floats), path_layout)
    loop = loop_arrays(borrow(floats), float_layout, borrow(ints), int_layout, part)
    _members(n, k0, config(config_row), loop, bank, borrow(noise), borrow(rec), lo, hi)


@numba.njit(cache=True, nogil=True)
def run_members(n, k0, config_row, loop, bank, noise, rec, lo, hi):
    """:func:`run_ticks` on the blobs' views (the env kernel calls this with its own).

    Members ``lo:hi`` run; ``acc_*`` receive the sums of just these ticks (their rows),
    ``ep_*`` the episode's running sums (kept in the kernel so they do not depend on how an
    episode is cut into calls). ``k0`` is the loop's tick; member ``b`` lives in local time
    ``k0 - k_start[b]`` (vector env members restart at different ticks). ``noise`` holds each
    member's normals; member ``b`` reads its rows from ``noise_at[b]`` on and advances it by
    ``n`` (:class:`contour_gym.loop.noise.NoiseSource` refills the buffer).
    """
    _members(n, k0, config(config_row), loop, bank, noise, rec, lo, hi)


# inlined by numba into run_ticks and run_members: run_ticks (simulate, the loop's Python API)
# compiles no run_members of its own, whose code LLVM would optimise and link once more
@numba.njit(cache=True, inline="always")
def _members(n, k0, cfg, loop, bank, noise, rec, lo, hi):
    """:func:`run_members`' body."""
    n_c, n_a = loop.c_axes.shape[0], loop.work.shape[1]
    loop.acc_c[lo * n_c : hi * n_c] = 0.0  # the window sums start at zero
    loop.acc_a[lo * n_a : hi * n_a] = 0.0
    # each member's views of its own path, carved here (carved inside member_run, compiled
    # without reference counting, they cost ~0.5 us a call at n = 1), and only when its path is
    # another than the last one carved (members sharing a path carve it once)
    path, carved = member_path(bank, loop.p_at, lo), lo
    for b in range(lo, hi):
        if loop.status[b] != STATUS_OK:
            continue
        path, carved = next_path(bank, loop.p_at, path, carved, b)
        loop.status[b] = member_run(b, n, k0 - loop.k_start[b], cfg, loop, path, noise, rec)
        loop.noise_at[b] += n  # the member consumed n rows of its stream, whenever it stopped
