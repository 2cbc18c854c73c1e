"""Where compiled code lives: numba's cache folder, named by a digest of the kernel modules.

numba's ``cache=True`` keys a function's machine code on its own file only, so after an edit
to a function it *calls* in another module it would load stale code. :func:`configure` points
numba at a folder named by a digest of the package's kernel modules (every module with
compiled code), taken over their syntax trees without docstrings: editing a docstring or
comment, or any module without compiled code, recompiles nothing. Set ``NUMBA_CACHE_DIR`` to
choose the folder yourself (then this does nothing). Generated kernel modules
(:mod:`contour_gym.jit.binding`) and the markers of what compiled live in it too.
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import logging
import os
import shutil
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType

import numba

from contour_gym.jit import flags_eq, inline_copy

KEEP = 3  # cache folders kept; older ones are removed
LOG = logging.getLogger("contour_gym")
PACKAGE = Path(__file__).resolve().parent.parent  # the contour_gym package
PARSE_LOCK = threading.Lock()  # Python 3.11's parser fails when two threads run it at once










@functools.lru_cache(maxsize=1024)
def code_digest(source: str) -> str:
    r"""Digest of Python source over its syntax tree, docstrings removed (comments never count).

    >>> documented = "def f():\n    'Doc.'\n    return 1"
    >>> code_digest(documented) == code_digest("def f():  # a comment\n    return 1")
    True
    """
    with PARSE_LOCK:
        tree = ast.parse(source)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and _is_docstring(body[0]):
            node.body = body[1:] or [ast.Pass()]  # type: ignore[attr-defined]
    return hashlib.sha1(ast.dump(tree).encode()).hexdigest()


def _is_docstring(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.Expr)
        and isinstance(node.value, ast.Constant)
        and isinstance(node.value.value, str)
    )


def kernel_sources() -> list[Path]:
    """The package's modules that hold compiled code (numba's decorators), sorted."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if any(mark in text for mark in _KERNEL_MARKS):
            out.append(path)
    return out


# what a module with compiled code contains (numba.config alone does not count)
_KERNEL_MARKS = ("njit", "@intrinsic", "@overload", "register_jitable")


def package_digest() -> str:
    """Digest of the package's kernel modules (:func:`code_digest` of each, with its path).

    Parsing the modules took 0.1-0.14 s in every process that imports the package, so the
    digest is remembered in a ``digests`` folder beside :func:`cache_root`'s
    (``~/.cache/contour_gym/digests``), under a digest of the modules' text as it is: a pure
    function of that text, so a memo is never stale, only absent (then computed, and
    written if the folder is writable).
    """
    texts = [(path.relative_to(PACKAGE).as_posix(), path.read_text(encoding="utf-8"))
             for path in kernel_sources()]
    raw = hashlib.sha1()
    for name, text in texts:
        raw.update(f"{name}\0{len(text)}\0".encode())
        raw.update(text.encode())
    memo = cache_root().parent / "digests" / raw.hexdigest()
    with contextlib.suppress(OSError, UnicodeDecodeError):
        known = memo.read_text(encoding="ascii")
        if len(known) == 16 and all(c in "0123456789abcdef" for c in known):
            return known
        memo.unlink()  # not a digest (a disk error): written afresh below
    digest = hashlib.sha1()
    for name, text in texts:
        digest.update(name.encode())
        digest.update(code_digest(text).encode())
    result = digest.hexdigest()[:16]
    with contextlib.suppress(OSError):
        memo.parent.mkdir(parents=True, exist_ok=True)
        create_atomically(memo, result)
        _prune(memo.parent, memo, keep=4 * KEEP)
    return result


_DIGEST: list[str] = []


def current_digest() -> str:
    """:func:`package_digest`, worked out once per process."""
    if not _DIGEST:
        _DIGEST.append(package_digest())
    return _DIGEST[0]


def cache_root() -> Path:
    """Folder holding the per-digest cache folders (``~/.cache/contour_gym/numba``)."""
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "contour_gym" / "numba"


def configure() -> None:
    """Set ``numba.config.CACHE_DIR`` unless the user set ``NUMBA_CACHE_DIR``; faster inlining.

    Also installs :mod:`contour_gym.jit.inline_copy` (numba copies inlined IR quadratically)
    and :mod:`contour_gym.jit.flags_eq` (its typing compares compiler flags slowly).
    """
    inline_copy.install()
    flags_eq.install()
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    target = cache_root() / current_digest()
    try:
        target.mkdir(parents=True, exist_ok=True)
        target.touch()
    except OSError:
        return  # unwritable home: numba's default (next to the sources) stays in force
    numba.config.CACHE_DIR = str(target)  # type: ignore[attr-defined]
    _prune(target.parent, target)


def _prune(base: Path, current: Path, keep: int = KEEP) -> None:
    # the newest `keep` entries of `base` of `current`'s kind (folder or file) stay, and it
    kind = Path.is_dir if current.is_dir() else Path.is_file
    entries = sorted((p for p in base.iterdir() if kind(p)), key=lambda p: p.stat().st_mtime)
    for old in entries[:-keep]:
        if old == current:
            continue
        if old.is_dir():
            shutil.rmtree(old, ignore_errors=True)
        else:
            with contextlib.suppress(OSError):
                old.unlink()


def generated_dir() -> Path:
    """Where generated kernel modules are written (inside numba's cache folder, else a temp one)."""
    base = str(getattr(numba.config, "CACHE_DIR", "") or "")
    candidates = [Path(base) / "generated"] if base else []
    fallback = Path(tempfile.gettempdir()) / "contour_gym_generated"
    candidates.append(fallback / current_digest())
    for folder in candidates:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            return folder
        except OSError:
            continue
    raise OSError(f"no writable folder for contour-gym's generated kernels: {candidates}")


def create_atomically(path: Path, text: str) -> None:
    """Write ``path`` complete or not at all, and never replace it.

    numba's cache entries for a generated module are keyed by its modification time, so
    another process' rewrite would invalidate them.
    """
    fd, tmp = tempfile.mkstemp(suffix=".py", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        with contextlib.suppress(FileExistsError):
            os.link(tmp, path)
    finally:
        os.unlink(tmp)


def needs_compile(module: ModuleType) -> bool:
    """Whether ``module``'s kernels have not been compiled (and cached) before."""
    return not Path(str(module.__file__)).with_suffix(".compiled").exists()


def mark_compiled(module: ModuleType) -> None:
    """Record that ``module``'s kernels are in numba's cache (no notice next time)."""
    marker = Path(str(module.__file__)).with_suffix(".compiled")
    if not marker.exists():
        with contextlib.suppress(OSError):
            marker.touch()


@contextlib.contextmanager
def locked(path: Path | str, wait: bool = True) -> Iterator[bool]:
    """Hold an exclusive lock on the file ``path`` for the block; yields whether it got it.

    Args:
        path: The lock file (created if missing).
        wait: Wait until the lock is free; else give up at once if another process holds it.
            Without ``fcntl`` (Windows) the lock is never got: waiting blocks run unlocked.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield wait
        return
    with open(path, "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except OSError:
            yield False
            return
        yield True
