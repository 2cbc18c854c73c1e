"""Files the library writes: whole or not at all, and only where a file may be.

Every output goes through :func:`write_atomically`: a regular file is replaced whole (a temp
file beside it, renamed over it), a symbolic link is written through to the file it points to
(the link stays a link), and anything else at the path (a folder, a device, a FIFO, a socket)
is refused with :class:`OutputPathError` before anything is written. The command line checks
its output paths the same way before it starts any work (:func:`output_file`,
:func:`output_folder`).
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any


class OutputPathError(ValueError):
    """An output path where no file may be written (a folder, a device, a FIFO, ...)."""


_KINDS = ((stat.S_ISREG, "a file"), (stat.S_ISDIR, "a folder"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"))


def _kind(path: Path) -> str | None:
    # what is at ``path`` (links followed), in words; None: nothing
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return None
    return next((kind for test, kind in _KINDS if test(mode)), "not a file")


def output_file(target: Path | str, what: str = "output file") -> Path:
    """Where writing ``target`` goes: the path itself, or the file a symbolic link points to.

    Args:
        target: The path asked for.
        what: What it is, for the error.

    Raises:
        OutputPathError: when something other than a regular file is at that place.
    """
    path = Path(target)
    real = Path(os.path.realpath(path)) if path.is_symlink() else path
    kind = _kind(real)
    if kind not in (None, "a file"):
        via = f" (a link to {real})" if real != path else ""
        raise OutputPathError(f"{what} {path}{via} is {kind}, not a file: give a file path")
    return real


def output_folder(target: Path | str, what: str = "output folder") -> Path:
    """``target`` if a folder may be made or written there.

    Raises:
        OutputPathError: when something other than a folder is at that place.
    """
    path = Path(target)
    kind = _kind(path)
    if kind not in (None, "a folder"):
        raise OutputPathError(f"{what} {path} is {kind}, not a folder: give a folder path")
    return path


def write_atomically(target: Path, write: Callable[[str], object]) -> None:
    """Write ``target`` by ``write(temp)`` into a temp file beside it, then rename.

    An interrupted write never leaves a partial ``target`` (nor the temp file). The temp file
    ends in ``.tmp``: writers that infer a format from the name must be told it. A symbolic
    link is written through (its file is replaced, the link kept); anything else that is not
    a regular file is refused (:func:`output_file`).
    """
    target = output_file(target)
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


def remove_temporaries(folder: Path) -> list[Path]:
    """Remove the temporary files :func:`write_atomically` left in ``folder`` (and below).

    A write killed outright (``kill -9``, a power cut) leaves its ``.NAME.XXXX.tmp``; call
    this only on a folder no other process is writing. Returns the files removed.
    """
    removed = [p for p in folder.rglob(".*.tmp") if p.is_file()]
    for path in removed:
        path.unlink()
    return removed


def write_text(target: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``target`` whole or not at all (:func:`write_atomically`)."""
    write_atomically(target, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
