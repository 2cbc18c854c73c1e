"""The friction-law interface: :class:`FrictionLaw`, its registry and the kernels' slot."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from operator import attrgetter
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym._registry import Registry
from contour_gym._schema import Schema
from contour_gym.jit import Family
from contour_gym.plant._kernel import N_FR


@dataclass(frozen=True)
class FrictionLaw:
    """A registered friction law.

    Attributes:
        name: Registry name.
        model: The dataclass an axis' ``friction`` holds (``type(None)`` for no friction).
        params: Schema of the law's parameter row (at most ``N_FR`` columns); its names are
            the model's fields.
        substep: ``substep(ax, fr, ad, bd, st, i, u, f_ext, h)``, compiled: advances axis row
            ``i`` by one substep ``h`` under control ``u`` and external force ``f_ext``.
        break_away: Largest friction force the model can produce at rest, N (bounds the
            lumped disturbance the model-based controllers are designed for).
        values: ``values(model) -> {name: value}`` for the schema (default: the model's
            dataclass fields).
        scale: The parameters that scale with the friction level (domain randomisation
            multiplies them by one factor).
    """

    name: str
    model: type
    params: Schema
    substep: Any = field(repr=False)
    break_away: Callable[[Any], float] = field(default=lambda m: 0.0, repr=False)
    values: Callable[[Any], dict[str, Any]] | None = field(default=None, repr=False)
    scale: tuple[str, ...] = ()

    def row(self, model: Any) -> NDArray[np.float64]:
        """The (N_FR,) parameter row of ``model``."""
        if self.values is not None:
            values = self.values(model)
        else:
            values = {} if model is None else dataclasses.asdict(model)
        row = np.zeros(N_FR)
        row[: self.params.size] = self.params.row(
            **{k: v for k, v in values.items() if k in self.params.names}
        )
        return row


FRICTION_LAWS: Registry[FrictionLaw] = Registry("friction law")


# the kernels' slot of a friction law (contour_gym.jit.slots)
FRICTION_FAMILY = Family("friction law", {"FRICTION": attrgetter("substep")},
                         FRICTION_LAWS.components)


def register_friction_law(law: FrictionLaw, *, replace: bool = False) -> FrictionLaw:
    """Register a friction law (see :mod:`contour_gym.plant.friction`); returns it.

    Raises:
        ValueError: for a taken name, a model type another law already claims, or a schema
            wider than ``N_FR`` columns.
    """
    if law.params.size > N_FR:
        raise ValueError(f"friction law {law.name!r} has {law.params.size} > {N_FR} parameters")
    for other in FRICTION_LAWS.names():
        if FRICTION_LAWS.get(other).model is law.model and other != law.name:
            raise ValueError(f"{law.model.__name__} is already the model of law {other!r}")
    return FRICTION_LAWS.register(law, replace=replace)


def law_for(model: Any) -> FrictionLaw:
    """The registered law whose model is ``type(model)`` (``none`` for None).

    Raises:
        ValueError: for a model no law claims.
    """
    for name in FRICTION_LAWS.names():
        law = FRICTION_LAWS.get(name)
        if type(model) is law.model:
            return law
    raise ValueError(
        f"no friction law for {type(model).__name__}; register one with register_friction_law"
    )
