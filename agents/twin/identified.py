"""What identifying a twin found (:func:`agents.twin.fit.identify`), and how sure it is."""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from contour_gym.plant.params import Ripple
from contour_gym.presets import resolve_preset

DETERMINED = 0.05  # a value is determined by the logs within this (relative std, spread, bias)
Z95 = 1.96  # a value's 95 % interval is this many standard deviations each side
COPIES = 8  # a twin with undetermined values is tuned on itself and this many copies (chosen)
SPREAD_CAP = 0.3  # a copy's values are drawn with at most this log-std, within 2 of them
VISCOUS = ("fv", "sigma2")
"""Friction parameters that act as viscous damping (a force ``c v``): no signal separates them
from the axis's damping, so they keep the preset's values and the fitted damping holds the
sum."""


@dataclass(frozen=True)
class Identified:
    """A twin found from logs.

    Attributes:
        plant: The machine file's plant dict (``{"preset": like, "stage": {"axes": ...}}``).
        values: Per axis, each identified parameter's value (SI; ``ripple``: the force
            ripple's largest harmonic amplitude, N, every harmonic scaled alike).
        std: Per axis, each one's standard deviation (from the Jacobian at the solution).
        fixed: What was kept at the preset's values (a parameter, or an axis that never
            moved), or read from the logs another way than the replay's fit, and why.
        nrmse: Per axis, the RMS of the twin's following error minus the measured one, over
            the RMS of the measured one, on the logs fitted.
        cost: The final least-squares cost.
        spread: Per axis, each value's largest relative distance to another start's that fits
            the axis about as well: the logs cannot tell such values apart.
        bias: Per axis, each value's relative bias (what the fit finds when the logs are the
            twin's own, over the value it started from, less 1: ``agents.twin.fit._bias``);
            the values are corrected by it.
    """

    plant: dict[str, Any]
    values: dict[str, dict[str, float]]
    std: dict[str, dict[str, float]]
    fixed: dict[str, str]
    nrmse: dict[str, float]
    cost: float
    spread: dict[str, dict[str, float]] = field(default_factory=dict)
    bias: dict[str, dict[str, float]] = field(default_factory=dict)

    def undetermined(self) -> dict[str, list[str]]:
        """Per axis, the values the logs do not determine within :data:`DETERMINED`.

        Their 95 % interval (:data:`Z95` standard deviations each side), their spread over
        starts that fit as well or their :attr:`bias` reaches past it (:meth:`reasons` says
        which): they trade off against others (a friction law's low-speed parameters on a
        circle test, say), and a recording that excites them (slow moves, reversals) would
        pin them. Not a proof of the others: a valley the starts did not find is not seen,
        nor what the twin's structure lacks.
        """
        return {axis: list(why) for axis, why in self.reasons().items()}

    def copies(self, count: int = COPIES, seed: int = 0) -> list[dict[str, Any]]:
        """Copies of the twin to tune on beside it (:func:`tuning_copies`)."""
        return tuning_copies(self.plant, self.values, self.std, self.undetermined(), count, seed)

    def reasons(self) -> dict[str, dict[str, str]]:
        """Per axis, each value :meth:`undetermined` lists and why, in words."""
        out: dict[str, dict[str, str]] = {}
        cut = f"{100 * DETERMINED:g} %"
        for axis, values in self.values.items():
            for n, v in values.items():
                hit = [Z95 * self.std[axis][n] > DETERMINED * abs(v),
                       abs(self.bias.get(axis, {}).get(n, 0.0)) > DETERMINED,
                       self.spread.get(axis, {}).get(n, 0.0) > DETERMINED]
                if any(hit):
                    out.setdefault(axis, {})[n] = (
                        f"its 95 % interval reaches past {cut}", f"the fit's bias is over {cut}",
                        "another start fits as well with another value")[hit.index(True)]
        return out


def tuning_copies(plant: Mapping[str, Any], values: Mapping[str, Mapping[str, float]],
                  std: Mapping[str, Mapping[str, float]], undetermined: Mapping[str, Any],
                  count: int = COPIES, seed: int = 0) -> list[dict[str, Any]]:
    """``count`` copies of a twin, its values drawn within their uncertainty; none if sure.

    Gains tuned on a twin whose logs left values undetermined fit those values' errors (on
    001's test machine up to 14 % worse than the machine's own, docs/measurements.md);
    tuned on the twin and these copies at once (the protocol's
    :meth:`~agents.tune.protocols.Protocol.on_plant`), they hold whichever the machine is.
    Each identified value is multiplied by ``exp(N(0, s))``, ``s`` its relative standard
    deviation capped at :data:`SPREAD_CAP` (and taken as it where not finite), the draw
    clipped to two ``s``.

    Args:
        plant: The twin's plant dict (:attr:`Identified.plant`, a machine file's).
        values: Per axis, its identified values.
        std: Per axis, their standard deviations.
        undetermined: Per axis, the values its logs left undetermined (``{}``: no copies).
        count: How many copies.
        seed: Seed of the draws.
    """
    if not any(undetermined.values()):
        return []
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        twin = copy.deepcopy(dict(plant))
        for axis, found in values.items():
            for name, value in found.items():
                rel = abs(std[axis][name] / value) if value else 0.0
                s = min(rel, SPREAD_CAP) if math.isfinite(rel) else SPREAD_CAP
                factor = math.exp(float(np.clip(rng.normal(0.0, s), -2.0 * s, 2.0 * s)))
                _scale_value(twin["stage"]["axes"][axis], name, factor)
        out.append(twin)
    return out


def _scale_value(changes: dict[str, Any], name: str, factor: float) -> None:
    # one identified value of an axis's machine-file changes times ``factor``
    if name in ("mass", "damping"):
        changes[name] *= factor
    elif name == "ripple":
        changes["ripple"] = Ripple(**changes["ripple"]).scaled(factor)
    else:
        changes["friction"][name] *= factor
        static_over_coulomb(changes["friction"])


def static_over_coulomb(fields: dict[str, Any]) -> None:
    """Raise a friction model's static force ``fs`` to its Coulomb force ``fc`` where below.

    A fitted or drawn ``fs`` under ``fc`` is no Stribeck hump (the law asks ``fs >= fc``).
    """
    if fields.get("fs") is not None and fields.get("fc") is not None:
        fields["fs"] = max(fields["fs"], fields["fc"])


def ratio_errors(values: dict[str, dict[str, float]], plant: Any, like: Any
                 ) -> dict[tuple[str, str], float]:
    """Each identified value against a known machine's (a hidden one's, in tests), relative.

    Values are compared as the logs see them: a force's (a ripple's amplitude too) or a
    mass's over the axis's force constant (the twin keeps ``like``'s), a Stribeck speed as it
    is, the damping with the viscous friction added (:data:`VISCOUS`: the twin keeps
    ``like``'s, its damping holds the sum).

    Args:
        values: Per axis, identified values (:attr:`Identified.values`).
        plant: The machine the logs came from (a plant spec).
        like: The preset (or machine file) the twin was identified like.
    """
    true, base = resolve_preset(plant), resolve_preset(like)
    out = {}
    for t, b in zip(true.stage.axes, base.stage.axes, strict=True):
        for name, mine in values.get(t.name, {}).items():
            hidden = _value(t, name)
            if name == "damping":
                hidden += sum(getattr(t.friction, v, 0.0) or 0.0 for v in VISCOUS)
                mine += sum(getattr(b.friction, v, 0.0) or 0.0 for v in VISCOUS)
            per = (1.0, 1.0) if name == "vs" else (b.force_constant, t.force_constant)
            out[(t.name, name)] = (mine / per[0]) / (hidden / per[1]) - 1.0
    return out


def _value(axis: Any, name: str) -> float:
    # an axis's value of an identified parameter (its mass, damping, friction or ripple)
    if name in ("mass", "damping"):
        return float(getattr(axis, name))
    if name == "ripple":
        return float(axis.ripple.amplitude) if axis.ripple is not None else 0.0
    return float(getattr(axis.friction, name))


__all__ = ["COPIES", "DETERMINED", "VISCOUS", "Z95", "Identified", "ratio_errors",
           "static_over_coulomb", "tuning_copies"]
