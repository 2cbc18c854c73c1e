"""Flat observations: the Dict's values in one array, as FlattenObservation gives them.

Kept free of stable-baselines3 so that saved agents register without importing it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

FLATTEN_WRAPPER = "gymnasium.wrappers.FlattenObservation"  # the env_wrapper flatten=True mirrors


def flatten_obs(obs: Mapping[str, Any], keys: Sequence[str], batch: int | None) -> NDArray[Any]:
    """A Dict observation's values in ``keys`` order as one float32 array.

    Args:
        obs: The observation (every value ``(batch, ...)``, or unbatched with ``batch`` None).
        keys: The Dict space's keys, in its order.
        batch: Members, or None for one unbatched observation.

    Returns:
        ``(batch, n)`` (or ``(n,)``), equal to ``gymnasium.spaces.flatten`` of each member.
    """
    shape = (-1,) if batch is None else (batch, -1)
    return np.concatenate([np.asarray(obs[k], dtype=np.float32).reshape(shape) for k in keys],
                          axis=-1)
