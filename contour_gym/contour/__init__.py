"""Contour error estimators behind one batched interface (the CCC's input each tick).

:data:`ESTIMATORS` is the registry (:mod:`contour_gym.contour.base`);
``get_estimator(name, **options)`` is an :class:`Estimator`, callable on a batch of tool
positions, and :func:`estimate` is the one-call form. The loop selects an estimator with
``ServoLoop(estimator=name, estimator_options={...})``; the same compiled functions run there
and here. Ground truth (the exact nearest point) stays available for metrics and rewards
whatever the CCC uses. Add an estimator with one module and one :func:`register_estimator`
call (the documentation's "Extending" page: an estimator).

| name | method | options |
|---|---|---|
| ground_truth | exact nearest point on the branch of the path the tool is on | - |
| exact | 000 eqs. 1-3: distance to the reference's line or arc | - |
| two_circle | 000: two circles through interpolation points near the tool | - |
| tangent | 001 (Yeh & Hsu): foot on the tangent line at the reference | max_turn |
| frenet | 002 eqs. 19-22: Frenet frame, delay time, Taylor expansion | order, max_turn |
| angle | 003 eqs. 16-21: line through previous and current command | lag, max_turn |
| window | 004 sec. 2.2: variable window, two closest reference points | half_width |
| iterative | Newton / osculating-circle iteration from the reference | n_iter, method, tol |

Options (keywords of the factory, or ``estimator_options`` of the loop):

* ``max_turn`` (tangent, frenet, angle; 1.0 rad): give up, i.e. fall back, when
  ``kappa |e| > max_turn`` (the tracking error spans more turning than a linearisation at
  the reference can describe).
* ``order`` (frenet; 2): order of the Taylor expansion, 1 (the paper's ``L = V_d t_d``) or 2.
* ``lag`` (angle; 1): how many ticks back the previous command point is.
* ``half_width`` (window; 1): starting half-width of the window, interpolation points.
* ``n_iter`` (iterative; 4), ``method`` (``"circle"``: projection on the osculating circle,
  or ``"newton"``), ``tol`` (1e-9 m): the iteration's step budget and convergence test.

Every estimator that cannot find a foot point falls back to the exact search (reported in
:attr:`ContourEstimate.fallback`); see :mod:`contour_gym.contour._kernel`. Each estimator's
docstring in :mod:`contour_gym.contour._estimators` names its paper, equations, what was
reconstructed, where it breaks down and when it falls back.
"""

from __future__ import annotations

from contour_gym.contour._api import (
    ContourEstimate,
    Estimator,
    build_estimator,
    estimate,
    estimate_full,
    get_estimator,
)
from contour_gym.contour.base import ESTIMATORS, ContourEstimator, register_estimator

__all__ = [
    "ESTIMATORS",
    "ContourEstimate",
    "ContourEstimator",
    "Estimator",
    "build_estimator",
    "estimate",
    "estimate_full",
    "get_estimator",
    "register_estimator",
]
