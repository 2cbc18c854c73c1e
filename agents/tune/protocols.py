"""Tuning protocols: what to search, on which scenarios, by which fitness, with what budget.

A :class:`Protocol` names the parameters it searches (:class:`TuneParam`, each with its box
and scale), the registered env ids it runs (its scenarios), its fitness (a key of
:data:`~agents.tune.fitness.FITNESSES`), how a candidate reaches its batch member (a key of
:data:`~agents.tune.setters.SETTERS`), and its default optimiser and budget. :data:`PROTOCOLS`
holds them by name (:func:`register_protocol`, :func:`get_protocol`); the papers' protocols
are in :mod:`agents.tune.papers`.

**Search scale.** Parameters marked ``log`` are searched in ``log10`` (the optimiser's box is
``log10`` of theirs; :meth:`Protocol.to_params` maps back), the others linearly. Results are
always reported in the parameters' own (SI) units.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from agents.optim import OPTIMIZERS
from agents.tune.fitness import FITNESSES, FloatArray
from agents.tune.setters import SETTERS
from contour_gym.ccc import CCC_LAWS
from contour_gym.params import choice
from contour_gym.presets import resolve_preset
from contour_gym.registry import Registry


@dataclass(frozen=True)
class TuneParam:
    """One searched parameter.

    Attributes:
        name: The CCC law parameter's name.
        low: Lower bound, in the parameter's units (> 0 when ``log``).
        high: Upper bound (> ``low``).
        log: Search ``log10`` of the parameter.
        unit: Its unit, for reports.
    """

    name: str
    low: float
    high: float
    log: bool = False
    unit: str = ""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise ValueError(f"parameter {self.name!r} needs finite low < high, got "
                             f"[{self.low!r}, {self.high!r}]")
        if self.log and self.low <= 0.0:
            raise ValueError(f"log-scaled parameter {self.name!r} needs low > 0, got {self.low!r}")


@dataclass(frozen=True)
class Protocol:
    """A tuning protocol: what to search, on which scenarios, by which fitness, with what budget.

    Attributes:
        name: Registry key.
        params: The searched parameters (D of them), CCC law parameters by name.
        scenarios: Registered env ids (``contour_gym/CCC-...``) the fitness averages over.
        fitness: A key of :data:`FITNESSES`.
        ccc_law: The CCC law whose parameters are searched.
        optimizer: Default optimiser, a key of :data:`agents.optim.OPTIMIZERS`.
        population: Default population (candidates per generation).
        iterations: Default generations after the initial one.
        optimizer_options: Options of the default optimiser.
        episode_seed: Seed every candidate's episodes are reset from.
        doc: What the protocol reproduces.
        setter: How a candidate's parameters reach its batch member, a key of
            :data:`SETTERS`: ``"ccc_law"`` (the CCC law's parameters by name) or
            ``"acc2pid"`` (paper 003's 2PID axes and P compensators, :func:`set_acc2pid`).
        scenario_kwargs: Scenario -> env keyword arguments overriding the id's own for this
            protocol (e.g. a shorter window: ``{"laps": 1}``). A scenario is a registered env
            id, or a name of your choosing whose kwargs name the id (``"id"``); on random
            paths (``"path": "random"``) its one path is the one ``env.reset(seed=path_seed)``
            runs (on an env without ``randomize``), so several paths of one id are several
            named scenarios, and a suite runs the same paths with ``seeds``.
        chatter_bound: A candidate whose chattering (total variation of the control command)
            on a scenario exceeds ``chatter_bound`` times that of the law's own defaults
            (:attr:`reference`) there fails on it. None: unbounded.
        reference: The untuned point the chattering is bounded by and ``relative`` divides
            by (parameters by name; None: the CCC law's registered defaults).
        relative: Score each scenario's fitness relative to the reference point's there (1:
            as good as the untuned law), so that paths of large and small errors weigh alike;
            the total is put back in metres (times the reference's mean over the scenarios).
        worst_case: The total is the worst scenario's, not the mean: a factor set that must
            not lose on any path.
        start_at_reference: Generation 0 holds the reference point (:meth:`reference_point`)
            as one of its candidates, so the result is never worse than the untuned law on the
            protocol's own fitness (a search that finds nothing better returns it).
    """

    name: str
    params: tuple[TuneParam, ...]
    scenarios: tuple[str, ...]
    fitness: str = "cea"
    ccc_law: str = "fuzzy_pid"
    optimizer: str = "improved_pso"
    population: int = 50
    iterations: int = 100
    optimizer_options: Mapping[str, Any] = field(default_factory=dict)
    episode_seed: int = 0
    doc: str = ""
    setter: str = "ccc_law"
    scenario_kwargs: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    chatter_bound: float | None = None
    reference: Mapping[str, float] | None = None
    relative: bool = False
    worst_case: bool = False
    start_at_reference: bool = False

    def __post_init__(self) -> None:
        choice(self.fitness, "fitness", FITNESSES)
        choice(self.optimizer, "optimizer", OPTIMIZERS)
        choice(self.setter, "setter", SETTERS)
        stray = sorted(set(self.scenario_kwargs) - set(self.scenarios))
        if stray:
            raise ValueError(f"scenario_kwargs for env ids not in the scenarios: {stray}")
        if self.chatter_bound is not None and not self.chatter_bound > 0:
            raise ValueError(f"chatter_bound must be > 0, got {self.chatter_bound!r}")
        if not self.params or not self.scenarios:
            raise ValueError(f"protocol {self.name!r} needs parameters and scenarios")

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in search order."""
        return tuple(p.name for p in self.params)

    @property
    def bounds(self) -> FloatArray:
        """(D, 2) box in the parameters' own units."""
        return np.array([(p.low, p.high) for p in self.params], dtype=np.float64)

    @property
    def search_bounds(self) -> FloatArray:
        """(D, 2) box the optimiser searches (``log10`` of the log-scaled parameters)."""
        b = self.bounds
        logs = self._logs()
        b[logs] = np.log10(b[logs])
        return b

    def _logs(self) -> NDArray[np.bool_]:
        return np.array([p.log for p in self.params])

    def to_params(self, z: ArrayLike) -> FloatArray:
        """(n, D) search coordinates -> parameters in their own units, clipped to the box.

        With :attr:`start_at_reference`, the reference's search coordinates
        (:meth:`reference_start`) map back to the reference point bit for bit (``10 **
        log10(v)`` alone may miss ``v`` in the last bit).
        """
        z = np.atleast_2d(np.asarray(z, dtype=np.float64))
        x = np.array(z)
        logs = self._logs()
        x[:, logs] = 10.0 ** x[:, logs]
        b = self.bounds
        x = np.clip(x, b[:, 0], b[:, 1])
        if self.start_at_reference:
            x[np.all(z == self.reference_start(), axis=1)] = self.reference_row()
        return x

    def reference_row(self) -> FloatArray:
        """The reference point's parameters in search order, ``(D,)``, in their own units."""
        return np.array(list(self.reference_point().values()))

    def reference_start(self) -> FloatArray:
        """The reference point's search coordinates, ``(D,)``."""
        return self.to_search(self.reference_row()[None, :])[0]

    def reference_point(self) -> dict[str, float]:
        """The untuned point's searched parameters: the CCC law's defaults, or :attr:`reference`.

        Raises:
            ValueError: for a searched parameter with neither.
        """
        point = {**CCC_LAWS.get(self.ccc_law).params.defaults(), **(self.reference or {})}
        missing = [name for name in self.names if point.get(name) is None]
        if missing:
            raise ValueError(f"protocol {self.name!r}: no reference value for {missing}")
        return {name: float(point[name]) for name in self.names}  # type: ignore[arg-type]

    def to_search(self, x: ArrayLike) -> FloatArray:
        """(n, D) parameters in their own units -> search coordinates."""
        z = np.array(np.atleast_2d(np.asarray(x, dtype=np.float64)))
        logs = self._logs()
        z[:, logs] = np.log10(z[:, logs])
        return z

    def on_plant(self, plant: str | Mapping[str, Any], name: str,
                 copies: Sequence[Mapping[str, Any]] = ()) -> Protocol:
        """This protocol with every scenario run on ``plant`` (a twin of your machine).

        Args:
            plant: A preset name or a machine file's plant dict
                (:func:`contour_gym.machines.read_machine`): it replaces each scenario's
                machine; the paths, fitness, box and budget stay the protocol's (but random
                paths on a 3-D machine, which :func:`~contour_gym.paths.random_path` does not
                draw: those scenarios are left out).
            name: The machine's name, for the returned protocol's (``"000@my_mill"``).
            copies: More machines every scenario also runs on (``"paper#1"``, ...), the
                fitness their mean: a twin's copies within its values' uncertainty
                (:func:`agents.twin.identified.tuning_copies`), so that what is tuned
                holds on the machine whichever of them it is.

        Returns:
            The protocol on that machine (not registered).

        Raises:
            ValueError: when no scenario is left (random paths only, on a 3-D machine).
        """
        flat = resolve_preset(plant).stage.dim == 3  # no random paths: random_path is 2-D
        kept = [s for s in self.scenarios
                if not (flat and self.scenario_kwargs.get(s, {}).get("path") == "random")]
        if not kept:
            raise ValueError(f"protocol {self.name!r} runs random paths only, which a 3-D "
                             f"machine ({name}) does not draw")
        kwargs = {(s if k == 0 else f"{s}#{k}"): {**self.scenario_kwargs.get(s, {}), "plant": p}
                  for k, p in enumerate([plant, *copies]) for s in kept}
        within = f", and {len(copies)} copies within its uncertainty" if copies else ""
        return dataclasses.replace(self, name=f"{self.name}@{name}", scenarios=tuple(kwargs),
                                   scenario_kwargs=kwargs,
                                   doc=f"{self.doc} (on the machine {name}{within})")


PROTOCOLS: Registry[Protocol] = Registry("tuning protocol")


def register_protocol(protocol: Protocol, *, replace: bool = False) -> Protocol:
    """Add ``protocol`` to :data:`PROTOCOLS` (under its name); returns it.

    Raises:
        ValueError: for a taken name (unless ``replace``) or an invalid one.
    """
    return PROTOCOLS.register(protocol, replace=replace)


def get_protocol(protocol: str | Protocol) -> Protocol:
    """The protocol itself, or the registered one of that name.

    Raises:
        ValueError: for an unknown name, listing the accepted ones.
    """
    return protocol if isinstance(protocol, Protocol) else PROTOCOLS.get(protocol)

