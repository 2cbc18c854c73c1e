"""One registry class behind every extension point (presets, estimators, controllers, ...).

Packages may ship components as plugins: a module declared under the entry-point group
:data:`PLUGIN_GROUP` registers them on import. :func:`load_plugins` imports every such module
once; a registry asked for a name it does not hold loads them before it says no, so a
plugin's component can be named as soon as ``contour_gym`` is imported.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import logging
import threading
from collections.abc import Callable, Iterator
from typing import Generic, Protocol, TypeVar

PLUGIN_GROUP = "contour_gym.components"
_PLUGINS: list[str] = []
_LOCK = threading.RLock()


def load_plugins() -> tuple[str, ...]:
    """Import the plugin modules (once); returns the top-level packages that declared them."""
    with _LOCK:
        if not _PLUGINS:
            names = []
            for entry in importlib.metadata.entry_points(group=PLUGIN_GROUP):
                try:
                    importlib.import_module(entry.value)
                except ImportError as exc:  # a broken plugin: its components are missing
                    logging.getLogger("contour_gym").warning(
                        "contour-gym: component plugin %s failed: %s", entry.value, exc)
                    continue
                names.append(entry.value.split(".")[0])
            _PLUGINS.extend(sorted(set(names)) or [""])
    return tuple(p for p in _PLUGINS if p)


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
        loader: Imports the modules that register the built-in items; called once, at the
            first lookup, listing or count.
    """

    def __init__(self, kind: str, loader: Callable[[], object] | None = None) -> None:
        self.kind = kind
        self._items: dict[str, T] = {}
        self._loader = loader  # imports the modules that register the built-in items (once)

    def add_loader(self, loader: Callable[[], object]) -> None:
        """Have ``loader`` import more modules that register items, once, at the next lookup.

        Called at the next lookup, listing or count (after the loader given at construction,
        if that has not run). For items whose modules sit above the registry's own: a module
        that knows them adds the loader, and the registry's module need not import them.
        """
        earlier = self._loader
        self._loader = loader if earlier is None else (lambda: (earlier(), loader()))

    def _load(self) -> None:
        # the built-in items, registered by their modules on import, on first use (so that a
        # module defining the registry need not import the modules that fill it)
        loader, self._loader = self._loader, None
        if loader is not None:
            loader()

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
        self._load()
        if isinstance(name, str) and name not in self._items:
            load_plugins()  # a plugin's component, not imported yet
        if not isinstance(name, str) or name not in self._items:
            raise ValueError(f"unknown {self.kind} {name!r}; accepted: {', '.join(self.names())}")
        return self._items[name]

    def components(self) -> list[T]:
        """Registered components, sorted by name."""
        return [self._items[name] for name in self.names()]

    def names(self) -> tuple[str, ...]:
        """Registered names, sorted."""
        self._load()
        return tuple(sorted(self._items))

    def __contains__(self, name: object) -> bool:
        self._load()
        return name in self._items

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        self._load()
        return len(self._items)
