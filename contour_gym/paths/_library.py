"""Named test paths from the papers (docs/references.md; SI units; the papers use mm)."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from contour_gym._validate import choice
from contour_gym.paths._freeform import FloatArray, Triple, analytic_path, bspline, nurbs
from contour_gym.paths._path import Path
from contour_gym.paths._primitives import circle, helix, polyline
from contour_gym.paths._timelaw import TimeLaw

MM = 1e-3


def _named(path: Path, name: str) -> Path:
    return Path(path.table, name)


def circle_r10() -> Path:
    """Circle of radius 10 mm: paper 000, circular-trajectory experiment (Fig. 17).

    ``x = 10 cos(pi t) - 10``, ``y = 10 sin(pi t)`` mm: centre (-10, 0) mm, starting at the
    origin, counter-clockwise, one turn. Alias: ``circle``.
    """
    return _named(circle(10 * MM, center=(-10 * MM, 0.0), start_angle=0.0), "circle_r10")


def circle_r20() -> Path:
    """Circle of radius R = 20 mm: paper 004 eq. (4.1), ``P = R (cos wt, sin wt)``.

    Centre at the origin, starts at (R, 0), counter-clockwise, one turn.
    """
    return _named(circle(20 * MM), "circle_r20")


def circle_r50() -> Path:
    """Circle of radius r = 50 mm: paper 003 case 1, ``x = r cos(2 pi f t)``, ``y = r sin``.

    Centre at the origin, starts at (r, 0), counter-clockwise. The +70 mm and +210 mm y offsets
    of the paper belong to the X-Y-Y stage's two contours, not to the path.
    """
    return _named(circle(50 * MM), "circle_r50")


def _rose(theta: FloatArray) -> Triple:
    r = 25 * MM
    rho = r * np.cos(3.0 * theta)
    rho1 = -3.0 * r * np.sin(3.0 * theta)
    rho2 = -9.0 * rho
    c, s = np.cos(theta), np.sin(theta)
    p = np.stack([rho * c, rho * s], axis=1)
    d1 = np.stack([rho1 * c - rho * s, rho1 * s + rho * c], axis=1)
    d2 = np.stack([rho2 * c - 2.0 * rho1 * s - rho * c, rho2 * s + 2.0 * rho1 * c - rho * s],
                  axis=1)
    return p, d1, d2


def three_leaf() -> Path:
    """Three-leaf rose of paper 003 case 2, with 003's time law at f = 1 Hz.

    ``x = r cos(3 theta) cos(theta)``, ``y = r cos(3 theta) sin(theta)``, r = 25 mm, with
    theta = 2 pi f t running over [0, pi], which traces the three leaves once (closed, passing
    through the origin three times) in 1 / (2 f) = 0.5 s. The path carries that timing as its
    :attr:`~Path.time_law`: the speed ``2 pi f r sqrt(9 sin^2 3theta + cos^2 3theta)`` runs
    from 2 pi f r (leaf tips) to 3 times that (the origin). The +30/+90 mm y offsets of the
    paper belong to the stage; 003's 10 s window is :meth:`Path.repeat` (20 passes).
    """
    path = analytic_path(_rose, 0.0, math.pi, 2, "three_leaf")
    return path.with_time_law(theta_law(_rose, THREE_LEAF_FREQUENCY, math.pi, path.length))


THREE_LEAF_FREQUENCY = 1.0  # 003 case 2: "the maximum frequency f up to 1 Hz"


def theta_law(curve: Callable[[FloatArray], Triple], frequency: float, theta_end: float,
              length: float, dt: float = 1e-3) -> TimeLaw:
    """Time law of a curve ``C(theta)`` run at ``theta = 2 pi f t`` from 0 to ``theta_end``.

    Args:
        curve: ``theta -> (C, C', C'')`` with ``C'`` the derivative in theta, (N, dim) each.
        frequency: f, Hz.
        theta_end: Parameter at the end.
        length: The path's arc length (the law is scaled onto it: the fit's length and the
            quadrature's agree to about 1e-12).
        dt: Grid step, s.
    """
    rate = 2.0 * math.pi * frequency

    def speed(t: FloatArray) -> FloatArray:
        flat = np.minimum(rate * np.ravel(t), theta_end)
        return np.linalg.norm(curve(flat)[1], axis=1).reshape(np.shape(t)) * rate

    law = TimeLaw.from_speed(speed, theta_end / rate, dt, f"theta = 2 pi {frequency:g} t")
    return law.scaled_to(length)


def corner() -> Path:
    """The +45/-45 degree corner of paper 004 section 4.2.

    The paper gives only the angles. Designed here: from the origin a 25 mm leg at +45 degrees,
    then a 25 mm leg at -45 degrees (a 90 degree right turn at (17.68, 17.68) mm).
    """
    leg = 25 * MM / math.sqrt(2.0)
    return _named(polyline([[0.0, 0.0], [leg, leg], [2.0 * leg, 0.0]]), "corner")


def infinity() -> Path:
    """The "infinity" (figure-eight) NURBS of paper 000, Fig. 12.

    The paper shows the shape only. Designed here: a closed, C2, degree-3 NURBS on a uniform
    (wrapped) knot vector with the eight control points ``(X sin(k pi/4), Y sin(k pi/2))``,
    X = 58.58 mm, Y = 32.47 mm, and weights 1 (at the centre), 1.4 (diagonal points) and 0.7
    (outer points). It spans 100 x 50 mm, starts at the origin heading up-right and crosses
    itself there halfway round.
    """
    k = np.arange(8)
    pts = np.stack([58.58 * np.sin(k * np.pi / 4), 32.47 * np.sin(k * np.pi / 2)], axis=1) * MM
    wts = np.array([1.0, 1.4, 0.7, 1.4, 1.0, 1.4, 0.7, 1.4])
    order = [7, 0, 1, 2, 3, 4, 5, 6, 7, 0, 1]
    return _named(nurbs(pts[order], wts[order], np.arange(15.0), 3), "infinity")


def trident() -> Path:
    """The "trident" NURBS of paper 000, Fig. 18 ("the curvature changes irregularly").

    The paper shows the shape only. Designed here: an open degree-3 NURBS, 50 mm wide and
    60 mm tall, with three prongs pointing up (two outer straight-ish prongs and a tall, sharp
    middle one) joined by two rounded troughs; irregular knots and weights (0.6 to 2) make the
    curvature vary irregularly, peaking at the middle prong tip and in the troughs.
    """
    pts = np.array([(0, 50), (0, 10), (5, 0), (15, 0), (20, 10), (22, 60), (28, 60), (30, 10),
                    (35, 0), (45, 0), (50, 10), (50, 50)], dtype=float) * MM
    wts = np.array([1.0, 1.0, 2.0, 1.0, 0.6, 1.5, 1.5, 0.6, 1.0, 2.0, 1.0, 1.0])
    knots = np.r_[[0.0] * 4, [0.08, 0.2, 0.3, 0.45, 0.55, 0.7, 0.8, 0.92], [1.0] * 4]
    return _named(nurbs(pts, wts, knots, 3), "trident")


def helix_path() -> Path:
    """The screw (helix) reference of paper 001.

    The paper's equations were lost in extraction. Designed here: radius 20 mm, pitch 10 mm,
    two turns, axis z through the origin, starting at (20, 0, 0) mm, counter-clockwise, rising.
    """
    return _named(helix(20 * MM, 10 * MM, 2.0), "helix")


_COMPLEX_CTRL = np.array([
    (0, 0), (30, 0), (60, 0), (90, 0), (120, 0), (150, 0), (160, 10), (160, 40), (160, 70),
    (160, 100), (160, 130), (160, 150), (140, 160), (110, 160), (90, 140), (70, 180), (50, 140),
    (30, 160), (10, 150), (0, 130), (0, 100), (0, 70), (0, 40)], dtype=float)


def bspline_complex() -> Path:
    """The B-spline complex path of paper 002, Fig. 13 (straight lines and curves, 742 mm).

    The paper gives the total length only. Designed here: a clamped degree-3 B-spline on
    uniform knots through 23 control points forming an open rounded frame: a straight bottom
    edge, two straight vertical sides (five or more collinear control points make exactly
    straight stretches), rounded corners and a wavy top; scaled so the length is 742 mm.
    """
    n = _COMPLEX_CTRL.shape[0]
    knots = np.r_[[0.0] * 4, np.linspace(0.0, 1.0, n - 2)[1:-1], [1.0] * 4]
    unit = bspline(_COMPLEX_CTRL * MM, knots, 3)
    scale = 742 * MM / unit.length
    return _named(bspline(_COMPLEX_CTRL * MM * scale, knots, 3), "bspline_complex")


_BUILDERS: dict[str, Callable[[], Path]] = {
    "circle_r10": circle_r10,
    "circle": circle_r10,
    "circle_r20": circle_r20,
    "circle_r50": circle_r50,
    "three_leaf": three_leaf,
    "corner": corner,
    "infinity": infinity,
    "trident": trident,
    "helix": helix_path,
    "bspline_complex": bspline_complex,
}

NAMES: tuple[str, ...] = tuple(_BUILDERS)
_ALIASES = {"circle": "circle_r10"}


@functools.lru_cache(maxsize=None)  # noqa: UP033 (the brief asks for lru_cache)
def _load(name: str) -> Path:
    return _BUILDERS[name]()


def load(name: str) -> Path:
    """A named test path (cached: paths are immutable).

    Args:
        name: One of :data:`NAMES`: ``circle_r10`` (alias ``circle``), ``circle_r20``,
            ``circle_r50``, ``three_leaf``, ``corner``, ``infinity``, ``trident``, ``helix``,
            ``bspline_complex``. Each builder's docstring names the paper and figure and says
            what was designed here.

    Returns:
        The path.

    Raises:
        ValueError: for an unknown name, listing the accepted ones.
    """
    choice(name, "path name", NAMES)
    return _load(_ALIASES.get(name, name))
