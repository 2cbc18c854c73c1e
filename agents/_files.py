"""Files a run writes: whole or not at all."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any


def write_atomically(target: Path, write: Callable[[str], object]) -> None:
    """Write ``target`` by ``write(temp)`` into a temp file beside it, then rename.

    An interrupted write never leaves a partial ``target`` (nor the temp file). The temp file
    ends in ``.tmp``: writers that infer a format from the name must be told it.
    """
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # a plain new file's mode, not mkstemp's private 0600
    try:
        write(tmp)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_handle_atomically(target: Path, write: Callable[[Any], object]) -> None:
    """:func:`write_atomically` through ``write(handle)``, a binary file open on the temp file.

    For writers that name their files themselves (stable-baselines3 adds a suffix to a path).
    """

    def through_handle(tmp: str) -> None:
        with open(tmp, "wb") as handle:
            write(handle)

    write_atomically(target, through_handle)


def save_figure(fig: Any, target: Path, dpi: float = 120.0) -> None:
    """Save a matplotlib figure whole or not at all; the format from the file name."""
    fmt = target.suffix[1:] or "png"
    write_atomically(target, lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))
