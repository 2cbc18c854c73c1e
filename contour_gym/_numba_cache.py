"""Point numba's on-disk cache at a folder keyed by a hash of this package's sources.

numba's ``cache=True`` checks only the source file of the cached function itself, so after
an edit to a function it *calls* in another module (the loop kernel calls the plant, servo,
estimator and geometry kernels) it would silently load stale machine code. Keying the cache
folder on every source file makes any edit start a fresh cache. Set ``NUMBA_CACHE_DIR`` to
choose the folder yourself (then this does nothing).
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import numba

KEEP = 3  # most recent cache folders kept; older ones are removed


def configure() -> None:
    """Set ``numba.config.CACHE_DIR`` unless the user set ``NUMBA_CACHE_DIR``."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    package = Path(__file__).resolve().parent
    digest = hashlib.sha1()
    for source in sorted(package.rglob("*.py")):
        digest.update(source.relative_to(package).as_posix().encode())
        digest.update(source.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "contour_gym" / "numba"
    target = base / digest.hexdigest()[:16]
    try:
        target.mkdir(parents=True, exist_ok=True)
        target.touch()
    except OSError:
        return  # unwritable home: numba's default (next to the sources) stays in force
    numba.config.CACHE_DIR = str(target)  # type: ignore[attr-defined]
    _prune(base, target)


def _prune(base: Path, current: Path) -> None:
    folders = sorted((p for p in base.iterdir() if p.is_dir()), key=lambda p: p.stat().st_mtime)
    for old in folders[:-KEEP]:
        if old != current:
            shutil.rmtree(old, ignore_errors=True)
