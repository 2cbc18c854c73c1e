"""Interpolator: the reference's arc length per servo tick, from a feedrate program or a time law.

**Feedrate mode** (a CNC's interpolator). Every path segment has a programmed feedrate (one
value for a plain path; a G-code part's own F words, rapids at the machine's rapid rate); the
feed override ``ovr`` (a CNC panel's, or the feedrate env's ``F(k) = F(k-1) + dF(k)`` as
``ovr = F / F_nom``) scales the programmed feeds of cutting moves, never above the machine's
``max_feedrate``. The path speed follows the target within an acceleration limit (and
optionally a jerk limit), starting from rest and braking so that it meets every downstream
speed limit: the *junction* speeds of the :class:`Program` (0 at the path end, at exact stops
and dwells) and the feed of the next segments. ``accel = inf`` steps to the target at once (the
papers' ``x = R cos(w t)`` references, ``s_k = k F Ts``) and only stops where it must.

**Look-ahead planning** (:func:`build_program`): the junction speed between two segments
follows the junction-deviation rule of open-source motion controllers (Grbl's planner, S. Jeon
2011, also Marlin and Smoothieware): with ``theta`` the angle between the incoming and
outgoing directions and ``delta`` the path tolerance, ``v_j^2 = a delta sin(phi/2) / (1 -
sin(phi/2))``, ``phi = pi - theta`` (``v_j = inf`` straight on, ``0`` on a reversal); segments
are also capped at ``sqrt(a / kappa_max)`` (centripetal acceleration), and a backward pass makes
every junction limit reachable by braking at ``a``. Modes (``path_control``, or a G-code part's
own per-segment modes): ``"none"`` (constant feedrate, only the path end stops: the papers'
constant-feedrate runs), ``"G61"`` (exact stop at every segment end; the next block starts when
the axes are in position), ``"G61.1"`` (exact path: stops at real corners only), ``"G64"``
(blending with the tolerance ``path_tolerance``).

**Acc/dec time constant** (``Interpolator.time_constant`` T, a CNC's "cutting feed acc/dec
time constant"): with T > 0 the path speed changes at ``min(accel, F / T)``, ``F`` the
commanded feed of the current block (times the override). The rate falls only when the
reference needs no braking at the lower rate (not while the override is below the speed, nor
while a limit ahead needs braking), and rises only when it needs no braking at the rate it
holds, whatever the override and the blocks' feeds do: a stop under way brakes at the rate it
was planned with and arrives at rest (``fa`` keeps the rate's F). Turning the override up
during a stop does not make it later and harder.
So every speed change takes about T whatever the feedrate, as on a CNC whose acc/dec is set
by time constants: a faster feed accelerates and stops harder, and the error at its stops
grows with it. The look-ahead plans each segment at the same rate, ``min(accel, F_j / T)``
with ``F_j`` that segment's commanded feed at the run's starting override
(``Interpolator.plan_override``); a junction at the lower of its two segments' rates. So a
block's F word sets its own corners and curvature caps, not those of other blocks, and a
constant override ``k`` runs as the same program with every F word times ``k`` would; an
override turned during the run (the feedrate env's) changes the rate but not the plan.
T = 0 (default) keeps ``accel`` at every feed, in the plan too.

**Time-law mode** (a path carrying a :class:`~contour_gym.paths.TimeLaw`): the reference is a
prescribed ``s(t)``, e.g. 003's three-leaf ``theta = 2 pi f t``; the override scales time
(``tau += ovr Ts``) and the feedrate settings do not apply.

Per member the kernel keeps ``ip_s`` (:data:`IS`) and reads ``ip_p`` (:data:`IP`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numba
import numpy as np
from numpy.typing import NDArray

from contour_gym._schema import Param, Schema, state_schema
from contour_gym._validate import choice, non_negative, positive, positive_or_inf
from contour_gym.paths._batch import segment_ends
from contour_gym.paths._geom import CORNER_TOL

if TYPE_CHECKING:
    from contour_gym.paths import Path

Array = NDArray[np.float64]

IP_PARAMS = Schema(
    "interpolator",
    ovr=Param(1.0, non_negative, "feed override (fraction of the programmed feedrate)"),
    a_max=Param(math.inf, positive_or_inf, "tangential acceleration limit, m/s^2"),
    j_max=Param(math.inf, positive_or_inf, "tangential jerk limit, m/s^3"),
    f_max=Param(math.inf, positive_or_inf, "machine's maximum feedrate, m/s"),
    t_acc=Param(0.0, non_negative, "acc/dec time constant, s (0: accel = a_max)"),
)
IP = IP_PARAMS.col
IP_STATE = state_schema(
    "interpolator state", "s", "v", "a", "done", "seg", "hold", "wait", "tau", "fa"
)
IS = IP_STATE.col

RAPID, CUTTING = 1, 2  # Program.flags bits
PATH_CONTROLS = ("none", "G61", "G61.1", "G64")
DEFAULT_TOLERANCE = 1e-5  # m: G64 without P (Grbl's default junction deviation is 0.01 mm)


@dataclass(frozen=True)
class Interpolator:
    """Feedrate settings of a run.

    Attributes:
        feedrate: Nominal (programmed) feedrate F, m/s (> 0).
        accel: Tangential acceleration limit, m/s^2 (``inf`` = step to F at once).
        jerk: Tangential jerk limit, m/s^3 (``inf`` = none).
        max_feedrate: The machine's feedrate limit, m/s (commanded feeds are capped to it).
        rapid_rate: Speed of rapid (G0) moves, m/s (default ``max_feedrate``).
        time_constant: The CNC's acc/dec time constant T, s (module docstring): the path
            speed changes at ``min(accel, F / T)``; 0 (default) = at ``accel`` whatever F.
        plan_override: The feed override the look-ahead plans with under a time constant
            (the run's starting override; module docstring).
    """

    feedrate: float
    accel: float = math.inf
    jerk: float = math.inf
    max_feedrate: float = math.inf
    rapid_rate: float | None = None
    time_constant: float = 0.0
    plan_override: float = 1.0

    def __post_init__(self) -> None:
        positive(self.feedrate, "feedrate")
        for name in ("accel", "jerk", "max_feedrate"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and value > 0):
                raise ValueError(f"{name} must be > 0 (inf allowed), got {value!r}")
        if self.rapid_rate is not None:
            positive(self.rapid_rate, "rapid_rate")
        non_negative(self.time_constant, "time_constant")
        positive(self.plan_override, "plan_override")

    def planning_accels(self, feed: Array, rapid: NDArray[np.bool_]) -> Array:
        """Acceleration the look-ahead plans each segment with, m/s^2, (n,).

        ``accel``; under a time constant ``min(accel, F / T)``, F the segment's commanded
        feed: its programmed ``feed`` times :attr:`plan_override` (a rapid's unscaled), at
        most ``max_feedrate``, the rate the interpolator changes speed at in that block.
        """
        if self.time_constant <= 0.0:
            return np.full(feed.shape, float(self.accel))
        commanded = np.minimum(np.where(rapid, feed, feed * self.plan_override),
                               self.max_feedrate)
        return np.minimum(self.accel, np.maximum(commanded, 1e-9) / self.time_constant)

    @property
    def rapid(self) -> float:
        """Rapid rate, m/s (``rapid_rate``, else ``max_feedrate``, else 10 x the feedrate)."""
        if self.rapid_rate is not None:
            return float(self.rapid_rate)
        return self.max_feedrate if math.isfinite(self.max_feedrate) else 10.0 * self.feedrate

    def params(self, batch: int, override: float = 1.0) -> Array:
        """Kernel parameter rows (batch, IP_PARAMS.size)."""
        row = IP_PARAMS.row(
            ovr=override, a_max=self.accel, j_max=self.jerk, f_max=self.max_feedrate,
            t_acc=self.time_constant,
        )
        return np.repeat(row[None], batch, axis=0)


def initial_state(batch: int) -> Array:
    """Kernel state rows (batch, IP_STATE.size) at rest at the start of the path."""
    out = np.zeros((batch, IP_STATE.size))
    out[:, IS.done] = -1.0
    return out


@dataclass(frozen=True)
class Program:
    """Per-segment feedrates, speed caps and junction limits of a path (compiled arrays).

    Attributes:
        feed: (n,) programmed feedrate per segment, m/s (rapids at the rapid rate).
        flags: (n,) bits: RAPID (the override does not apply), CUTTING (the metrics count it).
        vcap: (n,) speed cap of each segment (centripetal limit), m/s.
        vj: (n,) highest speed at the end of each segment after the backward pass, m/s (0 at
            the path end, exact stops and dwells).
        wait: (n,) 1 where the next segment starts only when the axes are in position.
        dwell: (n,) ticks to wait after the end of each segment.
        nominal: The nominal (programmed cutting) feedrate, m/s.
    """

    feed: Array
    flags: Array
    vcap: Array
    vj: Array
    wait: Array
    dwell: Array
    nominal: float

    def arrays(self) -> tuple[Array, ...]:
        """The compiled arrays, in the loop's order."""
        return (self.feed, self.flags, self.vcap, self.vj, self.wait, self.dwell)

    @property
    def cutting(self) -> NDArray[np.bool_]:
        """(n,) whether each segment cuts (counts in the metrics)."""
        return (self.flags.astype(np.int64) & CUTTING) != 0


def junction_speed(t_in: Array, t_out: Array, accel: float, tolerance: float) -> float:
    """Junction-deviation speed limit between two unit directions (module docstring), m/s.

    >>> import numpy as np
    >>> round(junction_speed(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), 1.0, 5e-5), 5)
    0.01099
    >>> junction_speed(np.array([1.0, 0, 0]), np.array([1.0, 0, 0]), 1.0, 5e-5)
    inf
    """
    if not math.isfinite(accel):
        return math.inf if tolerance > 0 else (0.0 if _corner(t_in, t_out) else math.inf)
    cos_theta = -float(np.dot(t_in, t_out))
    if cos_theta <= -0.999999:  # straight on
        return math.inf
    sin_half = math.sqrt(max(0.5 * (1.0 - cos_theta), 0.0))
    if sin_half <= 0.0 or tolerance <= 0.0:
        return 0.0 if _corner(t_in, t_out) else math.inf
    return math.sqrt(accel * tolerance * sin_half / (1.0 - sin_half))


def _corner(t_in: Array, t_out: Array) -> bool:
    return float(np.linalg.norm(np.asarray(t_in) - np.asarray(t_out))) > CORNER_TOL


def _segment_ends(path: Path) -> tuple[Array, Array, Array]:
    t = path.table
    ends = segment_ends(t.kind, t.s0, t.data)
    return ends[:, 0, 3:], ends[:, 1, 3:], np.diff(t.s0)


def segment_max_curvature(path: Path) -> Array:
    """The largest curvature of each segment of ``path``, 1/m (9 samples each; arcs exact).

    The last sample is the float just before the segment's end: at the end itself a path
    gives the next segment's curvature (a line into an arc would take the arc's).
    """
    t = path.table
    s = t.s0[:-1, None] + np.linspace(0.0, np.diff(t.s0), 9, axis=1)
    s[:, -1] = np.maximum(np.nextafter(t.s0[1:], -np.inf), t.s0[:-1])
    out: Array = np.max(np.reshape(path.curvature(s.ravel()), s.shape), axis=1)
    return out


def _gcode_modes(path: Path, n: int) -> tuple[NDArray[Any], ...]:
    """(feed or NaN, rapid, cutting, exact_stop, tolerance or NaN, dwell seconds after)."""
    feed = np.asarray(getattr(path, "segment_feedrates", np.full(n, np.nan)), dtype=float)
    rapid = np.asarray(getattr(path, "rapid", np.zeros(n, bool)), dtype=bool)
    cutting = np.asarray(getattr(path, "cutting", ~rapid), dtype=bool)
    stop = np.asarray(getattr(path, "exact_stop", np.zeros(n, bool)), dtype=bool)
    tol = np.asarray(getattr(path, "blend_tolerance", np.full(n, np.nan)), dtype=float)
    return feed, rapid, cutting, stop, tol


def _dwell_after(path: Path, n: int) -> Array:
    before = np.asarray(getattr(path, "dwell_before", np.zeros(n)), dtype=float)
    after = np.zeros(n)
    after[:-1] = before[1:]
    after[-1] = float(getattr(path, "dwell_after_end", 0.0))
    return after


def build_program(
    path: Path,
    interpolator: Interpolator,
    ts: float,
    *,
    path_control: str | None = None,
    path_tolerance: float | None = None,
    use_program_feeds: bool = True,
) -> Program:
    """Per-segment feeds, caps and junction limits of ``path`` (module docstring).

    Args:
        path: The path (a G-code part's per-segment modes and feeds are honoured).
        interpolator: Feedrate, limits, rapid rate.
        ts: Servo tick, s (dwell ticks).
        path_control: ``"none"``, ``"G61"``, ``"G61.1"``, ``"G64"``, or None for the path's
            own modes (a G-code part's; ``"none"`` for other paths). A given mode replaces a
            part's own G61/G61.1/G64 choices; its mandatory stops (``mandatory_stops``: M
            codes, G28, dwells, changes between rapid and feed) stay.
        path_tolerance: Blending tolerance of ``"G64"``, m (default: a G-code part's own P
            words, else :data:`DEFAULT_TOLERANCE`).
        use_program_feeds: Run a G-code part at its own F words (else every cutting segment at
            ``interpolator.feedrate``).

    Returns:
        The :class:`Program`.
    """
    n = path.table.n_segments
    if path_control is not None:
        choice(path_control, "path_control", PATH_CONTROLS)
    feed, rapid, cutting, stop, tol = _gcode_modes(path, n)
    nominal = float(interpolator.feedrate)
    programmed = np.where(np.isfinite(feed) & use_program_feeds, feed, nominal)
    feed = np.where(rapid, interpolator.rapid, programmed)
    flags = rapid * RAPID + cutting * CUTTING
    has_modes = hasattr(path, "exact_stop")
    mode = path_control if path_control is not None else ("program" if has_modes else "none")
    tolerance = _tolerances(mode, tol, path_tolerance, n)
    dwell_s = _dwell_after(path, n)
    stop = _stops(path, mode, stop, dwell_s)
    a = interpolator.planning_accels(feed, rapid)
    vcap, vj, lengths = _speed_limits(path, mode, tolerance, a)
    vj[stop] = 0.0
    vj[-1] = 0.0
    _backward_pass(vj, vcap, lengths, a)
    return Program(
        np.ascontiguousarray(feed, dtype=float), np.ascontiguousarray(flags, dtype=float),
        vcap, vj, np.ascontiguousarray(stop, dtype=float),
        np.ascontiguousarray(np.round(dwell_s / ts), dtype=float), nominal,
    )


def _tolerances(mode: str, tol: Array, path_tolerance: float | None, n: int) -> Array:
    """Blending tolerance per segment, m: the program's P words (NaN: default) or one value."""
    tol_default = DEFAULT_TOLERANCE if path_tolerance is None else non_negative(
        path_tolerance, "path_tolerance")
    if mode == "program":
        return np.where(np.isnan(tol), tol_default, tol)
    return np.full(n, tol_default)


def _stops(path: Path, mode: str, stop: NDArray[Any], dwell_s: Array) -> NDArray[np.bool_]:
    """Where the motion comes to rest: the program's stops, or ``mode``'s and the mandatory.

    A given mode replaces the part's G61/G64 choices, never its mandatory stops; a dwell
    always stops.
    """
    if mode == "program":
        return np.asarray(stop, dtype=bool) | (dwell_s > 0)
    n = dwell_s.shape[0]
    kept = np.asarray(getattr(path, "mandatory_stops", np.zeros(n, bool)), dtype=bool)
    return np.full(n, mode == "G61") | kept | (dwell_s > 0)


def _speed_limits(path: Path, mode: str, tolerance: Array, accel: Array
                  ) -> tuple[Array, Array, Array]:
    """Curvature caps and junction limits before the backward pass, and segment lengths.

    ``accel`` (n,) is each segment's planning acceleration; a junction takes the lower of
    its two segments'. Under ``"none"`` nothing limits the speed but the path end and the
    stops.
    """
    n = path.table.n_segments
    t_in, t_out, lengths = _segment_ends(path)
    vcap = np.full(n, math.inf)
    vj = np.full(n, math.inf)
    if mode != "none":
        exact_path = mode == "G61.1"
        finite = np.isfinite(accel)
        if finite.any():
            kappa = segment_max_curvature(path)
            capped = finite & (kappa > 0)
            vcap[capped] = np.sqrt(accel[capped] / kappa[capped])
        for j in range(n - 1):
            delta = 0.0 if exact_path else float(tolerance[j])
            a = min(float(accel[j]), float(accel[j + 1]))
            vj[j] = junction_speed(t_out[j], t_in[j + 1], a, delta)
    return vcap, vj, lengths


def _backward_pass(vj: Array, vcap: Array, lengths: Array, accel: Array) -> None:
    # every junction limit reachable braking over the next segment at its planning accel
    n = vj.size
    for j in range(n - 2, -1, -1):
        a = float(accel[j + 1])
        reach = math.sqrt(vj[j + 1] ** 2 + 2.0 * a * lengths[j + 1]) if math.isfinite(
            a) else math.inf
        vj[j] = min(vj[j], vcap[j], vcap[j + 1], reach)


# ------------------------------------------------------------------------------ kernel


# The share of the jerk limit a braking curve is planned with. The follower (``_advance``)
# reaches the curve's deceleration only by J per tick, so it needs slack: planned at J / 2 it
# stops within J everywhere (tests/test_motion.py); at 0.7 J or J it reached the end at
# 1.5-13 mm/s and stepped to rest (measured on lines and random polylines).
JERK_PLAN = 0.5


@numba.njit(cache=True, inline="always")
def brake_speed(room, v, a, v_end, a_max, j_max, ts):
    """Highest speed for the coming tick from which the reference can still slow to ``v_end``.

    Picks ``v_new`` so that after this tick's travel ``(v + v_new) ts / 2`` the remaining
    ``room`` still holds the braking distance. Without a jerk limit it is the exact discrete
    constant-deceleration ramp, ``(v_new^2 - v_end^2) / (2A) + (v_new - v_end) ts / 2``. With
    one it is the jerk-limited stop from and to zero acceleration (:func:`jerk_brake_speed`),
    planned at ``JERK_PLAN`` of ``J``: an S-curve that arrives at ``v_end`` in finite time,
    planned from where a reference still speeding up has ended its acceleration
    (:func:`ramp_out`).
    """
    if math.isinf(a_max):
        return math.inf
    rest = room - 0.5 * v * ts
    if math.isinf(j_max):
        if rest <= 0.0:
            return v_end
        c = 0.5 * ts
        rhs = rest + v_end * v_end / (2.0 * a_max) + c * v_end
        return -a_max * c + math.sqrt((a_max * c) ** 2 + 2.0 * a_max * rhs)
    rest -= ramp_out(v, a, j_max)
    if rest <= 0.0:
        return v_end
    return jerk_brake_speed(rest, v_end, a_max, JERK_PLAN * j_max)


@numba.njit(cache=True, inline="always")
def ramp_out(v, a, j_max):
    """Distance a reference at speed ``v`` still speeding up (``a > 0``) covers ending it.

    Its acceleration falls at ``J`` for ``a / J``: ``v a / J + a^3 / (3 J^2)``; 0 for ``a <= 0``.
    """
    if a <= 0.0:
        return 0.0
    return v * a / j_max + a * a * a / (3.0 * j_max * j_max)


@numba.njit(cache=True)
def jerk_brake_speed(rest, v_end, a_max, j_max):
    """Speed ``v`` whose jerk-limited stop to ``v_end`` covers exactly ``rest``.

    From and to zero acceleration at jerk ``J`` and deceleration at most ``A``, slowing by
    ``dv = v - v_end`` takes ``T = 2 sqrt(dv / J)`` while ``dv <= A^2 / J`` (the deceleration
    a triangle), else ``T = dv / A + A / J`` (a trapezoid); the profile is point-symmetric, so
    the distance is ``(v + v_end) T / 2``. The triangle in ``y = sqrt(dv / J)`` is the cubic
    ``J y^3 + 2 v_end y = rest``, solved by Cardano's formula (one real root); the trapezoid
    is the quadratic ``v^2 + k v - (v_end^2 - k v_end + 2 A rest) = 0``, ``k = A^2 / J``.
    Not inlined: compiled once, not into every kernel (no preset sets a jerk limit).
    """
    k = a_max * a_max / j_max
    p = 2.0 * v_end / j_max
    q = rest / j_max
    root = math.sqrt(0.25 * q * q + p * p * p / 27.0)
    u = (0.5 * q + root) ** (1.0 / 3.0)
    y = u - p / (3.0 * u)
    dv = j_max * y * y
    if dv <= k:
        return v_end + dv
    return 0.5 * (-k + math.sqrt(k * k + 4.0 * (v_end * v_end - k * v_end + 2.0 * a_max * rest)))


@numba.njit(cache=True, inline="always")
def brake_reach(v, a, a_max, j_max, ts):
    """Room beyond which no limit needs braking yet at speed ``v``: twice the stop's distance.

    A stop at ``A`` takes ``v^2 / (2A)``; with a jerk limit at most ``v A / (2 J_plan)`` more
    (doubled too), after :func:`ramp_out` for a reference still speeding up.
    """
    reach = v * v / a_max + 2.0 * v * ts + 1e-6
    if not math.isinf(j_max):
        reach += v * a_max / (JERK_PLAN * j_max) + ramp_out(v, a, j_max)
    return reach


@numba.njit(cache=True, inline="always")
def _cap(p, b, prog_feed, prog_flags, prog_vcap, j):
    # speed cap of segment j: its feed (scaled by the override unless a rapid), the machine
    # limit and the centripetal cap
    f = prog_feed[j]
    if (int(prog_flags[j]) & RAPID) == 0:
        f *= p[b, IP.ovr]
    return min(f, p[b, IP.f_max], prog_vcap[j])


@numba.njit(cache=True, inline="always")
def _feed_rate(p, b, f):
    # the acceleration limit at the commanded feed f: a_max, or f / T under a time constant
    t_acc = p[b, IP.t_acc]
    if t_acc <= 0.0:
        return p[b, IP.a_max]
    return min(p[b, IP.a_max], max(f, 1e-9) / t_acc)


@numba.njit(cache=True, inline="always")
def _curve(p, st, b, s0, plan, ts, a_max):
    # the highest speed from which every junction limit ahead can still be met braking at
    # a_max: every junction within braking reach, however many (the program's junction speeds
    # are planned at its own acceleration, and under a time constant the reference brakes at
    # F / T, less at a low feed or override, over more junctions than any fixed window holds)
    prog_feed, prog_flags, prog_vcap, prog_vj = plan
    n = prog_feed.shape[0]
    s, v, a = st[b, IS.s], st[b, IS.v], st[b, IS.a]
    j_max = p[b, IP.j_max]
    curve = math.inf
    for j in range(int(st[b, IS.seg]), n):
        room = s0[j + 1] - s
        v_end = prog_vj[j]
        if j + 1 < n:
            v_end = min(v_end, _cap(p, b, prog_feed, prog_flags, prog_vcap, j + 1))
        curve = min(curve, brake_speed(room, v, a, v_end, a_max, j_max, ts))
        if math.isinf(a_max) or room > brake_reach(v, a, a_max, j_max, ts):
            break
    return curve


@numba.njit(cache=True, inline="always")
def _rate(p, st, b, s0, plan, ts):
    # this tick's acceleration limit. Under a time constant it is F / T, F the commanded feed
    # of the current block (``fa`` keeps the last tick's), but it changes only when the
    # reference needs no braking at the rate it leaves or takes. It falls only when the
    # reference needs no braking at the lower rate: while F is below the speed, or while a
    # limit ahead needs braking at the lower rate, the last rate holds, so that a stop planned
    # at one rate is made however the override and the blocks' feeds fall meanwhile (else the
    # reference would reach the stop at speed and step to rest). It rises only when the
    # reference needs no braking at the rate it holds: a stop under way is made at its rate
    # however the override rises (else turning the override up before a stop bought a harder,
    # later stop: 004's general feedrate agent learned to, and paid for it in error at stops)
    if p[b, IP.t_acc] <= 0.0:
        return p[b, IP.a_max]
    prog_feed, prog_flags = plan[0], plan[1]
    seg = int(st[b, IS.seg])
    f = prog_feed[seg]
    if (int(prog_flags[seg]) & RAPID) == 0:
        f *= p[b, IP.ovr]
    f = min(f, p[b, IP.f_max])
    v, held = st[b, IS.v], st[b, IS.fa]
    if f == held:
        fa = f
    elif f < held and f < v:
        fa = max(held, v)
    else:
        # one braking curve, at the lower of the two rates: a fall needs none at the new rate;
        # a rise none at the held one, its curve a tick's speed-up above the speed (one call
        # site: the curve's loop is inlined into every kernel)
        probe = _feed_rate(p, b, min(f, held))
        margin = probe * ts if f > held else 0.0
        fa = f if _curve(p, st, b, s0, plan, ts, probe) >= v + margin else held
    st[b, IS.fa] = fa
    return _feed_rate(p, b, fa)


@numba.njit(cache=True, inline="always")
def _advance(p, st, b, target, ts, a_max):
    s, v, a = st[b, IS.s], st[b, IS.v], st[b, IS.a]
    j_max = p[b, IP.j_max]
    if math.isinf(a_max):
        return s + target * ts, target, 0.0
    dv = target - v
    if math.isinf(j_max):
        a_new = min(max(dv / ts, -a_max), a_max)
    else:
        # time-optimal approach to the target speed with zero final acceleration
        a_des = math.copysign(min(math.sqrt(2.0 * j_max * abs(dv)), a_max, abs(dv) / ts), dv)
        a_new = min(max(a_des, a - j_max * ts), a + j_max * ts)
    v_new = max(v + a_new * ts, 0.0)
    return s + 0.5 * (v + v_new) * ts, v_new, a_new


@numba.njit(cache=True, inline="always")
def _time_law_tick(p, st, b, k, length, law_s, law_v, law_dt, ts):
    ovr = p[b, IP.ovr]
    tau = st[b, IS.tau] + ovr * ts
    m = law_s.shape[0]
    x = tau / law_dt
    j = min(int(x), m - 2)
    if tau >= law_dt * (m - 1):
        st[b, IS.s], st[b, IS.v], st[b, IS.a], st[b, IS.tau] = length, 0.0, 0.0, tau
        st[b, IS.done] = k
        return
    u = x - j
    # cubic Hermite on (s, v) over [j dt, (j + 1) dt]
    s0_, s1_, v0, v1 = law_s[j], law_s[j + 1], law_v[j] * law_dt, law_v[j + 1] * law_dt
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    d00, d10, d01, d11 = 6 * u**2 - 6 * u, 3 * u**2 - 4 * u + 1, -6 * u**2 + 6 * u, 3 * u**2 - 2 * u
    e00, e10, e01, e11 = 12 * u - 6, 6 * u - 4, -12 * u + 6, 6 * u - 2
    st[b, IS.s] = min(h00 * s0_ + h10 * v0 + h01 * s1_ + h11 * v1, length)
    st[b, IS.v] = (d00 * s0_ + d10 * v0 + d01 * s1_ + d11 * v1) / law_dt * ovr
    st[b, IS.a] = (e00 * s0_ + e10 * v0 + e01 * s1_ + e11 * v1) / law_dt**2 * ovr * ovr
    st[b, IS.tau] = tau


@numba.njit(cache=True, inline="always")
def _hold(st, b, in_position):
    # a dwell or an exact stop waiting for the axes: True while the reference stays put
    if st[b, IS.hold] > 0.0:
        st[b, IS.hold] -= 1.0
        return True
    if st[b, IS.wait] > 0.0:
        if not in_position:
            return True
        st[b, IS.wait] = 0.0
    return False


@numba.njit(cache=True, inline="always")
def interp_tick(p, st, b, k, ts, s0, prog, law, law_dt, in_position):
    """Advance member ``b``'s reference by one tick; marks ``done`` at the path end.

    Args:
        p: (B, IP) parameters.
        st: (B, IS) state; row ``b`` is updated in place.
        b: The member.
        k: Index of the tick being produced.
        ts: Tick, s.
        s0: Segment start arc lengths of the path (n + 1,).
        prog: The :class:`Program` arrays (feed, flags, vcap, vj, wait, dwell).
        law: ``(s, v)`` of the time law (empty: feedrate mode).
        law_dt: Time-law grid step, s.
        in_position: Whether the axes were in position after the last tick (exact stops).
    """
    if st[b, IS.done] >= 0.0:
        return
    n = s0.shape[0] - 1
    length = s0[n]
    law_s, law_v = law
    if law_s.shape[0] > 1:
        _time_law_tick(p, st, b, k, length, law_s, law_v, law_dt, ts)
        return
    feed, flags, vcap, vj, wait, dwell = prog
    if _hold(st, b, in_position):
        st[b, IS.v], st[b, IS.a] = 0.0, 0.0
        return
    plan = (feed, flags, vcap, vj)
    a_max = _rate(p, st, b, s0, plan, ts)
    cap = _cap(p, b, feed, flags, vcap, int(st[b, IS.seg]))
    target = max(min(cap, _curve(p, st, b, s0, plan, ts, a_max)), 0.0)
    s_new, v_new, a_new = _advance(p, st, b, target, ts, a_max)
    seg = int(st[b, IS.seg])
    while seg < n - 1 and s_new >= s0[seg + 1] - 1e-12:
        if vj[seg] == 0.0:  # a stop at this junction: arrive at rest and hold
            break
        seg += 1
    stop_at = s0[seg + 1]
    if vj[seg] == 0.0 and (s_new >= stop_at - 1e-12 or (v_new == 0.0 and stop_at - s_new < 1e-9)):
        s_new, v_new, a_new = stop_at, 0.0, 0.0
        if seg == n - 1:
            st[b, IS.done] = k
        else:
            st[b, IS.hold] = dwell[seg]
            st[b, IS.wait] = wait[seg]
            seg += 1
    st[b, IS.s], st[b, IS.v], st[b, IS.a], st[b, IS.seg] = s_new, v_new, a_new, seg
