"""Faster equality and hash of numba's compiler flags, which its typing uses ~10^5 times a kernel.

numba resolves every call of an overloaded function (``min``, ``max``, ``int``, numpy's
functions) through a cache keyed on the compiler's flags
(``numba.core.typing.templates._OverloadFunctionTemplate._get_impl``), and a compile makes new
flags objects, so each lookup hashes one and compares it with others by
``TargetConfig.__hash__`` and ``__eq__``: each builds a dictionary of every option (~20
property reads) for each side (the counts and times are in docs/measurements.md).

:func:`install` computes the same answers from the class's defaults and the options set
explicitly (a flags object's option reads ``_values.get(name, default)``, so its values are the
defaults updated by ``_values``): equality compares those two merged dictionaries, and the hash,
``hash(tuple(sorted(self.values())))`` in numba, is the hash of the sorted option names (a
dictionary iterates its keys), the same for every object of a class, so it is computed once per
class. The answers are numba's own in every case, so nothing compiled changes. Each is
installed only when numba's method is still the one this was written against, and a class
whose options are not all numba's plain properties keeps numba's comparison.
"""

from __future__ import annotations

import inspect
from typing import Any

_EXPECTED_EQ = "return self.values() == other.values()"
_EXPECTED_HASH = "return hash(tuple(sorted(self.values())))"
_GETTER = "make_prop.<locals>.getter"

_DEFAULTS: dict[type, dict[str, Any] | None] = {}
_HASHES: dict[type, int] = {}


def _defaults(cls: type) -> dict[str, Any] | None:
    """The class's option defaults, or None when an option is read by other than numba's getter."""
    if cls not in _DEFAULTS:
        options = cls.options  # type: ignore[attr-defined]
        plain = all(
            isinstance(prop := getattr(cls, name, None), property)
            and getattr(prop.fget, "__qualname__", "").endswith(_GETTER)
            for name in options
        )
        defaults = {name: option.default for name, option in options.items()}
        _DEFAULTS[cls] = defaults if plain else None
    return _DEFAULTS[cls]


def _fast_eq(original: Any) -> Any:
    def __eq__(self: Any, other: Any) -> Any:  # noqa: N807 - numba's method name
        if self is other:
            return True
        if type(self) is not type(other):
            return original(self, other)
        if self._values == other._values:
            return True
        defaults = _defaults(type(self))
        if defaults is None or not set(self._values).union(other._values) <= defaults.keys():
            return original(self, other)
        return {**defaults, **self._values} == {**defaults, **other._values}

    __eq__.wrapped = original  # type: ignore[attr-defined]
    return __eq__


def _fast_hash(original: Any) -> Any:
    def __hash__(self: Any) -> int:  # noqa: N807 - numba's method name
        cls = type(self)
        found = _HASHES.get(cls)
        if found is None:
            found = _HASHES[cls] = original(self)
        return found

    __hash__.wrapped = original  # type: ignore[attr-defined]
    return __hash__


def _replace(cls: type, name: str, expected: str, faster: Any) -> bool:
    current = cls.__dict__.get(name)
    if current is None:
        return False
    if getattr(current, "wrapped", None) is not None:
        return True
    try:
        source = inspect.getsource(current)
    except (OSError, TypeError):
        return False
    if expected not in source:
        return False
    setattr(cls, name, faster(current))
    return True


def install() -> bool:
    """Install the faster flags equality and hash; False if numba's code is not as expected."""
    try:
        from numba.core.targetconfig import TargetConfig
    except ImportError:  # pragma: no cover - numba is a dependency
        return False
    if "_values" not in TargetConfig.__slots__:
        return False
    eq = _replace(TargetConfig, "__eq__", _EXPECTED_EQ, _fast_eq)
    return _replace(TargetConfig, "__hash__", _EXPECTED_HASH, _fast_hash) and eq
