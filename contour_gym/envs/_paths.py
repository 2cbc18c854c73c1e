"""Random paths of an env (``EnvConfig.path = "random"``): the options of its draws.

Each member draws its path at each reset with :func:`contour_gym.paths.random_path` from its
own generator, with these keyword arguments: ``within`` defaults to the machine's travel box
(:func:`travel_box`), the task may add its defaults (the feedrate task: ``feed_range``,
:meth:`contour_gym.tasks.Task.path_defaults`), and the env's ``path_options`` override both.
"""

from __future__ import annotations

import functools
import pickle
from collections.abc import Mapping
from typing import Any

import numpy as np

from contour_gym.paths import random_path
from contour_gym.paths._random import DEFAULT_WITHIN
from contour_gym.plant.stage import Stage

RANDOM = "random"  # EnvConfig.path of an env whose members draw their paths
# random_path's keyword arguments an env may set (rng and dim are the env's)
PATH_OPTIONS = ("family", "within", "length", "feed_range", "margin")
TRAVEL_MARGIN = 0.05  # the default box: each axis' travel less this fraction of it at each end


def check_path_options(path: Any, options: Any) -> None:
    """Raise ValueError for bad ``path_options``.

    They must be a dict of :data:`PATH_OPTIONS` keys, given only with ``path="random"``; the
    error names the unknown keys.
    """
    if not isinstance(options, Mapping):
        raise ValueError(f"path_options must be a dict, got {options!r}")
    unknown = sorted(set(options) - set(PATH_OPTIONS))
    if unknown:
        raise ValueError(f"unknown path_options key(s) {unknown}; accepted: "
                         f"{', '.join(PATH_OPTIONS)}")
    if options and path != RANDOM:
        raise ValueError(f"path_options apply to path='random', got path={path!r}")


def travel_box(stage: Stage, margin: float = TRAVEL_MARGIN) -> tuple[tuple[float, float], ...]:
    """The x-y box, m, where a path keeps every contour's axes within their travel.

    Each contour's coordinate ``j`` may span its axis' travel less the contour's offset; the
    box is the intersection over the contours, shrunk by ``margin`` of its width at each end.
    An axis without a travel leaves the coordinate at random_path's default (+-50 mm).
    """
    box = np.array(DEFAULT_WITHIN, dtype=float)
    limited = np.zeros(2, dtype=bool)
    for j, _, offset, travel in stage.limited_coordinates():
        if j >= 2:
            continue
        lo, hi = travel[0] - offset, travel[1] - offset
        box[j] = (lo, hi) if not limited[j] else (max(box[j, 0], lo), min(box[j, 1], hi))
        limited[j] = True
    width = box[:, 1] - box[:, 0]
    box[limited] += np.outer(width[limited] * margin, [1.0, -1.0])
    return tuple((float(lo), float(hi)) for lo, hi in box)


def path_options(stage: Stage, defaults: Mapping[str, Any], given: Mapping[str, Any]
                 ) -> dict[str, Any]:
    """The keyword arguments of each draw: travel box, the task's ``defaults``, ``given``."""
    return {"within": travel_box(stage), **defaults, **given}


def draw_path(rng: np.random.Generator, stage: Stage, options: Mapping[str, Any]) -> Any:
    """One random path on ``stage`` from ``rng`` (:func:`contour_gym.paths.random_path`).

    The last :data:`DRAWS_KEPT` draws of this process are kept, keyed by the generator's
    state and the options: a draw from the same state returns the same (immutable) path and
    leaves ``rng`` in the state the draw would have left it, so results are bit for bit those
    of drawing again. A bench scenario's policies each run the same seeded paths (a free-form
    curve takes 10-35 ms to fit). Anything else (not a generator of numpy's own bit
    generators, options of no fixed value) is drawn anew.
    """
    kind: Any = type(getattr(rng, "bit_generator", None))
    try:
        frozen = _frozen(options)
        hash(frozen)
    except TypeError:
        kind = None
    if kind not in _NUMPY_BIT_GENERATORS:
        return random_path(rng, dim=stage.dim, **options)
    path, after = _draw(kind, pickle.dumps(rng.bit_generator.state), stage.dim, frozen)
    rng.bit_generator.state = after
    return path


def reset_draws(rng: np.random.Generator, stage: Stage, options: Mapping[str, Any] | None
                ) -> tuple[int, Any]:
    """What a member draws from its generator at a reset, after its machine's randomisation.

    Its servo loop's seed, then, on random paths (``options`` not None), its path (drawn last,
    so that the streams of envs on fixed paths stay as they were).

    Returns:
        The loop's seed and the path (None on a fixed path).
    """
    seed = int(rng.integers(2**63 - 1))
    return seed, None if options is None else draw_path(rng, stage, options)


# the bit generators a kept draw can rebuild from their state alone
_NUMPY_BIT_GENERATORS = (np.random.PCG64, np.random.PCG64DXSM, np.random.MT19937,
                         np.random.Philox, np.random.SFC64)
DRAWS_KEPT = 64  # random paths a process keeps (100-160 kB each for the free-form curves)


@functools.lru_cache(maxsize=DRAWS_KEPT)
def _draw(kind: type, state: bytes, dim: int, options: tuple[tuple[str, Any], ...]
          ) -> tuple[Any, Mapping[str, Any]]:
    # the path drawn from a generator in ``state`` and the generator's state after the draw
    rng = np.random.Generator(kind())
    rng.bit_generator.state = pickle.loads(state)
    path = random_path(rng, dim=dim, **dict(options))
    return path, rng.bit_generator.state


def _frozen(value: Any) -> Any:
    # a hashable copy of an option's value: mappings as sorted pairs, sequences as tuples
    if isinstance(value, Mapping):
        return tuple(sorted((k, _frozen(v)) for k, v in value.items()))
    if isinstance(value, (list, tuple, np.ndarray)):
        return tuple(_frozen(v) for v in value)
    return value
