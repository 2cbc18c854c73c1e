"""Compiled fuzzy inference: plain numba kernels on plain arrays, callable from other kernels.

**Exact inference.** :func:`mamdani_exact_into` replicates skfuzzy's arithmetic (the output
universe upsampled at the points where each clipped set crosses its cut, the aggregate sampled
there, its piecewise-linear centroid) and matches ``ControlSystemSimulation`` to < 1e-15 of
the output range, but costs a few microseconds per member (601-sample output universes).

**Surface.** The default for two-input systems is therefore a precomputed surface
(:class:`Surface`, :func:`surface_eval`), tabulated by the exact kernel
at build time. Plain bilinear interpolation of the output does not work: the min/max kinks and
the steep centroid near the universe edges (a half set of small area against a weakly firing
one) converge only linearly in the node count. What works: tabulate the aggregate's moment
and area (smooth piecewise polynomials of the firing strengths, without the division's
steepness) and interpolate each linearly on triangles, every grid square split along the
diagonal that interpolates the exact value at its centre better (so the split follows the
diagonal kinks ``mu_e = mu_de``), then divide. With 241 nodes per input (spacing 0.025 on
[-3, 3], 1/120 on [-1, 1]: half the spacing of the sets is a whole number of node spacings,
so the lines where two memberships of these evenly spaced sets are equal, along which min and
max kink, run along grid lines or square diagonals) the surface stays within 2.4e-4 of the
output range of the exact inference for the papers' systems.

**Product inference** (paper 001): :func:`product_basis_into` gives the fuzzy basis functions
and :func:`product_output_into` the centre-average outputs ``theta . xi``.

**Calling the kernels from other compiled code.** The lookups are plain
``@numba.njit(cache=True, inline="always")`` functions of plain arrays, e.g. in the servo
loop kernel, per member and tick::

    sf = fuzzy_pid_000().compiled.surface        # outside: tables, flips, grid, empty
    surface_eval_into(sf.tables, sf.flips, sf.grid, sf.empty, k_e * eps, k_de * deps, d_k)

A component that gets one constant float vector (a CCC law's ``data``,
:mod:`contour_gym.ccc`) takes the surface flattened by :func:`surface_table` and reads it with
:func:`surface_eval_flat` (views of the same numbers, then :func:`surface_eval`: bit for bit
the same output)::

    data = surface_table(fuzzy_pid_000().compiled.surface)    # outside, once
    d_kp = surface_eval_flat(data, 0, k_e * eps, k_de * deps)  # inside, per output

and for 001, with workspaces ``mu`` (n_in, S) and ``xi`` (L,)::

    c = adaptive_fuzzy_001().compiled
    product_basis_into(c.inputs.mf, c.inputs.meta, c.ant, x, mu, xi)
    product_output_into(theta, xi, y)
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from agents.fuzzy.system import Array

EPS = 2.220446049250313e-16  # np.finfo(float).eps, as skfuzzy's centroid floors the area
# columns of a variables' ``meta`` table (see SampledVariables)
M_LOW, M_HIGH, M_STEP, M_POINTS, M_SETS = 0, 1, 2, 3, 4


@numba.njit(cache=True, inline="always")
def _grid_point(j, n, lo, hi, step):
    # np.linspace(lo, hi, n)[j], bit for bit
    return hi if j == n - 1 else j * step + lo


@numba.njit(cache=True, inline="always")
def _has_nan(x):
    for v in x:  # noqa: SIM110 (a loop: no generator or temporary array in the kernel)
        if v != v:
            return True
    return False


@numba.njit(cache=True, inline="always")
def fuzzify_into(mf, meta, x, mu):
    """Membership of crisp inputs in every set, as ``np.interp`` on the sampled sets.

    Args:
        mf: (n_in, S, N) sampled sets, zero-padded.
        meta: (n_in, 5) universe low, high, step, sample count and set count per input.
        x: (n_in,) crisp inputs, not NaN; each is clipped to its universe.
        mu: (n_in, S) result.
    """
    for i in range(x.shape[0]):
        lo, hi, step = meta[i, M_LOW], meta[i, M_HIGH], meta[i, M_STEP]
        n = int(meta[i, M_POINTS])
        xc = min(max(x[i], lo), hi)
        j = min(int((xc - lo) / step), n - 2)
        uj = _grid_point(j, n, lo, hi, step)
        du = _grid_point(j + 1, n, lo, hi, step) - uj
        for s in range(int(meta[i, M_SETS])):
            if xc >= hi:
                mu[i, s] = mf[i, s, n - 1]
            else:
                f0 = mf[i, s, j]
                mu[i, s] = (mf[i, s, j + 1] - f0) / du * (xc - uj) + f0


@numba.njit(cache=True, inline="always")
def _fire_into(mu, ant, cons, cut):
    # min AND over the inputs, max aggregation of the rules per output set
    cut[:, :] = 0.0
    for r in range(ant.shape[0]):
        w = mu[0, ant[r, 0]]
        for i in range(1, ant.shape[1]):
            w = min(w, mu[i, ant[r, i]])
        for o in range(cons.shape[1]):
            t = cons[r, o]
            if w > cut[o, t]:
                cut[o, t] = w


@numba.njit(cache=True, inline="always")
def _aggregate_at(mf, meta, o, cut, j, x):
    # the clipped-and-maxed membership of output o at x inside universe interval j
    lo, hi, step, n = meta[o, M_LOW], meta[o, M_HIGH], meta[o, M_STEP], int(meta[o, M_POINTS])
    uj = _grid_point(j, n, lo, hi, step)
    du = _grid_point(j + 1, n, lo, hi, step) - uj
    y = 0.0
    for t in range(int(meta[o, M_SETS])):
        c = cut[o, t]
        if c > 0.0:
            f0 = mf[o, t, j]
            y = max(y, min(c, (mf[o, t, j + 1] - f0) / du * (x - uj) + f0))
    return y


@numba.njit(cache=True)
def _crossings(mf, meta, sup, o, t, c, buf, nb):
    # where set t of output o crosses its cut c (skfuzzy's _interp_universe_fast): at most
    # two for a unimodal set; appended to buf[nb:], returns the new count
    lo, hi, step, n = meta[o, M_LOW], meta[o, M_HIGH], meta[o, M_STEP], int(meta[o, M_POINTS])
    for j in range(max(sup[o, t, 0] - 1, 0), min(sup[o, t, 1], n - 2) + 1):
        a = mf[o, t, j]
        b = mf[o, t, j + 1]
        if (a >= c) != (b >= c) and nb < buf.shape[0]:
            uj = _grid_point(j, n, lo, hi, step)
            buf[nb] = uj + (c - a) * (_grid_point(j + 1, n, lo, hi, step) - uj) / (b - a)
            nb += 1
    return nb


@numba.njit(cache=True, inline="always")
def _sort_prefix(buf, nb):
    # insertion sort of buf[:nb] (nb <= 2 * sets)
    for a in range(1, nb):
        v = buf[a]
        k = a - 1
        while k >= 0 and buf[k] > v:
            buf[k + 1] = buf[k]
            k -= 1
        buf[k + 1] = v


@numba.njit(cache=True, inline="always")
def _fired_span(meta, sup, o, cut):
    # samples of output o around the sets that fired (the aggregate is 0 elsewhere)
    n = int(meta[o, M_POINTS])
    jlo, jhi = n, -1
    for t in range(int(meta[o, M_SETS])):
        if cut[o, t] > 0.0:  # a cut of 0 adds zeros, and crossings only at universe points
            jlo = min(jlo, sup[o, t, 0])
            jhi = max(jhi, sup[o, t, 1])
    return max(jlo - 1, 0), min(jhi + 1, n - 1), jhi >= 0


@numba.njit(cache=True)
def _centroid(mf, meta, sup, o, cut, agg, buf):
    # skfuzzy's CrispValueCalculator.defuzz: the universe upsampled at the cut crossings,
    # the aggregate sampled there, its piecewise-linear moment and area (0, 0 if empty)
    jlo, jhi, fired = _fired_span(meta, sup, o, cut)
    if not fired:
        return 0.0, 0.0
    lo, hi, step, n = meta[o, M_LOW], meta[o, M_HIGH], meta[o, M_STEP], int(meta[o, M_POINTS])
    agg[jlo : jhi + 1] = 0.0
    nb = 0
    for t in range(int(meta[o, M_SETS])):
        c = cut[o, t]
        if c > 0.0:
            for j in range(sup[o, t, 0], sup[o, t, 1] + 1):
                agg[j] = max(agg[j], min(c, mf[o, t, j]))
            nb = _crossings(mf, meta, sup, o, t, c, buf, nb)
    _sort_prefix(buf, nb)
    num = 0.0
    den = 0.0
    px = _grid_point(jlo, n, lo, hi, step)
    py = agg[jlo]
    k = 0
    for j in range(jlo + 1, jhi + 1):
        uj = _grid_point(j, n, lo, hi, step)
        while k < nb and buf[k] < uj:
            x = buf[k]
            y = _aggregate_at(mf, meta, o, cut, j - 1, x)
            num += (x - px) * (py * (2.0 * px + x) + y * (px + 2.0 * x))
            den += (x - px) * (py + y)
            px, py = x, y
            k += 1
        y = agg[j]
        num += (uj - px) * (py * (2.0 * px + uj) + y * (px + 2.0 * uj))
        den += (uj - px) * (py + y)
        px, py = uj, y
    return num / 6.0, 0.5 * den


@numba.njit(cache=True)
def mamdani_exact_into(
    in_mf, in_meta, ant, cons, out_mf, out_meta, out_sup, x, mu, cut, agg, buf, out, raw
):
    """Exact Mamdani inference of one member, as skfuzzy's ``ControlSystemSimulation``.

    min AND, min implication, max aggregation; centroid of the aggregate sampled on the
    output universe upsampled at the cut crossings, integrated piecewise linearly (what
    skfuzzy does). Inputs are clipped to their universes. An empty aggregate (no rule
    fired) gives the middle of the output universe (skfuzzy gives no output there).

    Args:
        in_mf: (n_in, S, N) sampled input sets (:class:`SampledVariables`).
        in_meta: (n_in, 5) input universes and set counts.
        ant: (R, n_in) antecedent set indices.
        cons: (R, n_out) consequent set indices.
        out_mf: (n_out, T, M) sampled output sets.
        out_meta: (n_out, 5) output universes and set counts.
        out_sup: (n_out, T, 2) first and last sample where each output set is > 0.
        x: (n_in,) crisp inputs (any NaN: every output NaN).
        mu: (n_in, S) workspace.
        cut: (n_out, T) workspace.
        agg: (M,) workspace.
        buf: (2 T,) workspace.
        out: (n_out,) result.
        raw: (n_out, 2) receives each aggregate's moment and area; pass (0, 2) to skip.
    """
    if _has_nan(x):
        out[:] = np.nan
        raw[:, :] = np.nan
        return
    fuzzify_into(in_mf, in_meta, x, mu)
    _fire_into(mu, ant, cons, cut)
    for o in range(out.shape[0]):
        moment, area = _centroid(out_mf, out_meta, out_sup, o, cut, agg, buf)
        if area > 0.0:
            out[o] = moment / max(area, EPS)
        else:
            out[o] = 0.5 * (out_meta[o, M_LOW] + out_meta[o, M_HIGH])
        if raw.shape[0] > 0:
            raw[o, 0] = moment
            raw[o, 1] = area


@numba.njit(cache=True)
def _mamdani_exact_batch(
    in_mf, in_meta, ant, cons, out_mf, out_meta, out_sup, x, out, raw
):
    mu = np.zeros((in_mf.shape[0], in_mf.shape[1]))
    cut = np.zeros((out_mf.shape[0], out_mf.shape[1]))
    agg = np.zeros(out_mf.shape[2])
    buf = np.zeros(2 * out_mf.shape[1])
    for b in range(x.shape[0]):
        mamdani_exact_into(
            in_mf,
            in_meta,
            ant,
            cons,
            out_mf,
            out_meta,
            out_sup,
            x[b],
            mu,
            cut,
            agg,
            buf,
            out[b],
            raw[b],
        )


@numba.njit(cache=True, inline="always")
def _cell(x, lo, step, n):
    # interval index and fraction of x on the nodes lo + k step, k < n, clipped to the ends
    u = (x - lo) / step
    if u <= 0.0:
        return 0, 0.0
    if u >= n - 1:
        return n - 2, 1.0
    i = min(int(u), n - 2)
    return i, u - i


@numba.njit(cache=True, inline="always")
def _split_square(tables, flips, o, p, i, k, t, s):
    # linear interpolation on the half of square (i, k) that holds (t, s); the square is
    # split along the diagonal flips[o, p, i, k] marks (0: (i, k)-(i+1, k+1), 1: the other)
    f00 = tables[o, p, i, k]
    f10 = tables[o, p, i + 1, k]
    f01 = tables[o, p, i, k + 1]
    f11 = tables[o, p, i + 1, k + 1]
    if flips[o, p, i, k] == 0:
        if t >= s:
            return f00 + t * (f10 - f00) + s * (f11 - f10)
        return f00 + s * (f01 - f00) + t * (f11 - f01)
    if t + s <= 1.0:
        return f00 + t * (f10 - f00) + s * (f01 - f00)
    return f11 + (1.0 - t) * (f01 - f11) + (1.0 - s) * (f10 - f11)


@numba.njit(cache=True, inline="always")
def _surface_ratio(tables, flips, empty, o, i, k, t, s):
    area = _split_square(tables, flips, o, 1, i, k, t, s)
    if area <= 0.0:
        return empty[o]
    return _split_square(tables, flips, o, 0, i, k, t, s) / max(area, EPS)


@numba.njit(cache=True, inline="always")
def surface_eval(tables, flips, grid, empty, o, x0, x1):
    """Output ``o`` of a two-input Mamdani surface at one point; inlinable into other kernels.

    The output is ``moment / area`` of the aggregate, both interpolated linearly on the
    triangles of a node grid whose squares are split along the diagonal that follows the
    min/max kinks (:class:`Surface`).

    Args:
        tables: (n_out, 2, G0, G1) moment and area of each output's aggregate at the nodes
            ``(grid[0] + i grid[1], grid[2] + k grid[3])``.
        flips: (n_out, 2, G0 - 1, G1 - 1) uint8 diagonal of each square.
        grid: (4,) first node and node spacing of input 0, then of input 1.
        empty: (n_out,) output where the aggregate is empty (middle of the output universe).
        o: Output index.
        x0: First crisp input; clipped to the grid (its universe).
        x1: Second crisp input; clipped to the grid.

    Returns:
        The output (NaN if an input is NaN).
    """
    if x0 != x0 or x1 != x1:
        return np.nan
    i, t = _cell(x0, grid[0], grid[1], tables.shape[2])
    k, s = _cell(x1, grid[2], grid[3], tables.shape[3])
    return _surface_ratio(tables, flips, empty, o, i, k, t, s)


@numba.njit(cache=True, inline="always")
def surface_eval_into(tables, flips, grid, empty, x0, x1, out):
    """Every output of a two-input Mamdani surface at one point (the cell is found once).

    Args:
        tables: (n_out, 2, G0, G1) moment and area at the nodes (see :func:`surface_eval`).
        flips: (n_out, 2, G0 - 1, G1 - 1) uint8 diagonal of each square.
        grid: (4,) first node and node spacing of input 0, then of input 1.
        empty: (n_out,) output where the aggregate is empty.
        x0: First crisp input; clipped to the grid.
        x1: Second crisp input; clipped to the grid.
        out: (n_out,) result (NaN if an input is NaN).
    """
    if x0 != x0 or x1 != x1:
        out[:] = np.nan
        return
    i, t = _cell(x0, grid[0], grid[1], tables.shape[2])
    k, s = _cell(x1, grid[2], grid[3], tables.shape[3])
    for o in range(tables.shape[0]):
        out[o] = _surface_ratio(tables, flips, empty, o, i, k, t, s)


@numba.njit(cache=True)
def _surface_batch(tables, flips, grid, empty, x, out):
    for b in range(x.shape[0]):
        surface_eval_into(tables, flips, grid, empty, x[b, 0], x[b, 1], out[b])


@dataclass(frozen=True, eq=False)
class Surface:
    """A two-input Mamdani system tabulated for :func:`surface_eval` (arrays only).

    Attributes:
        tables: (n_out, 2, G0, G1) moment and area of each output's aggregate at the nodes,
            from the exact compiled inference; the output is their ratio.
        flips: (n_out, 2, G0 - 1, G1 - 1) uint8: 0 splits a square along its
            (i, k)-(i+1, k+1) diagonal, 1 along the other: whichever interpolates the exact
            value at the square's centre better (so the split follows a min/max kink).
        grid: (4,) first node and node spacing of input 0, then of input 1.
        empty: (n_out,) output where the aggregate is empty (the middle of its universe).
    """

    tables: Array
    flips: NDArray[np.uint8]
    grid: Array
    empty: Array


# a surface as one float64 vector: header (n_out, G0, G1, grid[4]), empty (n_out,), tables
# (n_out, 2, G0, G1), flips (n_out, 2, G0 - 1, G1 - 1) as 0.0 / 1.0, all C order
FLAT_HEADER = 7


def surface_table(surface: Surface) -> Array:
    """A surface flattened into one float64 vector (the layout :func:`surface_views` reads).

    Header ``n_out, G0, G1`` and the 4 grid numbers, then ``empty``, ``tables`` and ``flips``
    (as 0.0 / 1.0), each in C order.

    Args:
        surface: A tabulated surface (``compile_system(system).surface``).

    Returns:
        The (7 + n_out + 2 n_out G0 G1 + 2 n_out (G0 - 1) (G1 - 1),) vector.
    """
    n_out, _, g0, g1 = surface.tables.shape
    head = np.array([n_out, g0, g1], dtype=np.float64)
    parts = (head, surface.grid, surface.empty, surface.tables, surface.flips)
    return np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in parts])


@numba.njit(cache=True, inline="always")
def surface_views(data):
    """``tables, flips, grid, empty`` of a :func:`surface_table` vector, as views (no copy).

    ``flips`` is a float view (0.0 / 1.0); :func:`surface_eval` compares it with 0 either way.
    """
    n_out, g0, g1 = int(data[0]), int(data[1]), int(data[2])
    a = FLAT_HEADER
    grid = data[3:a]
    empty = data[a : a + n_out]
    a += n_out
    size = n_out * 2 * g0 * g1
    tables = data[a : a + size].reshape((n_out, 2, g0, g1))
    a += size
    size = n_out * 2 * (g0 - 1) * (g1 - 1)
    flips = data[a : a + size].reshape((n_out, 2, g0 - 1, g1 - 1))
    return tables, flips, grid, empty


@numba.njit(cache=True, inline="always")
def surface_eval_flat(data, o, x0, x1):
    """:func:`surface_eval` on a :func:`surface_table` vector (the same output, bit for bit).

    Args:
        data: The flattened surface.
        o: Output index.
        x0: First crisp input; clipped to the grid.
        x1: Second crisp input; clipped to the grid.

    Returns:
        The output (NaN if an input is NaN).
    """
    tables, flips, grid, empty = surface_views(data)
    return surface_eval(tables, flips, grid, empty, o, x0, x1)


@numba.njit(cache=True)
def _surface_flat_batch(data, x, out):
    for b in range(x.shape[0]):
        for o in range(out.shape[1]):
            out[b, o] = surface_eval_flat(data, o, x[b, 0], x[b, 1])


@numba.njit(cache=True, inline="always")
def product_basis_into(mf, meta, ant, x, mu, xi):
    """Fuzzy basis functions of one member (singleton fuzzifier, product inference).

    ``xi_l = prod_i mu_{A_i^l}(x_i) / sum_l prod_i mu_{A_i^l}(x_i)``; all zeros if no rule
    fires. Inputs are clipped to their universes.

    Args:
        mf: (n_in, S, N) sampled input sets (:class:`SampledVariables`).
        meta: (n_in, 5) input universes and set counts.
        ant: (L, n_in) antecedent set indices (integers, or whole floats: a table read
            from one float vector).
        x: (n_in,) crisp inputs (any NaN: every basis function NaN).
        mu: (n_in, S) workspace.
        xi: (L,) result.
    """
    if _has_nan(x):
        xi[:] = np.nan
        return
    fuzzify_into(mf, meta, x, mu)
    total = 0.0
    for rule in range(ant.shape[0]):
        w = 1.0
        for i in range(ant.shape[1]):
            w *= mu[i, int(ant[rule, i])]
        xi[rule] = w
        total += w
    for rule in range(ant.shape[0]):
        xi[rule] = xi[rule] / total if total > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def product_output_into(theta, xi, out):
    """Centre-average outputs of one member, ``out[o] = sum_l theta[o, l] xi[l]``.

    Args:
        theta: (n_out, L) consequent centres.
        xi: (L,) basis functions (:func:`product_basis_into`).
        out: (n_out,) result.
    """
    for o in range(theta.shape[0]):
        y = 0.0
        for rule in range(xi.shape[0]):
            y += theta[o, rule] * xi[rule]
        out[o] = y


@numba.njit(cache=True)
def _product_batch(mf, meta, ant, theta, x, xi, out):
    mu = np.zeros((mf.shape[0], mf.shape[1]))
    for b in range(x.shape[0]):
        product_basis_into(mf, meta, ant, x[b], mu, xi[b])
        product_output_into(theta, xi[b], out[b])
