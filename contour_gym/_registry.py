"""One registry class behind every extension point (presets, estimators, controllers, ...)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Generic, Protocol, TypeVar


class Named(Protocol):
    """Anything with a ``name``."""

    @property
    def name(self) -> str:
        """Registry key."""
        ...


T = TypeVar("T", bound=Named)


class Registry(Generic[T]):
    """Name -> component, filled by :meth:`register` calls.

    Args:
        kind: What the registry holds ("estimator", "axis controller", ...), for messages.
    """

    def __init__(self, kind: str) -> None:
        self.kind = kind
        self._items: dict[str, T] = {}

    def register(self, item: T, *, replace: bool = False) -> T:
        """Add ``item`` under ``item.name``; returns it (usable as a one-line registration).

        Raises:
            ValueError: if the name is taken and ``replace`` is False, or is not an identifier
                made of letters, digits and underscores.
        """
        name = item.name
        if not name or not all(ch.isalnum() or ch == "_" for ch in name):
            raise ValueError(f"{self.kind} name must be letters, digits and '_', got {name!r}")
        if name in self._items and not replace:
            raise ValueError(f"{self.kind} {name!r} is already registered (pass replace=True)")
        self._items[name] = item
        return item

    def unregister(self, name: str) -> None:
        """Remove ``name`` (tests and interactive sessions)."""
        self.get(name)
        del self._items[name]

    def get(self, name: str) -> T:
        """The component called ``name``.

        Raises:
            ValueError: for an unknown name, listing the accepted ones.
        """
        if not isinstance(name, str) or name not in self._items:
            raise ValueError(f"unknown {self.kind} {name!r}; accepted: {', '.join(self.names())}")
        return self._items[name]

    def components(self) -> list[T]:
        """Registered components, sorted by name."""
        return [self._items[name] for name in self.names()]

    def names(self) -> tuple[str, ...]:
        """Registered names, sorted."""
        return tuple(sorted(self._items))

    def __contains__(self, name: object) -> bool:
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self._items)
