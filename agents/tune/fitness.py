"""Fitness of a tuning candidate: per scenario from a loop's metrics, and over the scenarios.

:data:`FITNESSES` maps a protocol's ``fitness`` name to the function of one scenario's metrics
(``(B,)`` per member, m); :func:`combine` averages them over a protocol's scenarios and gives a
candidate that failed anywhere the finite penalty ``PENALTY_HARD_LIMITS * H``, ``H`` the
largest hard limit of the protocol's scenarios (times :data:`FITNESS_TERMS` for a fitness
that sums several errors). Every fitness is at most the largest contour error (times its
terms), which a candidate that did not fail keeps below ``H``: a failure never wins and never
crashes a run.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from contour_gym.api import Scenario

FloatArray = NDArray[np.float64]
PENALTY_HARD_LIMITS = 2.0  # a failed candidate's fitness, in hard limits (module docstring)


def _cea(metrics: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(metrics["cea"], dtype=np.float64)


def _rms(metrics: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(metrics["rms_contour_error"], dtype=np.float64)


def _max(metrics: Mapping[str, FloatArray]) -> FloatArray:
    return np.asarray(metrics["max_contour_error"], dtype=np.float64)


def _eq38(metrics: Mapping[str, FloatArray]) -> FloatArray:
    tracking = np.asarray(metrics["rms_tracking_error"], dtype=np.float64).sum(axis=1)
    contour = np.asarray(metrics["rms_contour_error_per_contour"], dtype=np.float64).sum(axis=1)
    return np.asarray(tracking + contour, dtype=np.float64)


FITNESSES: dict[str, Callable[[Mapping[str, FloatArray]], FloatArray]] = {
    "cea": _cea,
    "rms": _rms,
    "max": _max,
    "eq38": _eq38,
}
"""Fitness of one scenario from a loop's metrics, (B,), m; each is at most the max |error|.

``cea``: paper 000's eq. (15), ``J = (1/N) sum_i |eps_i|`` over the N servo samples of the
run, ``eps_i`` the true contour error at sample i: the equation was lost in extraction; the
text keeps "where N is the sampling point. eps_i is the contour error modulus at position i",
i.e. a mean of moduli over the samples, which is 000's own CEA ("module average", its
Table 4). Reconstructed as that mean (not a sum, so paths of different durations weigh
alike; not squared, as the text speaks of the modulus). ``rms`` and ``max``: the RMS and the
largest contour error, for other protocols.

``eq38``: paper 003's eq. (38), ``sqrt(mean e_x^2) + sum_i sqrt(mean e_yi^2) + sum_i
sqrt(mean eps_i^2)`` over the n samples of the run: the RMS tracking error of every axis (x,
y1, y2) plus the RMS contour error of every contour (x-y1, x-y2). Reconstructed: the
extraction kept the five mean squares ``(1/n) sum [x_d - x^]^2``, ``(1/n) sum e_yi^2``,
``(1/n) sum eps_i^2`` and the sums over ``i = 1, 2`` but lost any root sign; the roots are
ours (the extraction drops them elsewhere too, and with them the fitness is in metres like
the others and no term's units square away). 003 evaluates it on an observer's predicted
positions ``x^, y^_i``; here the simulated (true) positions are the prediction. 003 keeps
the candidate of "highest fitness" (ABC's ``1/(1 + f)``); minimising ``f`` is the same
order. It sums ``A + C`` errors, none bounded by the contour hard limit, so a protocol using
it has ``A + C`` times the usual penalty and counts ``f >= penalty`` as a failure.
"""

# how many error terms a fitness sums (its penalty scales with it)
FITNESS_TERMS: dict[str, Callable[[Scenario], int]] = {
    "eq38": lambda sc: sc.preset.stage.n_axes + len(sc.preset.stage.contours),
}



def combine(
    per_case: ArrayLike, failed: ArrayLike, penalty: float, worst: bool = False
) -> FloatArray:
    """Total fitness: the mean over scenarios, ``penalty`` wherever a scenario failed.

    Args:
        per_case: ``(S, n)`` fitness per scenario and candidate.
        failed: ``(S, n)`` failures (a non-finite fitness counts as one).
        penalty: Finite fitness of a failed candidate.
        worst: The worst scenario's fitness instead of the mean.

    Returns:
        ``(n,)`` finite fitness.
    """
    f = np.asarray(per_case, dtype=np.float64)
    bad = np.asarray(failed, dtype=bool) | ~np.isfinite(f)
    kept = np.where(bad, 0.0, f)
    total = kept.max(axis=0) if worst else kept.mean(axis=0)
    return np.where(bad.any(axis=0), float(penalty), total)

