"""The compiled closed loop: servo ticks for every batch member (DESIGN.md data flow).

interpolator -> path -> reference r; plant -> measured p; axis controllers; contour error
estimator -> CCC -> coupling gains; u = sat(u_axis + u_ccc) -> plant. One copy of this loop
serves the convenience API, the environments and the optimisers.

Small kernels called every tick (here and in plant, servo, contour, motion and paths) are
compiled with ``inline="always"``: numba does not inline one njit function into another at
the LLVM level, and the calls (9-float tuple returns, array arguments) cost more than the
work. With one segment-visit site in nearest_window and the reference point reused by the
ground truth, inlining took the loop from 1.2e6 to ~2.6e6 member-ticks/s (measured with
benchmarks/loop_throughput.py), at the price of a longer first compile.

Reference counting. Every array value numba makes in compiled code (a view ``a[b]``, an
array handed to an inlined function) calls ``NRT_incref``/``NRT_decref``; on an owned array
those are atomic instructions, and perf put ~30 % of the tick there. Three measures remove
them, together ~2.6e6 -> ~4.3e6 member-ticks/s:

* :func:`run_ticks` borrows its arrays (:func:`contour_gym._blob.borrow`): views without an
  owner, whose reference counting does nothing;
* the per-tick kernels index row tables (``p[i, AX_M]`` with ``i = b * A + a``) instead of
  taking row views;
* :func:`_member_run` is compiled without numba's reference counting (its private
  ``_nrt=False`` option; numba refuses to compile a function that then allocates). It
  allocates nothing, and no array it makes outlives it.

Inlining the windowed nearest-point search into the tick as well was measured at ~4.6e6,
but it added ~30 s to the first compile and ~2.5 min to the test suite's compiles, so the
search stays a call.
"""

from __future__ import annotations

import math
from typing import Any

import numba

from contour_gym._blob import borrow, flat, rows2, rows3, view1, view2, view3
from contour_gym.contour._kernel import EST_GROUND_TRUTH, estimate, ground_truth_from, history_push
from contour_gym.motion import IS_A, IS_DONE, IS_S, IS_V, interp_tick
from contour_gym.paths._geom import eval_path
from contour_gym.plant._kernel import AX_UMAX, ST_V, ST_X, axis_tick, measure
from contour_gym.servo._kernel import axis_commit, axis_control, pid_commit, pid_output

# acc_c[b, c, :]: contour error sums over the window's active ticks
AC_ABS, AC_SQ, AC_MAX, AC_N = 0, 1, 2, 3
# acc_a[b, a, :]: tracking error sums and control total variation
AA_ABS, AA_SQ, AA_MAX, AA_TV = 0, 1, 2, 3
# last[b, c, :]: the last tick's true and estimated contour error
LS_TRUE, LS_EST = 0, 1
# work rows (per axis): reference, its derivatives, true and measured position, control
W_R, W_RDOT, W_RDDOT, W_X, W_Y, W_U = 0, 1, 2, 3, 4, 5
N_W = 6

STATUS_OK, STATUS_FAILED, STATUS_PAUSED = 0, 1, 2
STATE_LIMIT = 1e3  # |x| in m or |v| in m/s beyond this is a diverged member


@numba.njit(cache=True, inline="always")
def _reference(kind, s0, data, c_axes, c_off, s, v, acc, work):  # type: ignore[no-untyped-def]
    # r = P(s) + offset, r' = P'(s) v, r'' = P''(s) v^2 + P'(s) a, written per axis
    px, py, pz, tx, ty, tz, kx, ky, kz = eval_path(kind, s0, data, s)
    for c in range(c_axes.shape[0]):
        for j in range(3):
            a = c_axes[c, j]
            if a < 0:
                continue
            p, t, k = (px, tx, kx) if j == 0 else ((py, ty, ky) if j == 1 else (pz, tz, kz))
            work[W_R, a] = p + c_off[c, j]
            work[W_RDOT, a] = t * v
            work[W_RDDOT, a] = k * v * v + t * acc
    return px, py, pz


@numba.njit(cache=True, inline="always")
def _contour_coords(c_axes, c_off, c, pos, row):  # type: ignore[no-untyped-def]
    # contour c's coordinates of the axis positions pos[row, :], its offset removed
    dim = 2 if c_axes[c, 2] < 0 else 3
    p0 = pos[row, c_axes[c, 0]] - c_off[c, 0]
    p1 = pos[row, c_axes[c, 1]] - c_off[c, 1]
    p2 = pos[row, c_axes[c, 2]] - c_off[c, 2] if dim == 3 else 0.0
    return dim, p0, p1, p2


@numba.njit(cache=True, inline="always")
def _accumulate_axes(acc, b, u_last, work, n_axes):  # type: ignore[no-untyped-def]
    for a in range(n_axes):
        i = b * n_axes + a
        e = work[W_R, a] - work[W_X, a]
        acc[i, AA_ABS] += abs(e)
        acc[i, AA_SQ] += e * e
        acc[i, AA_MAX] = max(acc[i, AA_MAX], abs(e))
        acc[i, AA_TV] += abs(work[W_U, a] - u_last[b, a])


@numba.njit(cache=True, inline="always")
def _accumulate_contour(acc, q, eps):  # type: ignore[no-untyped-def]
    acc[q, AC_ABS] += abs(eps)
    acc[q, AC_SQ] += eps * eps
    acc[q, AC_MAX] = max(acc[q, AC_MAX], abs(eps))
    acc[q, AC_N] += 1.0


@numba.njit(cache=True, inline="always")
def _ccc(p, w, st, q, axes, c, dim, eps, g0, g1, g2, ts, work):  # type: ignore[no-untyped-def]
    # Contour row q = b * C + c; its PID state rows are 3 q + i.
    # 2-D: the papers' scalar PID on the signed eps, distributed by C (one state, row 3 q).
    # 3-D: eps = |eps_vec| >= 0 cannot carry integral action, so a PID acts on each signed
    # component eps_vec_i = C_i eps (one state per coordinate, row 3 q + i).
    if dim == 2:
        big_u = pid_output(p, q, st, 3 * q, eps, 0.0, ts)
        work[W_U, axes[c, 0]] += w[q, 0] * g0 * big_u
        work[W_U, axes[c, 1]] += w[q, 1] * g1 * big_u
        pid_commit(st, 3 * q, eps, ts, big_u, math.inf)
        return
    for i in range(3):
        e_i = (g0 if i == 0 else (g1 if i == 1 else g2)) * eps
        u_i = pid_output(p, q, st, 3 * q + i, e_i, 0.0, ts)
        work[W_U, axes[c, i]] += w[q, i] * u_i
        pid_commit(st, 3 * q + i, e_i, ts, u_i, math.inf)


# numba's private ``_nrt`` option: compiled without reference counting (module docstring)
_NO_REFCOUNT: dict[str, Any] = {"cache": True, "_nrt": False}


@numba.njit(**_NO_REFCOUNT)
def _member_run(  # type: ignore[no-untyped-def]  # noqa: C901
    b,
    n,
    k0,
    ts,
    nsub,
    kind,
    s0,
    data,
    bound,
    c_axes,
    c_off,
    ax_p,
    rip,
    dist,
    ad,
    bd,
    ax_s,
    ctrl_kind,
    ctrl_p,
    ctrl_s,
    ccc_p,
    ccc_w,
    ccc_s,
    est_kind,
    est_p,
    hist,
    ip_p,
    ip_s,
    length,
    foot,
    last,
    noise,
    acc_c,
    acc_a,
    ep_c,
    ep_a,
    u_last,
    y_last,
    rec,
    record,
    work,
    meas_exact,
):
    """Run ``n`` servo ticks of batch member ``b`` from its local tick ``k0``.

    Returns False when its state diverged. Per-axis and per-contour arrays come as row
    tables (row ``b * A + a``, ``b * C + c``; see :func:`run_ticks`).

    The tick body is written inline here: a call per tick with this many array arguments
    cost more than the tick itself.
    """
    n_axes = work.shape[1]
    n_c = c_axes.shape[0]
    has_noise = noise.shape[1] > 0
    hb = hist[b]
    for j in range(n):
        k = k0 + j
        active = ip_s[b, IS_DONE] < 0.0
        interp_tick(length, ts, ip_p, ip_s, b, k)
        s, v = ip_s[b, IS_S], ip_s[b, IS_V]
        rx, ry, rz = _reference(kind, s0, data, c_axes, c_off, s, v, ip_s[b, IS_A], work)
        for a in range(n_axes):
            i = b * n_axes + a
            work[W_X, a] = ax_s[i, ST_X]
            w = noise[b, j, n_axes + a] if has_noise else 0.0
            work[W_Y, a] = measure(ax_p, i, work[W_X, a], w)
            y_last[b, a] = work[W_Y, a]
            work[W_U, a] = axis_control(
                ctrl_kind,
                ctrl_p,
                ctrl_s,
                i,
                work[W_R, a],
                work[W_RDOT, a],
                work[W_RDDOT, a],
                work[W_Y, a],
                ts,
            )
        for c in range(n_c):
            q = b * n_c + c
            dim, p0, p1, p2 = _contour_coords(c_axes, c_off, c, work, W_X)
            eps, g0, g1, g2, sf = ground_truth_from(
                kind, s0, data, bound, dim, p0, p1, p2, s, rx, ry, rz
            )
            foot[b, c] = sf
            eh = eps
            if not (meas_exact and est_kind == EST_GROUND_TRUTH):  # else: already computed
                if not meas_exact:
                    dim, p0, p1, p2 = _contour_coords(c_axes, c_off, c, work, W_Y)
                eh, g0, g1, g2 = estimate(
                    est_kind,
                    est_p,
                    kind,
                    s0,
                    data,
                    bound,
                    dim,
                    p0,
                    p1,
                    p2,
                    s,
                    v,
                    ip_s[b, IS_A],
                    hb,
                    ts,
                )
            _ccc(ccc_p, ccc_w, ccc_s, q, c_axes, c, dim, eh, g0, g1, g2, ts, work)
            last[b, c, LS_TRUE], last[b, c, LS_EST] = eps, eh
            if active:
                _accumulate_contour(acc_c, q, eps)
                _accumulate_contour(ep_c, q, eps)
            if record:
                rec[b, j, 2 + 3 * n_axes + 2 * c] = eps
                rec[b, j, 3 + 3 * n_axes + 2 * c] = eh
        history_push(hb, s)
        for a in range(n_axes):
            i = b * n_axes + a
            u_max = ax_p[i, AX_UMAX]
            axis_commit(
                ctrl_kind,
                ctrl_p,
                ctrl_s,
                i,
                work[W_R, a],
                work[W_RDOT, a],
                work[W_RDDOT, a],
                work[W_Y, a],
                ts,
                work[W_U, a],
                u_max,
            )
            work[W_U, a] = min(max(work[W_U, a], -u_max), u_max)
        if active:
            _accumulate_axes(acc_a, b, u_last, work, n_axes)
            _accumulate_axes(ep_a, b, u_last, work, n_axes)
        if record:
            rec[b, j, 0], rec[b, j, 1] = s, v
            for a in range(n_axes):
                rec[b, j, 2 + a] = work[W_R, a]
                rec[b, j, 2 + n_axes + a] = work[W_X, a]
                rec[b, j, 2 + 2 * n_axes + a] = work[W_U, a]
        ok = True
        for a in range(n_axes):
            i = b * n_axes + a
            u_last[b, a] = work[W_U, a]
            w = noise[b, j, a] if has_noise else 0.0
            axis_tick(ax_p, rip, dist, ad, bd, ax_s, i, work[W_U, a], k * ts, ts, nsub, w)
            if not (abs(ax_s[i, ST_X]) < STATE_LIMIT and abs(ax_s[i, ST_V]) < STATE_LIMIT):
                ok = False
        if not ok:
            return False
    return True


# The arrays of a ServoLoop's float and int blobs, in layout order (contour_gym._blob).
FLOAT_ARRAYS = (
    "ax_p", "rip", "dist", "ad", "bd", "ax_s", "ctrl_p", "ctrl_s", "ccc_p", "ccc_w", "ccc_s",
    "est_p", "hist", "ip_p", "ip_s", "foot", "last", "acc_c", "acc_a", "ep_c", "ep_a",
    "u_last", "y_last", "work", "c_off",
)  # fmt: skip
I_CCC_P, I_EST_P, I_IP_P, I_IP_S = 8, 11, 13, 14
I_LAST, I_ACC_C, I_Y_LAST, I_C_OFF = 16, 17, 22, 24
I_C_AXES, I_STATUS = 0, 1
assert FLOAT_ARRAYS.index("ccc_p") == I_CCC_P and FLOAT_ARRAYS.index("ip_s") == I_IP_S
assert FLOAT_ARRAYS.index("last") == I_LAST and FLOAT_ARRAYS.index("acc_c") == I_ACC_C
assert FLOAT_ARRAYS.index("y_last") == I_Y_LAST and FLOAT_ARRAYS.index("c_off") == I_C_OFF
assert FLOAT_ARRAYS.index("ip_p") == I_IP_P and FLOAT_ARRAYS.index("est_p") == I_EST_P


@numba.njit(cache=True)
def run_ticks(  # type: ignore[no-untyped-def]
    n,
    k0,
    ts,
    nsub,
    length,
    record,
    meas_exact,
    ctrl_kind,
    est_kind,
    kind,
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
    """Run ``n`` ticks for every member whose status is OK; a diverging member is flagged.

    ``fb``/``fl`` and ``ib``/``il`` are the float and int blobs and their layouts (arrays in
    the order of ``FLOAT_ARRAYS`` and (c_axes, status, k_start)). ``acc_*`` receive the sums
    of just these ticks, ``ep_*`` the episode's running sums (kept in the kernel so they do
    not depend on how an episode is cut into calls). ``k0`` is the loop's tick; member ``b``
    lives in local time ``k0 - k_start[b]`` (vector env members restart at different ticks).
    """
    # borrowed: the views made here and in the callees carry no owner to count
    fb, ib, noise, rec = borrow(fb), borrow(ib), borrow(noise), borrow(rec)  # type: ignore[call-arg]
    kind, s0, data, bound = borrow(kind), borrow(s0), borrow(data), borrow(bound)
    flat(fb, fl, I_ACC_C)[:] = 0.0  # the window sums acc_c and acc_a start at zero
    flat(fb, fl, I_ACC_C + 1)[:] = 0.0
    # per-axis and per-contour arrays as row tables: the kernels index rows, never take views
    ax_p, rip, dist = rows2(fb, fl, 0), rows3(fb, fl, 1), rows2(fb, fl, 2)
    ad, bd, ax_s = rows3(fb, fl, 3), rows3(fb, fl, 4), rows2(fb, fl, 5)
    ctrl_p, ctrl_s, ccc_p = rows2(fb, fl, 6), rows2(fb, fl, 7), rows2(fb, fl, 8)
    ccc_w, ccc_s, est_p = rows2(fb, fl, 9), rows2(fb, fl, 10), view1(fb, fl, 11)
    hist, ip_p, ip_s = view2(fb, fl, 12), view2(fb, fl, 13), view2(fb, fl, 14)
    foot, last, acc_c = view2(fb, fl, 15), view3(fb, fl, 16), rows2(fb, fl, 17)
    acc_a, ep_c, ep_a = rows2(fb, fl, 18), rows2(fb, fl, 19), rows2(fb, fl, 20)
    u_last, y_last, work = view2(fb, fl, 21), view2(fb, fl, 22), view2(fb, fl, 23)
    c_off = view2(fb, fl, 24)
    c_axes, status, k_start = view2(ib, il, 0), view1(ib, il, 1), view1(ib, il, 2)
    for b in range(ip_s.shape[0]):
        if status[b] != STATUS_OK:
            continue
        ok = _member_run(
            b,
            n,
            k0 - k_start[b],
            ts,
            nsub,
            kind,
            s0,
            data,
            bound,
            c_axes,
            c_off,
            ax_p,
            rip,
            dist,
            ad,
            bd,
            ax_s,
            ctrl_kind,
            ctrl_p,
            ctrl_s,
            ccc_p,
            ccc_w,
            ccc_s,
            est_kind,
            est_p,
            hist,
            ip_p,
            ip_s,
            length,
            foot,
            last,
            noise,
            acc_c,
            acc_a,
            ep_c,
            ep_a,
            u_last,
            y_last,
            rec,
            record,
            work,
            meas_exact,
        )
        if not ok:
            status[b] = STATUS_FAILED
