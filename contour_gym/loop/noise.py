"""The servo loop's random numbers: one generator per member, read in chunks by the kernel.

:func:`member_generators` turns the seed given to :meth:`contour_gym.loop.ServoLoop.reset` into
one ``numpy.random.Generator`` per reset member; :class:`NoiseSource` draws each member's
standard normals from its own generator, in order, and hands the kernel a buffer to read them
from. A member's result therefore depends only on its own seed, never on ``B``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from contour_gym._validate import seed_value
from contour_gym.loop.state import STATUS_OK
from contour_gym.plant.stage import Stage

Array = NDArray[np.float64]
NOISE_CHUNK = 256  # ticks of normals drawn per member at a time


class NoiseSource:
    """Per-member standard normals, drawn in chunks, each member with its own read position.

    A member's numbers are its own generator's normal stream consumed in order (numpy fills
    arrays sequentially, so chunk sizes do not matter): results never depend on B, on how a
    run is cut into calls, or on other members' resets and pauses. The kernel reads member
    ``b``'s rows in place from ``pos[b]`` (the loop's ``noise_at``) and advances it.

    Args:
        batch: Number of members B.
        width: Normals per member and tick.
        active: Whether the loop draws noise at all (else :meth:`take` gives an empty buffer).
    """

    def __init__(self, batch: int, width: int, active: bool) -> None:
        self.width, self.active = width, active
        self.gens: list[np.random.Generator | None] = [None] * batch
        self.buf = np.zeros((batch, NOISE_CHUNK if active else 0, width))
        self.end = np.zeros(batch, dtype=np.int64)  # end of the valid rows per member
        self.ahead = 0  # rows every member has left at least (a call takes n from each)

    def reseed(
        self, members: NDArray[np.intp], gens: list[np.random.Generator | None], pos: Any
    ) -> None:
        """Give ``members`` new generators; their next :meth:`take` draws fresh numbers."""
        for b, g in zip(members, gens, strict=True):
            self.gens[b] = g
            pos[b] = self.end[b] = 0  # nothing left: the next take draws fresh
        self.ahead = 0

    def take(self, n: int, status: NDArray[np.int64], pos: Any) -> Array:
        """The buffer (B, rows, width): rows ``pos[b]`` on hold ``n`` for running members.

        Without noise, an empty buffer (B, 0, width).
        """
        if not self.active:
            return self.buf
        if n <= self.ahead:  # every member has its n rows: no array work on a short call
            self.ahead -= n
            return self.buf
        running = status == STATUS_OK
        if n > self.buf.shape[1]:
            grown = np.zeros((self.buf.shape[0], n, self.width))
            grown[:, : self.buf.shape[1]] = self.buf
            self.buf = grown
        cap = self.buf.shape[1]
        for b in np.flatnonzero(running & (pos + n > self.end)):
            rest = self.buf[b, pos[b] : self.end[b]].copy()
            self.buf[b, : len(rest)] = rest
            self.buf[b, len(rest) :] = self.gens[b].standard_normal((cap - len(rest), self.width))  # type: ignore[union-attr]
            pos[b], self.end[b] = 0, cap
        self.ahead = int((self.end - pos).min()) - n
        return self.buf


def draws_noise(stage: Stage, ideal: bool) -> bool:
    """Whether a loop on ``stage`` draws random numbers (``ideal``: only random disturbances)."""
    if not ideal:
        return stage.is_random
    return any(x.disturbance is not None and x.disturbance.is_random for x in stage.axes)


def member_generators(
    seed: int | Sequence[int] | None, count: int, active: bool
) -> list[np.random.Generator | None]:
    """The reset members' generators, checked seeds.

    Args:
        seed: An int (member ``i`` uses child ``i`` of ``SeedSequence(seed)``), one seed per
            member, or None for fresh entropy.
        count: Number of reset members.
        active: Whether the loop draws noise: None each when not (a tuner's reset of 16
            members spent 0.2 ms making generators it never used).

    Raises:
        ValueError: for a bad seed, or a sequence of other than ``count`` seeds.
    """
    if seed is None or isinstance(seed, (int, np.integer)):
        root = np.random.SeedSequence(None if seed is None else seed_value(seed))
        children = root.spawn(count) if active else []
    else:
        if not isinstance(seed, (Sequence, np.ndarray)) or isinstance(seed, (str, bytes)):
            raise ValueError("seed must be a non-negative int, a sequence of them or None, "
                             f"got {seed!r}")
        roots = [np.random.SeedSequence(seed_value(s)) for s in seed]
        if len(roots) != count:
            raise ValueError(f"need {count} seeds, got {len(roots)}")
        children = [r.spawn(1)[0] for r in roots] if active else []
    if not active:
        return [None] * count
    return [np.random.default_rng(c) for c in children]
