"""Brute-force nearest point for the path tests: dense samples plus golden-section refinement."""

from __future__ import annotations

import numpy as np

_GOLD = (np.sqrt(5.0) - 1.0) / 2.0


def brute_nearest(path, pts, n=200_001):
    """Return (s, dist) of the nearest point to each row of pts (unsigned), by brute force."""
    s = np.linspace(0.0, path.length, n)
    samples = path.point(s)
    out_s = np.empty(len(pts))
    out_d = np.empty(len(pts))
    for m, p in enumerate(pts):
        k = int(np.argmin(np.sum((samples - p) ** 2, axis=1)))
        lo, hi = s[max(k - 1, 0)], s[min(k + 1, n - 1)]
        out_s[m], out_d[m] = _golden(path, p, lo, hi)
    return out_s, out_d


def _golden(path, p, lo, hi):
    def f(x):
        return float(np.sum((path.point(x) - p) ** 2))

    a, b = lo, hi
    c, d = b - _GOLD * (b - a), a + _GOLD * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(80):
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - _GOLD * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + _GOLD * (b - a)
            fd = f(d)
    cands = [(f(lo), lo), (f(hi), hi), (fc, c), (fd, d)]
    best = min(cands)
    return best[1], np.sqrt(best[0])


def points_near(path, rng, n, spread):
    """n random points within about `spread` (m) of the path."""
    s = rng.uniform(0.0, path.length, n)
    return path.point(s) + rng.normal(scale=spread / 2.0, size=(n, path.dim)), s
