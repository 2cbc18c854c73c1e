"""Contour error estimators by registration.

An estimator is a compiled foot-point function with one signature::

    foot(p, kind, s0, data, bound, p0, p1, p2, s, hist) -> (ok, qx, qy, qz, tx, ty, tz, e2)

``p`` its option row (laid out by its :class:`~contour_gym._schema.Schema`), the path table
(``kind, s0, data, bound``), the tool position ``p0, p1, p2`` in path coordinates, the
reference arc length ``s`` and the ring buffer ``hist`` of previous references
(:mod:`contour_gym.contour._history`). It returns its estimate of the foot point q (the path
point nearest the tool) and a tangent there, or ``ok = False`` to fall back to the exact
search; ``e2`` is ``|r - p|^2`` for the plausibility check ``|q - p| <= |r - p|`` (or -1 when
the construction guarantees it). Register with :func:`register_estimator`; the loop compiles
and inlines exactly the estimator it runs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from contour_gym._registry import Registry
from contour_gym._schema import Schema
from contour_gym._validate import choice
from contour_gym.jit import Family
from contour_gym.jit.slots import no_foot

if TYPE_CHECKING:
    from contour_gym.paths import Path


@dataclass(frozen=True)
class ContourEstimator:
    """A registered contour error estimator.

    Attributes:
        name: Registry name.
        params: Schema of its options (the row ``p``).
        foot: Compiled foot-point function (module docstring); None for the exact search
            itself (``ground_truth``).
        needs_history: Whether it reads previous reference points.
        path_check: Raises ValueError for paths it cannot handle (Python API only: in the
            loop an estimator that cannot answer falls back to the exact search).
        doc: Paper, equations and what was reconstructed, in one line.
    """

    name: str
    params: Schema
    foot: Any = field(default=None, repr=False)
    needs_history: bool = False
    path_check: Callable[[Path], None] | None = field(default=None, repr=False)
    doc: str = ""


ESTIMATORS: Registry[ContourEstimator] = Registry("estimator")


# the kernels' slot of an estimator (contour_gym.jit.slots); the exact search has no foot function
ESTIMATOR_FAMILY = Family(
    "estimator",
    {"EST_FOOT": lambda est: no_foot if est.foot is None else est.foot},
    ESTIMATORS.components,
)


def register_estimator(est: ContourEstimator, *, replace: bool = False) -> ContourEstimator:
    """Register a contour error estimator (see the module docstring); returns it."""
    return ESTIMATORS.register(est, replace=replace)


def int_in(lo: int, hi: int) -> Callable[[Any, str], float]:
    """A schema check accepting ints in ``[lo, hi]``."""

    def check(value: Any, name: str) -> float:
        ok = isinstance(value, int) and not isinstance(value, bool) and lo <= value <= hi
        if not ok:
            raise ValueError(f"{name} must be an int in [{lo}, {hi}], got {value!r}")
        return float(value)

    return check


def one_of(codes: dict[str, int]) -> Callable[[Any, str], float]:
    """A schema check mapping a name to its code (ValueError listing the names)."""

    def check(value: Any, name: str) -> float:
        if isinstance(value, (int, float)) and value in codes.values():
            return float(value)
        return float(codes[choice(value, name, codes)])

    return check
