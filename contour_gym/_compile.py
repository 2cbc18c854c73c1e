"""Compiled code: numba's cache folder, the kernels' slots and their components, progress.

**Cache folder.** numba's ``cache=True`` keys a function's machine code on its own file only,
so after an edit to a function it *calls* in another module it would load stale code.
:func:`configure` points numba at a folder named by a digest of the package's kernel modules
(every module with compiled code), taken over their syntax trees without docstrings: editing
a docstring or comment, or any module without compiled code, recompiles nothing. Set
``NUMBA_CACHE_DIR`` to choose the folder yourself (then this does nothing).

**Kernels and their slots.** The servo loop and the env step are written once, as templates
(``contour_gym.loop.kernel``, ``contour_gym.envs._kernel``), whose *slots* (the axis
controller, the estimator, the friction law, the compensation, the CCC law, the reward) are
module globals. :func:`specialise` writes the template's source into a generated module named
by a digest of its text and of the components' sources, imports it and binds the slots.
A slot is *dispatched* (:data:`contour_gym._slots.DISPATCHED`): it takes a component code and
is bound to a tuple of components (:func:`dispatcher_source`). :func:`bind` chooses the tuple:

* every built-in component of the family when a run uses built-ins only: one kernel serves
  every combination of them, compiled once per installation (and cached);
* just the components the run uses when one of them is a user's (registered from a module
  outside the built-in packages, :func:`builtin_packages`): a kernel of its own, compiled at
  its first run, so registering a component is all it takes.

Components are inlined into the kernel (fast, and numba would not inline a call across
compiled functions by itself) unless their family says to call them (:class:`Called`: large
components whose work per call dwarfs a call, compiled apart).

A run of built-ins may also run on its *own* kernel (``bind(..., own=True)``: the same codes,
only its components bound), faster than the built-ins' one; :mod:`contour_gym._tiers` says
which of the two a run uses.

**What a kernel calls compiles with it.** A function a kernel calls (the exact search and
ground truth, the estimators, the history ring) is a plain ``@numba.njit`` without ``cache``:
it compiles in the process that compiles the kernel, where LLVM can inline it. One loaded
from numba's cache is machine code LLVM cannot inline, and a kernel compiled beside it would
run slower. The kernels themselves and the functions called from Python
(:mod:`contour_gym.paths._batch`, the estimator API's kernel) are cached.

**Inlined by whom.** ``inline="always"`` makes numba inline a function's IR at every call
site, typing it again each time; ``forceinline=True`` types it once and has LLVM inline it
(``alwaysinline``). The path's segment evaluation
(:func:`contour_gym.paths._geom.eval_segment`, three segment kinds, nine floats) is the second
kind; the per-tick helpers the first. ``tests/test_compile_budget.py`` counts what a first run
compiles; docs/measurements.md has the timings behind each choice.

**First run.** The built-ins' kernels compile in worker processes, several at a time, with a
progress bar (:mod:`contour_gym._precompile`); a kernel for a user's component, or a run's own
kernel on a fresh installation, compiles in the calling process with a progress line
(:func:`compiling`).
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import importlib.util
import inspect
import logging
import os
import shutil
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numba
from numba.core import event

from contour_gym import _inline_copy
from contour_gym._registry import load_plugins

KEEP = 3  # cache folders kept; older ones are removed
SLOTS_MODULE = "contour_gym._slots"  # the templates import their slots from here
GENERATED_PACKAGE = "contour_gym._generated"  # specialise's modules: k_<digest of their text>
LOG = logging.getLogger("contour_gym")
_PACKAGE = Path(__file__).resolve().parent
_MODULES: dict[str, ModuleType] = {}
_LOCK = threading.Lock()
_PARSE_LOCK = threading.Lock()  # Python 3.11's parser fails when two threads run it at once


@functools.lru_cache(maxsize=1024)
def code_digest(source: str) -> str:
    r"""Digest of Python source over its syntax tree, docstrings removed (comments never count).

    >>> documented = "def f():\n    'Doc.'\n    return 1"
    >>> code_digest(documented) == code_digest("def f():  # a comment\n    return 1")
    True
    """
    with _PARSE_LOCK:
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
    for path in sorted(_PACKAGE.rglob("*.py")):
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
    texts = [(path.relative_to(_PACKAGE).as_posix(), path.read_text(encoding="utf-8"))
             for path in kernel_sources()]  # fmt: skip
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
        _create_atomically(memo, result)
        _prune(memo.parent, memo, keep=4 * KEEP)
    return result


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
    """Set ``numba.config.CACHE_DIR`` unless the user set ``NUMBA_CACHE_DIR``; faster inlining.

    Also installs :mod:`contour_gym._inline_copy` (numba copies inlined IR quadratically).
    """
    _inline_copy.install()
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
    :func:`package_digest`. Each function's identity is worked out once per process (a bench
    run binds kernels 169 times, with 2763 slot values: 0.2-0.3 s of reading and parsing
    sources, 0.05 s since).
    """
    func = getattr(value, "py_func", value)
    if not inspect.isfunction(func):
        return repr(value)
    known = _IDENTITIES.get(func)
    if known is None:
        known = _IDENTITIES[func] = _function_identity(func)
    return known


_IDENTITIES: dict[Any, str] = {}


def _function_identity(func: Any) -> str:
    if func.__module__.startswith(GENERATED_PACKAGE + "."):
        # a generated module is named by a digest of its text, whose header names what its
        # slots are bound to (with their modules' digests): the name is the identity
        return f"{func.__module__}.{func.__qualname__}"
    module = sys.modules.get(func.__module__)
    source = inspect.getsource(module) if module is not None else inspect.getsource(func)
    deps = "".join(f" + {name} @ {code_digest(text)[:12]}" for name, text in _used(module))
    return f"{func.__module__}.{func.__qualname__} @ {code_digest(source)[:12]}{deps}"


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


def builtin_packages() -> tuple[str, ...]:
    """The packages whose registered components count as built-in (plugins loaded once).

    This package, and every package that declares a module under the entry-point group
    :data:`contour_gym._registry.PLUGIN_GROUP` (this wheel's ``agents`` declares its CCC
    laws): importing those modules registers their components, so the kernel of the
    built-ins is the same whatever the user imported first.
    """
    return tuple(sorted({_PACKAGE.name, *load_plugins()}))


def is_generic(slots: Mapping[str, Any]) -> bool:
    """Whether slots made by :func:`bind` are the built-ins' kernel (no component of a user's)."""
    fns = [f for v in slots.values() for f in (v if isinstance(v, tuple) else (v,))]
    return all(is_builtin(f.fn if isinstance(f, Called) else f) for f in fns if f is not None)


def is_builtin(fn: Any) -> bool:
    """Whether a compiled function comes from a built-in package (:func:`builtin_packages`)."""
    module = getattr(getattr(fn, "py_func", fn), "__module__", None) or ""
    return module.split(".")[0] in builtin_packages()


@dataclass(frozen=True, eq=False)
class Family:
    """One kind of component as the kernels dispatch it (:data:`contour_gym._slots.DISPATCHED`).

    Attributes:
        name: What it is ("axis controller", ...), for labels.
        slots: Slot name -> how to get that slot's compiled function from a component.
        members: The candidates for the built-in kernel, in code order (a registry's
            components sorted by name, or a fixed sequence); those whose functions are all
            built-in (:func:`is_builtin`) are kept.
        inlined: Whether the kernels inline a component (else they call it: :class:`Called`).
    """

    name: str
    slots: Mapping[str, Callable[[Any], Any]]
    members: Callable[[], Sequence[Any]]
    inlined: Callable[[Any], bool] = lambda component: True

    def functions(self, component: Any) -> list[Any]:
        """The component's compiled functions, one per slot."""
        return [get(component) for get in self.slots.values()]

    def builtins(self) -> list[Any]:
        """The built-in components, in code order."""
        return [m for m in self.members() if all(map(is_builtin, self.functions(m)))]


def bind(
    uses: Mapping[Family, Sequence[Any]], own: bool = False
) -> tuple[dict[str, Any], dict[str, list[int]]]:
    """Slots and component codes for a kernel whose families run the components ``uses``.

    When every component used is built-in, each family is bound to all its built-ins: one
    kernel, compiled once per installation, serves every combination of them. Otherwise each
    family is bound to just the components used (a kernel specialised to the run, compiled
    for it: a user's component costs one compile of its own).

    Args:
        uses: Per family, the components the run uses.
        own: The run's own kernel of built-ins (:mod:`contour_gym._tiers`): the same codes,
            but each family's tuple holds just the components used (None elsewhere).

    Returns:
        ``(slots, codes)``: the tuples to pass to :func:`specialise`, and per family name the
        code of each used component, in the order given.
    """
    generic = all(is_builtin(f) for fam, used in uses.items() for c in used
                  for f in fam.functions(c))  # fmt: skip
    slots: dict[str, Any] = {}
    codes: dict[str, list[int]] = {}
    for fam, used in uses.items():
        members = fam.builtins() if generic else list(dict.fromkeys(used))
        codes[fam.name] = [_index(members, c) for c in used]
        keep = set(codes[fam.name]) if own else set(range(len(members)))
        for slot, get in fam.slots.items():
            slots[slot] = tuple(
                None if k not in keep else (get(m) if fam.inlined(m) else Called(get(m)))
                for k, m in enumerate(members)
            )  # fmt: skip
    return slots, codes


def _index(members: Sequence[Any], component: Any) -> int:
    for i, m in enumerate(members):
        if m is component or m == component:
            return i
    raise ValueError(f"component {component!r} is not among {members!r}")


def _template_body(template: str, insert: str = "") -> str:
    """The template's source, ``insert`` in place of its ``from contour_gym._slots import ...``."""
    head, tail = _template_parts(template)
    return "\n".join([*head, insert, *tail]) + "\n"


@functools.cache
def _template_parts(template: str) -> tuple[list[str], list[str]]:
    # the template's lines before and after its slots import (parsed once per process)
    spec = importlib.util.find_spec(template)
    if spec is None or spec.origin is None:
        raise ImportError(f"kernel template {template!r} not found")
    text = Path(spec.origin).read_text(encoding="utf-8")
    lines = text.splitlines()
    with _PARSE_LOCK:
        tree = ast.parse(text)
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module == SLOTS_MODULE:
            first, last = node.lineno - 1, node.end_lineno or node.lineno
            return lines[:first], lines[last:]
    raise ImportError(f"kernel template {template!r} imports no slots from {SLOTS_MODULE}")


@dataclass(frozen=True)
class Called:
    """A component that a kernel calls instead of inlining (see :func:`dispatcher_source`)."""

    fn: Any


def dispatcher_source(slot: str, codes: Sequence[int], called: frozenset[int] = frozenset()) -> str:
    """Source of the dispatcher of ``slot`` over its components ``SLOT__k``, ``k`` in ``codes``.

    The dispatcher takes the component's code first, then the stub's arguments
    (:data:`contour_gym._slots.DISPATCHED`), and runs component ``code`` (the last one for
    any code past the others: codes are made by :func:`bind`, never by a user). The
    dispatcher is ``inline="always"``: the branch on a code constant over a run is well
    predicted, and each component is inlined at its call site as if it were the only one,
    except those in ``called``, which the dispatcher calls through a function of their own
    (``SLOT__k__call``), compiled apart: a large component whose work per call dwarfs a call
    then costs the kernel's compile nothing.
    """
    from contour_gym._slots import DISPATCHED

    args, returns = DISPATCHED[slot]
    ret = "return " if returns else ""
    lines: list[str] = []
    for k in sorted(called):
        lines += ["@numba.njit(cache=True)", f"def {slot}__{k}__call({args}):",
                  f"    {ret}{slot}__{k}({args})", "", ""]  # fmt: skip
    lines += ["@numba.njit(cache=True, inline='always')", f"def {slot}(code, {args}):"]
    ordered = sorted(codes)
    for k in ordered:
        call = f"{ret}{slot}__{k}{'__call' if k in called else ''}({args})"
        if k == ordered[-1]:
            lines.append(f"    {call}")
            break
        lines += [f"    if code == {k}:", f"        {call}"]
        if not returns:
            lines.append("        return")
    return "\n".join(lines) + "\n"


def specialise(template: str, slots: Mapping[str, Any]) -> ModuleType:
    """The template module with its slots bound to ``slots``: generated, cached, imported.

    Args:
        template: Module name of the template (its ``from contour_gym._slots import ...``
            statement is dropped).
        slots: Slot name -> component (an njit function or a constant), or a tuple of
            components for a dispatched slot (:data:`contour_gym._slots.DISPATCHED`): the
            template then calls component ``code`` (:func:`dispatcher_source`); None in the
            tuple for a code the kernel never runs.

    Returns:
        The generated module; the same object for the same template and slots.
    """
    header = [f"# contour-gym generated kernel: {template}"]
    header.append(f"# package kernels @ {_package_digest_once()}")
    bound: dict[str, Any] = {}
    dispatch: list[str] = []
    for k, v in sorted(slots.items()):
        if isinstance(v, tuple):
            called = frozenset(i for i, f in enumerate(v) if isinstance(f, Called))
            fns = {i: f.fn if isinstance(f, Called) else f
                   for i, f in enumerate(v) if f is not None}  # fmt: skip
            header += [f"# slot {k}[{i}] = {'called ' * (i in called)}{identity(f)}"
                       for i, f in fns.items()]  # fmt: skip
            bound.update({f"{k}__{i}": f for i, f in fns.items()})
            dispatch.append(dispatcher_source(k, list(fns), called))
        else:
            header.append(f"# slot {k} = {identity(v)}")
            bound[k] = v
    insert = "import numba\n\n\n" + "\n\n".join(dispatch) if dispatch else ""
    text = "\n".join(header) + "\n" + _template_body(template, insert)
    key = hashlib.sha1(text.encode()).hexdigest()[:20]
    with _LOCK:
        if key in _MODULES:
            return _MODULES[key]
        path = generated_dir() / f"k_{key}.py"
        if not path.exists():
            _create_atomically(path, text)
        name = f"{GENERATED_PACKAGE}.k_{key}"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        module.__dict__.update(bound)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        _MODULES[key] = module
        return module


def _create_atomically(path: Path, text: str) -> None:
    # complete or absent, and never replaced: numba's cache entries for the generated module
    # are keyed by its modification time, so another process' rewrite would invalidate them
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


OWN_KERNEL_SECONDS = 20.0
"""About how long one kernel compiles in-process on a 2-core machine (20-22 s for 004's machine;
``benchmarks/cold_start.py``: ``contour-gym simulate`` 27 s in all, the README's toy estimator
19 s), for the progress line."""


class _Progress(event.Listener):
    """A progress line on stderr while numba compiles: what, how long to expect, the time so far."""

    def __init__(self, label: str) -> None:
        from tqdm.auto import tqdm

        desc = (f"contour-gym: compiling {label} "
                f"(first run only, about {OWN_KERNEL_SECONDS:.0f} s on 2 cores)")  # fmt: skip
        self.bar = tqdm(total=None, file=sys.stderr, desc=desc,
                        bar_format="{desc} [{elapsed}] {postfix}")  # fmt: skip
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._tick, daemon=True)
        self.thread.start()

    def _tick(self) -> None:
        while not self.stop.wait(0.5):
            if sys.stderr.isatty():  # redrawn in place; a log file gets the start and end
                self.bar.refresh()

    def on_start(self, ev: event.Event) -> None:
        func = getattr(ev.data.get("dispatcher"), "py_func", None)
        self.bar.set_postfix_str(f"now: {getattr(func, '__qualname__', '?')}", refresh=False)

    def on_end(self, ev: event.Event) -> None:
        pass

    def close(self) -> None:
        self.stop.set()
        self.thread.join()
        self.bar.set_postfix_str("done", refresh=False)
        self.bar.close()


@contextlib.contextmanager
def compiling(label: str, show: bool = True) -> Iterator[None]:
    """Show a progress line while the block compiles kernels in this process (if ``show``).

    Used for kernels specialised to a user's component (the built-ins' kernels compile in
    worker processes: :mod:`contour_gym._precompile`).
    """
    if not show:
        yield
        return
    progress = _Progress(label)
    try:
        with event.install_listener("numba:compile", progress):
            yield
    finally:
        progress.close()


def mark_compiled(module: ModuleType) -> None:
    """Record that ``module``'s kernels are in numba's cache (no notice next time)."""
    marker = Path(str(module.__file__)).with_suffix(".compiled")
    if not marker.exists():
        with contextlib.suppress(OSError):
            marker.touch()


@dataclass(frozen=True)
class Census:
    """What numba compiled in this process: a measure of a first run's compile work.

    Attributes:
        functions: Compiled signatures (a function compiled for two signatures counts twice).
        statements: Statements of their typed IR, numba-inlined code included: a number that
            does not depend on the machine or its load, and grows with the compile's time.
    """

    functions: int
    statements: int


def census() -> Census:
    """Count what numba compiled in this process (not what it loaded from its cache)."""
    import gc

    from numba.core.dispatcher import Dispatcher

    functions = statements = 0
    for obj in gc.get_objects():
        if not isinstance(obj, Dispatcher):
            continue
        for result in obj.overloads.values():
            annotation = getattr(result, "type_annotation", None)
            if annotation is None:  # loaded from the cache
                continue
            functions += 1
            statements += sum(len(block.body) for block in annotation.blocks.values())
    return Census(functions, statements)
