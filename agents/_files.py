"""Files a run writes: whole or not at all, and only where a file may be.

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
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from contour_gym.limits import check_size


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


MAX_PLOT_BYTES = 1e9  # a plot's pixels (RGBA) in memory at most
MAX_PLOT_SIDE = 1 << 16  # pixels on a side at most (matplotlib's Agg draws no more)


def check_plot(inches: Sequence[float], dpi: float) -> None:
    """Refuse (ValueError) a plot of ``inches`` (width, height) at ``dpi`` too large to draw.

    Past :data:`MAX_PLOT_SIDE` pixels on a side, or :data:`MAX_PLOT_BYTES` (or the memory
    available) of pixels.
    """
    width, height = (float(x) * dpi for x in inches)
    what = f"a {width:.0f} x {height:.0f} pixel plot (dpi {dpi:g})"
    if max(width, height) > MAX_PLOT_SIDE:
        raise ValueError(f"{what} is more than {MAX_PLOT_SIDE} pixels on a side: lower --dpi")
    check_size(4.0 * width * height, what, "--dpi", cap=MAX_PLOT_BYTES)


def save_figure(fig: Any, target: Path, dpi: float = 120.0) -> None:
    """Save a matplotlib figure whole or not at all; the format from the file name.

    Raises:
        ValueError: for a size at ``dpi`` past :data:`MAX_PLOT_SIDE` pixels on a side or
            :data:`MAX_PLOT_BYTES` (or the memory available), before it is drawn.
    """
    check_plot(fig.get_size_inches(), dpi)
    fmt = target.suffix[1:] or "png"
    write_atomically(target, lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))


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
