"""Parameters declared by name once: a row of floats for the kernels, named columns for both sides.

A component (friction law, axis controller, estimator, CCC law, reward) declares its
parameters as a :class:`Schema`. The schema builds the float row the compiled kernel reads
(:meth:`Schema.row`, validating every value and naming it in errors) and gives the kernel
its column indices by name (:attr:`Schema.col`, a namedtuple of ints: numba treats a global
namedtuple as a constant, so ``p[i, C.kp]`` compiles to a fixed offset)::

    PARAMS = Schema("pid", kp=Param(check=positive), ki=0.0, kd=0.0)
    C = PARAMS.col

    @numba.njit
    def control(p, s, i, ...):
        return p[i, C.kp] * e + ...

A state block is declared the same way (:func:`state_schema`), with every column starting at
zero.

>>> from contour_gym._validate import positive
>>> pid = Schema("pid", kp=Param(check=positive), ki=0.0)
>>> pid.row(kp=2.0).tolist(), pid.col.ki
([2.0, 0.0], 1)
>>> pid.row(kp=-1.0)
Traceback (most recent call last):
...
ValueError: pid.kp must be > 0, got -1.0
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym._validate import finite

Check = Callable[[Any, str], float]


@dataclass(frozen=True)
class Param:
    """One named parameter.

    Attributes:
        default: Value when none is given; ``None`` makes the parameter required.
        check: ``check(value, name) -> float``; raises ValueError naming the value (default:
            any finite number).
        doc: What the parameter means, with its unit.
    """

    default: float | None = None
    check: Check | None = None
    doc: str = ""


class Schema:
    """Named float parameters of a component, in column order.

    Args:
        name: Component name (quoted in errors).
        **params: Parameter name -> :class:`Param`, or a plain number (its default).
    """

    def __init__(self, name: str, **params: Param | float) -> None:
        self.name = name
        self.params: dict[str, Param] = {
            k: v if isinstance(v, Param) else Param(float(v)) for k, v in params.items()
        }
        self.names: tuple[str, ...] = tuple(self.params)
        cols = namedtuple(f"{_ident(name)}_cols", self.names) if self.names else None
        self.col: Any = cols(*range(len(self.names))) if cols is not None else ()

    @property
    def size(self) -> int:
        """Number of columns."""
        return len(self.names)

    def __repr__(self) -> str:
        return f"Schema({self.name!r}, {', '.join(self.names)})"

    def defaults(self) -> dict[str, float | None]:
        """Name -> default (None where required)."""
        return {k: p.default for k, p in self.params.items()}

    def check_names(self, values: Mapping[str, Any]) -> None:
        """Raise ValueError for keys that are not parameters, listing the accepted ones."""
        unknown = sorted(set(values) - set(self.names))
        if unknown:
            raise ValueError(
                f"unknown parameter(s) {', '.join(unknown)} for {self.name!r}; "
                f"accepted: {', '.join(self.names) or 'none'}"
            )

    def value(self, key: str, value: Any) -> float:
        """One parameter checked by its rule (ValueError naming ``name.key`` and the value)."""
        check = self.params[key].check or finite
        return float(check(value, f"{self.name}.{key}"))

    def row(self, **values: Any) -> NDArray[np.float64]:
        """The (size,) float row; missing parameters take their defaults.

        Raises:
            ValueError: for an unknown name, a missing required value or a value its check
                rejects.
        """
        self.check_names(values)
        out = np.zeros(max(self.size, 1))
        for j, (key, param) in enumerate(self.params.items()):
            given = values.get(key, param.default)
            if given is None:
                raise ValueError(f"{self.name}: parameter {key!r} is required")
            out[j] = self.value(key, given)
        return out[: self.size] if self.size else np.zeros(0)

    def rows(self, n: int, **values: Any) -> NDArray[np.float64]:
        """(n, size) rows: each value a scalar (every row) or a sequence of ``n``.

        Raises:
            ValueError: as :meth:`row`, or for a sequence of the wrong length.
        """
        self.check_names(values)
        out = np.zeros((n, self.size))
        for j, (key, param) in enumerate(self.params.items()):
            given = values.get(key, param.default)
            if given is None:
                raise ValueError(f"{self.name}: parameter {key!r} is required")
            arr = np.asarray(given, dtype=object)
            items = [given] * n if arr.ndim == 0 else list(arr.reshape(-1))
            if len(items) != n:
                raise ValueError(
                    f"{self.name}.{key} must be a scalar or {n} values, got {len(items)}"
                )
            out[:, j] = [self.value(key, v) for v in items]
        return out


def state_schema(name: str, *columns: str) -> Schema:
    """A state block: named columns, all starting at zero."""
    return Schema(name, **{c: 0.0 for c in columns})


def _ident(name: str) -> str:
    text = "".join(ch if ch.isalnum() else "_" for ch in name)
    return text if text and not text[0].isdigit() else f"s_{text}"
