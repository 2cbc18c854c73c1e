"""Kernel template: one estimator over a batch of tool positions (the Python estimator API)."""

from __future__ import annotations

import math

import numba
import numpy as np

from contour_gym.contour._history import HIST_WIDTH
from contour_gym.contour._kernel import _fill_history, _row_finite, ground_truth, resolve
from contour_gym.jit.slots import EST_FOOT


@numba.njit(cache=True)
def estimate_many(code, search, est_p, kind, s0, data, bound, pos, s, s_hist, ds, mode, out, fell):
    """The estimate for every member: ``out[b] = (eps, c0, c1, c2)``, ``fell[b]``.

    ``code`` is the estimator's (slot ``EST_FOOT``); ``search``: it is the exact search itself.
    ``pos`` (B, dim) tool positions in path coordinates; ``s`` (B,) or (1,) references;
    ``s_hist`` (B or 1, n) previous references, most recent first (mode 1), or ``ds``
    (B,) or (1,) a constant interpolation step (mode 2); mode 0: the reference at rest.

    Returns:
        -1, or the first member whose input is not finite (its row is then not computed).
    """
    dim = pos.shape[1]
    hist = np.zeros(HIST_WIDTH)
    for b in range(pos.shape[0]):
        sb = s[b if s.shape[0] > 1 else 0]
        hrow = s_hist[b if s_hist.shape[0] > 1 else 0]
        db = ds[b if ds.shape[0] > 1 else 0]
        if not (
            _row_finite(pos[b])
            and math.isfinite(sb)
            and math.isfinite(db)
            and (mode != 1 or _row_finite(hrow))
        ):
            return b
        _fill_history(hist, sb, hrow, db, mode)
        p2 = pos[b, 2] if dim == 3 else 0.0
        if search:
            p0, p1 = pos[b, 0], pos[b, 1]
            eps, c0, c1, c2, _ = ground_truth(kind, s0, data, bound, dim, p0, p1, p2, sb)
            fb = False
        else:
            foot = EST_FOOT(code, est_p, kind, s0, data, bound, pos[b, 0], pos[b, 1], p2, sb, hist)
            p0, p1 = pos[b, 0], pos[b, 1]
            eps, c0, c1, c2, fb = resolve(foot, kind, s0, data, bound, dim, p0, p1, p2, sb)
        out[b, 0], out[b, 1], out[b, 2], out[b, 3] = eps, c0, c1, c2
        fell[b] = fb
    return -1
