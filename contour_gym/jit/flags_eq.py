"""Faster equality of numba's compiler flags, which its typing compares ~10^5 times a kernel.

numba resolves every call of an overloaded function (``min``, ``max``, ``int``, numpy's
functions) through a cache keyed on the compiler's flags
(``numba.core.typing.templates._OverloadFunctionTemplate._get_impl``), and a compile makes new
flags objects of equal value, so each lookup compares two objects by
``TargetConfig.__eq__``: a dictionary of every option (~20 attribute reads) built for each
side (the counts and times are in docs/measurements.md).

:func:`install` answers from the options set explicitly first: two flags of one class whose
explicitly set options are equal are equal (every other option has its class's default on
both sides), and only otherwise does numba's own comparison decide. The answer is the same
in every case, so nothing compiled changes; it is installed only when numba's ``__eq__`` is
still the one this was written against.
"""

from __future__ import annotations

import inspect
from typing import Any

_EXPECTED = "return self.values() == other.values()"


def _fast_eq(original: Any) -> Any:
    def __eq__(self: Any, other: Any) -> Any:  # noqa: N807 - numba's method name
        if self is other:
            return True
        if type(self) is type(other) and self._values == other._values:
            return True
        return original(self, other)

    __eq__.wrapped = original  # type: ignore[attr-defined]
    return __eq__


def install() -> bool:
    """Install the faster flags equality; False if numba's code is not as expected."""
    try:
        from numba.core.targetconfig import TargetConfig
    except ImportError:  # pragma: no cover - numba is a dependency
        return False
    current = TargetConfig.__dict__.get("__eq__")
    if current is None:
        return False
    if getattr(current, "wrapped", None) is not None:
        return True
    try:
        source = inspect.getsource(current)
    except (OSError, TypeError):
        return False
    if _EXPECTED not in source or "_values" not in TargetConfig.__slots__:
        return False
    TargetConfig.__eq__ = _fast_eq(current)  # type: ignore[method-assign]
    return True
