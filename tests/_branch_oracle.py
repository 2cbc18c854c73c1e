"""A brute-force oracle of the true contour error, for paths of lines and plain arcs.

Written apart from the library's search (:mod:`contour_gym.paths._branch`): no tree, no
bounding spheres, no binary search. Every segment is searched in closed form, in numpy, and
the branch is worked out per segment from the turning, as the definition reads: the stretch
from the previous foot to the reference, extended while the path has turned less than 180
degrees beyond it (laps unwrapped on a closed path). Only the path's geometry is taken from
its table (line starts and directions, arc centres, frames, radii).
"""

from __future__ import annotations

import numpy as np

LINE, HELIX = 0, 1
TIE_D2 = 1e-24  # the library's tie: within this, the point farther along wins


class Oracle:
    """The true foot point of a 2-D or 3-D path of lines and arcs, by brute force."""

    def __init__(self, path) -> None:
        t = path.table
        if np.any((t.kind != LINE) & ((t.kind != HELIX) | (t.data[:, 14] != 0.0))):
            raise ValueError("the oracle takes lines and plain arcs only")
        self.kind, self.s0, self.data = t.kind, t.s0, t.data
        self.n = t.n_segments
        self.length = float(t.s0[-1])
        self.seg_len = np.diff(t.s0)
        self.closed = bool(path.closed)
        self._turning()

    # ------------------------------------------------------------------------- geometry
    def _tangent(self, i: int, t: float) -> np.ndarray:
        d = self.data[i]
        if self.kind[i] == LINE:
            u = d[3:6].copy()
        else:
            w, phi = d[13], d[13] * t
            u = d[12] * w * (np.cos(phi) * d[6:9] - np.sin(phi) * d[3:6])
        return u / np.linalg.norm(u)

    @staticmethod
    def _angle(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))

    def _turning(self) -> None:
        # turning at each segment start (its start corner included) and within each segment,
        # accumulated in path order
        self.t_in = np.array([0.0 if k == LINE else abs(self.data[i, 12] * self.data[i, 13] ** 2)
                              * self.seg_len[i] for i, k in enumerate(self.kind)])
        self.t_start = np.zeros(self.n)
        total = 0.0
        for i in range(self.n):
            if i > 0:
                total += self._angle(self._tangent(i - 1, self.seg_len[i - 1]),
                                     self._tangent(i, 0.0))
            self.t_start[i] = total
            total += self.t_in[i]
        self.t_end = total
        close = self._angle(self._tangent(self.n - 1, self.seg_len[-1]), self._tangent(0, 0.0))
        self.period = total + close if self.closed else np.inf

    def _segment_nearest(self, i: int, p: np.ndarray, ta: float, tb: float) -> tuple[float, float]:
        # (t, d2) of the nearest point of segment i to p over local [ta, tb], closed form
        d = self.data[i]
        cands = [ta, tb]
        if self.kind[i] == LINE:
            cands.append(float(np.clip(np.dot(p - d[0:3], d[3:6]), ta, tb)))
        else:
            q = p - d[0:3]
            theta = np.arctan2(np.dot(q, d[6:9]), np.dot(q, d[3:6]))
            w = d[13]
            lo, hi = sorted((w * ta, w * tb))
            phi = theta + np.ceil((lo - theta) / (2 * np.pi)) * 2 * np.pi
            while phi <= hi:
                cands.append(float(np.clip(phi / w, ta, tb)))
                phi += 2 * np.pi
        pts = np.array([self._point(i, t) for t in cands])
        d2 = np.sum((pts - p) ** 2, axis=1)
        k = int(np.argmin(d2))
        return cands[k], float(d2[k])

    def _point(self, i: int, t: float) -> np.ndarray:
        d = self.data[i]
        if self.kind[i] == LINE:
            return d[0:3] + t * d[3:6]
        phi = d[13] * t
        return d[0:3] + d[12] * (np.cos(phi) * d[3:6] + np.sin(phi) * d[6:9])

    def point(self, s: float) -> np.ndarray:
        """The path's point at arc length ``s`` in [0, L]."""
        i = int(np.clip(np.searchsorted(self.s0, s, side="right") - 1, 0, self.n - 1))
        return self._point(i, s - self.s0[i])

    # ------------------------------------------------------------------------- the branch
    def _turn(self, s: float, left: bool) -> float:
        # T(s) unwrapped, the turning from the start up to s; a corner at s itself counted
        # unless `left` (the left limit)
        lap, r = 0.0, min(max(s, 0.0), self.length)
        if self.closed:
            lap = np.floor(s / self.length)
            r = s - lap * self.length
        base = lap * self.period if self.closed else 0.0
        for i in range(self.n):
            a, b = self.s0[i], self.s0[i + 1]
            inside = (a < r <= b) if left else (a <= r < b or (i == self.n - 1 and r >= b))
            if inside:
                return base + self.t_start[i] + self.t_in[i] * (r - a) / self.seg_len[i]
        return base - (self.period - self.t_end)  # left limit at a lap start (closed)

    def _allowed(self, i: int, lap: int, a: float, b: float) -> tuple[float, float] | None:
        """Segment i's local interval (in lap `lap`) inside the branch of the stretch [a, b].

        On the segment T runs linearly, t0 + rate t (t0 its start corner included; the point
        t = 0 itself is the previous segment's end too, which decides it after the stretch).
        Before the stretch a point y is in if T(a-) - T(y) < pi, after it if
        T(y-) - T(b) < pi.
        """
        s_a = lap * self.length + self.s0[i]
        t0 = (lap * self.period if self.closed else 0.0) + self.t_start[i]
        rate = self.t_in[i] / self.seg_len[i]
        lo_t, hi_t = 0.0, float(self.seg_len[i])
        if s_a < a:  # some of the segment lies before the stretch
            limit = self._turn(a, True) - np.pi
            flat = -np.inf if t0 > limit else np.inf  # T constant: all of it or nothing
            cut = (limit - t0) / rate if rate > 0.0 else flat
            lo_t = max(lo_t, min(cut, a - s_a))
        if s_a + hi_t > b:  # some of it lies after the stretch
            limit = self._turn(b, False) + np.pi
            flat = np.inf if t0 < limit else -np.inf
            cut = (limit - t0) / rate if rate > 0.0 else flat
            hi_t = min(hi_t, max(cut, b - s_a))
        if hi_t < lo_t:
            return None
        return lo_t, hi_t

    def nearest(self, p: np.ndarray, s_from: float, s_to: float) -> tuple[float, float]:
        """(s, distance) of the branch's nearest point, the library's tie rule."""
        a = s_from
        if self.closed:
            while a - s_to > 0.5 * self.length:
                a -= self.length
            while s_to - a > 0.5 * self.length:
                a += self.length
        a, b = min(a, s_to), max(a, s_to)
        laps = (-2, -1, 0, 1, 2) if self.closed else (0,)
        cands = []
        for lap in laps:
            for i in range(self.n):
                got = self._allowed(i, lap, a, b)
                if got is None:
                    continue
                t, d2 = self._segment_nearest(i, p, *got)
                cands.append((d2, min(self.s0[i] + t, self.s0[i + 1])))
        best = min(c[0] for c in cands)
        s = max(c[1] for c in cands if c[0] <= best + TIE_D2)
        return s, float(np.sqrt(best))

    def global_nearest(self, p: np.ndarray) -> tuple[float, float]:
        """(s, distance) of the whole path's nearest point."""
        cands = [self._segment_nearest(i, p, 0.0, self.seg_len[i]) for i in range(self.n)]
        k = int(np.argmin([c[1] for c in cands]))
        return self.s0[k] + cands[k][0], float(np.sqrt(cands[k][1]))

    def track(self, points: np.ndarray, s_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The feet and distances along a trajectory, the previous foot carried (from 0)."""
        s_out, d_out = np.empty(len(points)), np.empty(len(points))
        prev = 0.0
        for k, p in enumerate(points):
            prev, d_out[k] = self.nearest(p, prev, float(s_ref[k]))
            s_out[k] = prev
        return s_out, d_out
