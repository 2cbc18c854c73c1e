"""Compiled code: numba's cache folder, kernels specialised per component, the first-run notice.

**Cache folder.** numba's ``cache=True`` keys a function's machine code on its own file only,
so after an edit to a function it *calls* in another module it would load stale code.
:func:`configure` points numba at a folder named by a digest of the package's kernel modules
(every module that imports numba), taken over their syntax trees without docstrings: editing
a docstring or comment, or any module without compiled code, recompiles nothing. Set
``NUMBA_CACHE_DIR`` to choose the folder yourself (then this does nothing).

**Specialised kernels.** The servo loop and the env step are written once, as templates
(``contour_gym._loopkernel``, ``contour_gym.envs._kernel``), whose *slots* (the axis
controller, the estimator, the friction laws, the CCC law, the reward) are module globals.
:func:`specialise` writes the template's source into a generated module named by a digest of
its text and of the components' sources, imports it and binds the slots to the components:
numba then compiles only the components a run uses and inlines them, and each combination is
cached on disk like any module. A component registered from a user's own module (a test, a
script) is bound the same way, so registering it is all it takes.

**First run.** The first call of a kernel not yet in the cache compiles it (tens of seconds on
a laptop CPU); :func:`notice_first_compile` says so once per kernel on the ``contour_gym``
logger at WARNING level, which Python prints to stderr unless the user configured logging
(``logging.getLogger("contour_gym").setLevel(logging.ERROR)`` silences it).
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import importlib.util
import inspect
import logging
import os
import shutil
import sys
import tempfile
import threading
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import Any

import numba

KEEP = 3  # cache folders kept; older ones are removed
SLOTS_MODULE = "contour_gym._slots"  # the templates import their slots from here
LOG = logging.getLogger("contour_gym")
_PACKAGE = Path(__file__).resolve().parent
_MODULES: dict[str, ModuleType] = {}
_NOTIFIED: set[str] = set()
_LOCK = threading.Lock()


def code_digest(source: str) -> str:
    r"""Digest of Python source over its syntax tree, docstrings removed (comments never count).

    >>> documented = "def f():\n    'Doc.'\n    return 1"
    >>> code_digest(documented) == code_digest("def f():  # a comment\n    return 1")
    True
    """
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
    """The package's modules that hold compiled code (they import numba), sorted."""
    out = []
    for path in sorted(_PACKAGE.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        if "import numba" in text or "from numba" in text:
            out.append(path)
    return out


def package_digest() -> str:
    """Digest of the package's kernel modules (:func:`code_digest` of each, with its path)."""
    digest = hashlib.sha1()
    for path in kernel_sources():
        digest.update(path.relative_to(_PACKAGE).as_posix().encode())
        digest.update(code_digest(path.read_text(encoding="utf-8")).encode())
    return digest.hexdigest()[:16]


_DIGEST: list[str] = []


def _package_digest_once() -> str:
    if not _DIGEST:
        _DIGEST.append(package_digest())
    return _DIGEST[0]


def cache_root() -> Path:
    """Folder holding the per-digest cache folders (``~/.cache/contour_gym/numba``)."""
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "contour_gym" / "numba"


def configure() -> None:
    """Set ``numba.config.CACHE_DIR`` unless the user set ``NUMBA_CACHE_DIR``."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    target = cache_root() / _package_digest_once()
    try:
        target.mkdir(parents=True, exist_ok=True)
        target.touch()
    except OSError:
        return  # unwritable home: numba's default (next to the sources) stays in force
    numba.config.CACHE_DIR = str(target)  # type: ignore[attr-defined]
    _prune(target.parent, target)


def _prune(base: Path, current: Path) -> None:
    folders = sorted((p for p in base.iterdir() if p.is_dir()), key=lambda p: p.stat().st_mtime)
    for old in folders[:-KEEP]:
        if old != current:
            shutil.rmtree(old, ignore_errors=True)


def generated_dir() -> Path:
    """Where generated kernel modules are written (inside numba's cache folder, else a temp one)."""
    base = str(getattr(numba.config, "CACHE_DIR", "") or "")
    candidates = [Path(base) / "generated"] if base else []
    fallback = Path(tempfile.gettempdir()) / "contour_gym_generated"
    candidates.append(fallback / _package_digest_once())
    for folder in candidates:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            return folder
        except OSError:
            continue
    raise OSError(f"no writable folder for contour-gym's generated kernels: {candidates}")


def identity(value: Any) -> str:
    """What a slot is bound to, for the generated module's header (changes recompile).

    A function is named with a digest of its module's source and of every module outside
    this package whose compiled functions that module uses, directly or through others (a
    user's law calling a user's kernel library); the package's own modules are covered by
    :func:`package_digest`.
    """
    func = getattr(value, "py_func", value)
    if inspect.isfunction(func):
        module = sys.modules.get(func.__module__)
        source = inspect.getsource(module) if module is not None else inspect.getsource(func)
        deps = "".join(f" + {name} @ {code_digest(text)[:12]}" for name, text in _used(module))
        return f"{func.__module__}.{func.__qualname__} @ {code_digest(source)[:12]}{deps}"
    return repr(value)


def _used(module: ModuleType | None) -> list[tuple[str, str]]:
    # (name, source) of the modules outside the package whose njit functions `module` uses
    if module is None:
        return []
    seen, todo, out = {module.__name__}, [module], []
    while todo:
        for obj in list(vars(todo.pop()).values()):
            name = getattr(getattr(obj, "py_func", None), "__module__", None)
            if not isinstance(name, str) or name in seen or name.split(".")[0] == _PACKAGE.name:
                continue
            dep = sys.modules.get(name)
            if dep is None:
                continue
            seen.add(dep.__name__)
            with contextlib.suppress(OSError, TypeError):
                out.append((dep.__name__, inspect.getsource(dep)))
                todo.append(dep)
    return sorted(out)


def _template_body(template: str) -> str:
    """The template's source without its ``from contour_gym._slots import ...`` statement."""
    spec = importlib.util.find_spec(template)
    if spec is None or spec.origin is None:
        raise ImportError(f"kernel template {template!r} not found")
    text = Path(spec.origin).read_text(encoding="utf-8")
    lines = text.splitlines()
    drop: set[int] = set()
    for node in ast.parse(text).body:
        if isinstance(node, ast.ImportFrom) and node.module == SLOTS_MODULE:
            drop.update(range(node.lineno - 1, (node.end_lineno or node.lineno)))
    if not drop:
        raise ImportError(f"kernel template {template!r} imports no slots from {SLOTS_MODULE}")
    return "\n".join(line for i, line in enumerate(lines) if i not in drop) + "\n"


def specialise(template: str, slots: Mapping[str, Any], label: str) -> ModuleType:
    """The template module with its slots bound to ``slots``: generated, cached, imported.

    Args:
        template: Module name of the template (its ``from contour_gym._slots import ...``
            statement is dropped).
        slots: Slot name -> component (an njit function or a constant).
        label: Human-readable description (the first-compile notice shows it).

    Returns:
        The generated module; the same object for the same template and slots.
    """
    header = [f"# contour-gym generated kernel: {template}", f"# {label}"]
    header.append(f"# package kernels @ {_package_digest_once()}")
    header += [f"# slot {k} = {identity(v)}" for k, v in sorted(slots.items())]
    text = "\n".join(header) + "\n" + _template_body(template)
    key = hashlib.sha1(text.encode()).hexdigest()[:20]
    with _LOCK:
        if key in _MODULES:
            return _MODULES[key]
        path = generated_dir() / f"k_{key}.py"
        if not path.exists():
            _write_atomically(path, text)
        name = f"contour_gym._generated.k_{key}"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        module.__dict__.update(slots)
        module.__dict__["KERNEL_LABEL"] = label
        sys.modules[name] = module
        spec.loader.exec_module(module)
        _MODULES[key] = module
        return module


def _write_atomically(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(suffix=".py", dir=path.parent)
    with os.fdopen(fd, "w", encoding="utf-8") as handle:
        handle.write(text)
    os.replace(tmp, path)


def notice_first_compile(module: ModuleType, what: str) -> None:
    """Log once if ``module``'s kernels have not been compiled before (see module doc)."""
    marker = Path(str(module.__file__)).with_suffix(".compiled")
    key = f"{marker}:{what}"
    if key in _NOTIFIED or marker.exists():
        return
    _NOTIFIED.add(key)
    LOG.warning(
        "contour-gym: compiling the %s kernels for %s (first run of this combination only; "
        "about 20-60 s on a laptop CPU; cached in %s)",
        what,
        getattr(module, "KERNEL_LABEL", "this setup"),
        marker.parent.parent,
    )


def mark_compiled(module: ModuleType) -> None:
    """Record that ``module``'s kernels are in numba's cache (no notice next time)."""
    marker = Path(str(module.__file__)).with_suffix(".compiled")
    if not marker.exists():
        with contextlib.suppress(OSError):
            marker.touch()
