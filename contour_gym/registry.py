"""The public home of :class:`Registry`, the name -> component table behind every extension point.

A registry holds components (presets, controllers, CCC laws, tuning protocols, ...) by their
``name``: ``register`` adds one (refusing a taken name unless ``replace``), ``get`` returns one
or raises ValueError listing the accepted names, and a name it does not hold first loads the
plugins declared under the entry-point group ``contour_gym.components``. Packages building
their own extension points on contour_gym make theirs with ``Registry("what it holds")``.
"""

from __future__ import annotations

from contour_gym._registry import Registry

__all__ = ["Registry"]
