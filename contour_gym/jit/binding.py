"""Kernels bound to their components: templates, slots, families, generated modules.

The servo loop and the env step are written once, as templates (``contour_gym.loop.kernel``,
``contour_gym.envs._kernel``), whose *slots* (the axis controller, the estimator, the friction
law, the compensation, the CCC law, the reward, the task) are stubs in
:mod:`contour_gym.jit.slots`. A :class:`Family` registers which slots a kind of component
fills and with which of its functions (``Family("axis controller", {"CTRL_CONTROL":
attrgetter("control"), ...}, ...)``): that registration is where to look for the code a slot
runs, and :func:`slot_table` lists it for every built-in component. :func:`bind` chooses the
components a kernel carries:

* every built-in component of the family when a run uses built-ins only: one kernel serves
  every combination of them, compiled once per installation (and cached);
* just the components the run uses when one of them is a user's (registered from a module
  outside the built-in packages, :func:`builtin_packages`): a kernel of its own, compiled at
  its first run, so registering a component is all it takes.

:func:`specialise` writes the template's source into a generated module named by a digest of
its text and of the components' sources, with a dispatcher per slot
(:func:`dispatcher_source`: the component's code picks one), imports it and binds the slots.
Components are inlined into the kernel unless their family says to call them (:class:`Called`:
large components whose work per call dwarfs a call, compiled apart). ``bind(..., own=True)``
gives a run of built-ins its *own* kernel (the same codes, only its components bound);
:mod:`contour_gym.jit.tiers` says which of the two a run uses.
"""

from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import importlib.util
import inspect
import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

from contour_gym._registry import load_plugins
from contour_gym.jit.cache import (
    PACKAGE,
    PARSE_LOCK,
    code_digest,
    create_atomically,
    current_digest,
    generated_dir,
)

SLOTS_MODULE = "contour_gym.jit.slots"  # the templates import their slots from here
GENERATED_PACKAGE = "contour_gym._generated"  # specialise's modules: k_<digest of their text>
_MODULES: dict[str, ModuleType] = {}
_LOCK = threading.Lock()


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
            if not isinstance(name, str) or name in seen or name.split(".")[0] == PACKAGE.name:
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
    return tuple(sorted({PACKAGE.name, *load_plugins()}))


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
    """One kind of component as the kernels dispatch it (:data:`contour_gym.jit.slots.DISPATCHED`).

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

    def __post_init__(self) -> None:
        FAMILIES.append(self)


FAMILIES: list[Family] = []  # every family, in the order made (slot_table)


def slot_table() -> list[tuple[str, str, str, str]]:
    """What code each slot runs, read from the families' registrations, not generated source.

    ``python -m contour_gym.jit`` prints it.

    Returns:
        Sorted rows ``(slot, family, component, "module.function (file:line)")``, one per
        slot and built-in component (plugins' components included).
    """
    builtin_packages()  # the plugins' components register on import
    rows = []
    for fam in FAMILIES:
        for component in fam.builtins():
            label = str(getattr(component, "name", component))
            for slot, get in fam.slots.items():
                rows.append((slot, fam.name, label, _where(get(component))))
    return sorted(rows)


def _where(fn: Any) -> str:
    # "module.qualname (file:line)" of a compiled function
    func = getattr(fn, "py_func", fn)
    if not inspect.isfunction(func):
        return repr(fn)
    line = inspect.getsourcelines(func)[1]
    return f"{func.__module__}.{func.__qualname__} ({inspect.getsourcefile(func)}:{line})"


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
        own: The run's own kernel of built-ins (:mod:`contour_gym.jit.tiers`): the same codes,
            but each family's tuple holds just the components used (None elsewhere).

    Returns:
        ``(slots, codes)``: the tuples to pass to :func:`specialise`, and per family name the
        code of each used component, in the order given.
    """
    generic = all(is_builtin(f) for fam, used in uses.items() for c in used
                  for f in fam.functions(c))
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
            )
    return slots, codes


def _index(members: Sequence[Any], component: Any) -> int:
    for i, m in enumerate(members):
        if m is component or m == component:
            return i
    raise ValueError(f"component {component!r} is not among {members!r}")


def _template_body(template: str, insert: str = "") -> str:
    """The template's source, ``insert`` in place of its import from the slots module."""
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
    with PARSE_LOCK:
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
    (:data:`contour_gym.jit.slots.DISPATCHED`), and runs component ``code`` (the last one for
    any code past the others: codes are made by :func:`bind`, never by a user). The
    dispatcher is ``inline="always"``: the branch on a code constant over a run is well
    predicted, and each component is inlined at its call site as if it were the only one,
    except those in ``called``, which the dispatcher calls through a function of their own
    (``SLOT__k__call``), compiled apart: a large component whose work per call dwarfs a call
    then costs the kernel's compile nothing.
    """
    from contour_gym.jit.slots import DISPATCHED

    args, returns = DISPATCHED[slot]
    ret = "return " if returns else ""
    lines: list[str] = []
    for k in sorted(called):
        lines += ["@numba.njit(cache=True)", f"def {slot}__{k}__call({args}):",
                  f"    {ret}{slot}__{k}({args})", "", ""]
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
        template: Module name of the template (its ``from contour_gym.jit.slots import ...``
            statement is dropped).
        slots: Slot name -> component (an njit function or a constant), or a tuple of
            components for a dispatched slot (:data:`contour_gym.jit.slots.DISPATCHED`): the
            template then calls component ``code`` (:func:`dispatcher_source`); None in the
            tuple for a code the kernel never runs.

    Returns:
        The generated module; the same object for the same template and slots.
    """
    header = [f"# contour-gym generated kernel: {template}"]
    header.append(f"# package kernels @ {current_digest()}")
    bound: dict[str, Any] = {}
    dispatch: list[str] = []
    for k, v in sorted(slots.items()):
        if isinstance(v, tuple):
            called = frozenset(i for i, f in enumerate(v) if isinstance(f, Called))
            fns = {i: f.fn if isinstance(f, Called) else f
                   for i, f in enumerate(v) if f is not None}
            header += [f"# slot {k}[{i}] = {'called ' * (i in called)}{identity(f)}"
                       for i, f in fns.items()]
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
            create_atomically(path, text)
        name = f"{GENERATED_PACKAGE}.k_{key}"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        module.__dict__.update(bound)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        _MODULES[key] = module
        return module
