"""The compiled closed loop: one servo tick for every batch member (DESIGN.md data flow).

interpolator -> path -> reference r; plant -> measured p; e = r - p -> axis PIDs; contour
error -> CCC -> coupling gains; u = sat(u_axis + u_ccc) -> plant. One copy of this loop
serves the convenience API, the environments and the optimisers.
"""

from __future__ import annotations

import math

import numba

from contour_gym.motion import IS_DONE, IS_S, IS_V, interp_tick
from contour_gym.paths._geom import eval_path, nearest_window
from contour_gym.plant._kernel import AX_UMAX, ST_V, ST_X, axis_tick, measure
from contour_gym.servo._kernel import pid_commit, pid_output

# acc_c[b, c, :]: contour error sums over the window's active ticks
AC_ABS, AC_SQ, AC_MAX, AC_N = 0, 1, 2, 3
# acc_a[b, a, :]: tracking error sums and control total variation
AA_ABS, AA_SQ, AA_MAX, AA_TV = 0, 1, 2, 3
# last[b, c, :]: the last tick's true and estimated contour error
LS_TRUE, LS_EST = 0, 1
# work rows
W_R, W_RDOT, W_Y, W_E, W_U = 0, 1, 2, 3, 4
N_W = 5

STATUS_OK, STATUS_FAILED = 0, 1
STATE_LIMIT = 1e3  # |x| in m or |v| in m/s beyond this is a diverged member


@numba.njit(cache=True)
def contour_error(kind, s0, data, bound, c_axes, c_off, c, pos, s_ref, rx, ry, rz):  # type: ignore[no-untyped-def]
    """Exact contour error of axis positions ``pos`` for contour ``c`` near ``s_ref``.

    The foot point is searched in the arc-length window ``s_ref +- (4 d0 + 1e-9)`` with
    ``d0 = |p - r(s_ref)|``: the foot lies within ``2 d0`` of ``r``, and along a smooth
    path or a corner of up to 90 degrees that chord bounds the arc length by ``4 d0``. At a
    self-intersection this keeps the branch being traversed.

    Returns:
        ``(eps, c0, c1, c2, s_foot)``: signed (2-D) or unsigned (3-D) contour error and the
        coupling gains C (unit vector from the tool toward the path when eps > 0).
    """
    dim = 2 if c_axes[c, 2] < 0 else 3
    p0 = pos[c_axes[c, 0]] - c_off[c, 0]
    p1 = pos[c_axes[c, 1]] - c_off[c, 1]
    p2 = pos[c_axes[c, 2]] - c_off[c, 2] if dim == 3 else 0.0
    d0 = math.sqrt((p0 - rx) ** 2 + (p1 - ry) ** 2 + (p2 - rz) ** 2)
    w = 4.0 * d0 + 1e-9
    sf, _ = nearest_window(kind, s0, data, bound, p0, p1, p2, s_ref - w, s_ref + w)
    qx, qy, qz, tx, ty, tz, _, _, _ = eval_path(kind, s0, data, sf)
    vx, vy, vz = qx - p0, qy - p1, qz - p2
    if dim == 2:
        tn = math.hypot(tx, ty)
        nx, ny = -ty / tn, tx / tn  # left normal
        return -(vx * nx + vy * ny), -nx, -ny, 0.0, sf
    eps = math.sqrt(vx * vx + vy * vy + vz * vz)
    if eps < 1e-300:
        return 0.0, 0.0, 0.0, 0.0, sf
    return eps, vx / eps, vy / eps, vz / eps, sf


@numba.njit(cache=True)
def _reference(kind, s0, data, c_axes, c_off, s, v, work):  # type: ignore[no-untyped-def]
    px, py, pz, tx, ty, tz, _, _, _ = eval_path(kind, s0, data, s)
    pt = (px, py, pz)
    tg = (tx, ty, tz)
    for c in range(c_axes.shape[0]):
        for j in range(3):
            a = c_axes[c, j]
            if a >= 0:
                work[W_R, a] = pt[j] + c_off[c, j]
                work[W_RDOT, a] = tg[j] * v
    return px, py, pz


@numba.njit(cache=True)
def _accumulate_axes(acc_a, u_last, work, x, n_axes):  # type: ignore[no-untyped-def]
    for a in range(n_axes):
        e = work[W_R, a] - x[a]
        acc_a[a, AA_ABS] += abs(e)
        acc_a[a, AA_SQ] += e * e
        acc_a[a, AA_MAX] = max(acc_a[a, AA_MAX], abs(e))
        acc_a[a, AA_TV] += abs(work[W_U, a] - u_last[a])


@numba.njit(cache=True)
def _accumulate_contour(acc, eps):  # type: ignore[no-untyped-def]
    acc[AC_ABS] += abs(eps)
    acc[AC_SQ] += eps * eps
    acc[AC_MAX] = max(acc[AC_MAX], abs(eps))
    acc[AC_N] += 1.0


@numba.njit(cache=True)
def member_tick(  # type: ignore[no-untyped-def]  # noqa: C901
    b, j, k, ts, nsub, kind, s0, data, bound, c_axes, c_off, ax_p, rip, dist, ad, bd, ax_s,
    ctrl_p, ctrl_s, ccc_p, ccc_w, ccc_s, ip_p, ip_s, length, foot, last, noise, acc_c, acc_a,
    u_last, rec, record, work, xbuf, meas_exact,
):
    """One servo tick of batch member ``b`` (``j`` = index within this call, ``k`` = global)."""
    n_axes = ax_p.shape[1]
    active = ip_s[b, IS_DONE] < 0.0
    interp_tick(length, ts, ip_p[b], ip_s[b], k)
    s, v = ip_s[b, IS_S], ip_s[b, IS_V]
    rx, ry, rz = _reference(kind, s0, data, c_axes, c_off, s, v, work)
    has_noise = noise.shape[1] > 0
    for a in range(n_axes):
        xbuf[a] = ax_s[b, a, ST_X]
        w = noise[b, j, n_axes + a] if has_noise else 0.0
        work[W_Y, a] = measure(ax_p[b, a], xbuf[a], w)
        work[W_E, a] = work[W_R, a] - work[W_Y, a]
        work[W_U, a] = pid_output(ctrl_p[b, a], ctrl_s[b, a], work[W_E, a], work[W_RDOT, a], ts)
    for c in range(c_axes.shape[0]):
        eps, g0, g1, g2, sf = contour_error(kind, s0, data, bound, c_axes, c_off, c, xbuf, s, rx, ry, rz)
        foot[b, c] = sf
        eh = eps
        if not meas_exact:
            eh, g0, g1, g2, _ = contour_error(
                kind, s0, data, bound, c_axes, c_off, c, work[W_Y], s, rx, ry, rz
            )
        big_u = pid_output(ccc_p[b, c], ccc_s[b, c], eh, 0.0, ts)
        gains = (g0, g1, g2)
        for i in range(3):
            a = c_axes[c, i]
            if a >= 0:
                work[W_U, a] += ccc_w[b, c, i] * gains[i] * big_u
        pid_commit(ccc_s[b, c], eh, ts, big_u, math.inf)
        last[b, c, LS_TRUE], last[b, c, LS_EST] = eps, eh
        if active:
            _accumulate_contour(acc_c[b, c], eps)
        if record:
            rec[b, j, 2 + 3 * n_axes + 2 * c] = eps
            rec[b, j, 3 + 3 * n_axes + 2 * c] = eh
    for a in range(n_axes):
        u_max = ax_p[b, a, AX_UMAX]
        u_sat = min(max(work[W_U, a], -u_max), u_max)
        pid_commit(ctrl_s[b, a], work[W_E, a], ts, work[W_U, a], u_max)
        work[W_U, a] = u_sat
    if active:
        _accumulate_axes(acc_a[b], u_last[b], work, xbuf, n_axes)
    if record:
        rec[b, j, 0], rec[b, j, 1] = s, v
        for a in range(n_axes):
            rec[b, j, 2 + a] = work[W_R, a]
            rec[b, j, 2 + n_axes + a] = xbuf[a]
            rec[b, j, 2 + 2 * n_axes + a] = work[W_U, a]
    ok = True
    for a in range(n_axes):
        u_last[b, a] = work[W_U, a]
        w = noise[b, j, a] if has_noise else 0.0
        axis_tick(ax_p[b, a], rip[b, a], dist[b, a], ad[b, a], bd[b, a], ax_s[b, a],
                  work[W_U, a], k * ts, ts, nsub, w)
        xa, va = ax_s[b, a, ST_X], ax_s[b, a, ST_V]
        if not (abs(xa) < STATE_LIMIT and abs(va) < STATE_LIMIT):
            ok = False
    return ok


@numba.njit(cache=True)
def run_ticks(  # type: ignore[no-untyped-def]
    n, k0, ts, nsub, kind, s0, data, bound, c_axes, c_off, ax_p, rip, dist, ad, bd, ax_s,
    ctrl_p, ctrl_s, ccc_p, ccc_w, ccc_s, ip_p, ip_s, length, foot, last, noise, status,
    acc_c, acc_a, u_last, rec, record, work, xbuf, meas_exact,
):
    """Run ``n`` ticks for every member that has not failed; a diverging member is flagged."""
    for b in range(ax_p.shape[0]):
        if status[b] != STATUS_OK:
            continue
        for j in range(n):
            ok = member_tick(
                b, j, k0 + j, ts, nsub, kind, s0, data, bound, c_axes, c_off, ax_p, rip,
                dist, ad, bd, ax_s, ctrl_p, ctrl_s, ccc_p, ccc_w, ccc_s, ip_p, ip_s, length,
                foot, last, noise, acc_c, acc_a, u_last, rec, record, work, xbuf, meas_exact,
            )
            if not ok:
                status[b] = STATUS_FAILED
                break
