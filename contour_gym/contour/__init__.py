"""Contour error estimators behind one batched interface (the CCC's input each tick).

``ESTIMATORS`` maps a name to ``(kernel kind, options builder)``; the loop selects one with
``ServoLoop(estimator=name)``. Ground truth (``Path.nearest`` near the reference) stays
available for metrics and rewards whatever the CCC uses.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from contour_gym._validate import choice
from contour_gym.contour import _kernel as K


def _no_options(**options: object) -> np.ndarray:
    if options:
        raise ValueError(f"this estimator takes no options, got {sorted(options)}")
    return np.zeros(K.N_EST_P)


# name -> (kernel kind, builder(**options) -> (N_EST_P,) option row)
ESTIMATORS: dict[str, tuple[int, Callable[..., np.ndarray]]] = {
    "ground_truth": (K.EST_GROUND_TRUTH, _no_options),
}


def build_estimator(name: str, **options: object) -> tuple[int, np.ndarray]:
    """Kernel kind and option row of the estimator ``name``.

    Raises:
        ValueError: for an unknown name (the message lists the accepted ones) or bad options.
    """
    kind, builder = ESTIMATORS[choice(name, "estimator", ESTIMATORS)]
    return kind, builder(**options)


__all__ = ["ESTIMATORS", "build_estimator"]
