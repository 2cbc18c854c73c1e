"""No import circle between the files of ``contour_gym`` and ``agents`` (issue 62, item 3).

The import graph is read statically with ``ast``. Its nodes are modules, one per file (a
package is its ``__init__.py``). Every import counts: at module level, under
``if TYPE_CHECKING:``, and inside functions. An import is resolved to a module file of the
repository as follows:

- ``import a.b.c``: an edge to the module ``a.b.c``, or to the deepest prefix of it that is a
  module file of the repository;
- ``from a.b import n``: an edge to ``a.b.n`` if that is a module file, otherwise to ``a.b``
  (its ``__init__``, or the module file ``a/b.py``);
- a relative import (``from . import n``, ``from ..x import n``) is resolved against the
  package of the importing file, then as above;
- the implicit import of the parent packages' ``__init__`` (which Python runs before a
  submodule) is not an edge, as in import-linter; a package's own ``__init__`` importing one of
  its submodules is an ordinary edge;
- an import of a module outside the repository is ignored.

A circle is a strongly connected component of more than one module (or a module importing
itself); each is shown as a chain of module names, ``a -> b -> ... -> a``.
"""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGES = ("contour_gym", "agents")


def _modules() -> dict[str, pathlib.Path]:
    """Every module file of the packages, by dotted name (a package by its own name)."""
    out = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out[".".join(parts)] = path
    return out


def _deepest(name: str, modules: dict[str, pathlib.Path]) -> str | None:
    """``name`` or its deepest prefix that is a module of the repository (None: outside it)."""
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        if ".".join(parts[:k]) in modules:
            return ".".join(parts[:k])
    return None


def _base(node: ast.ImportFrom, module: str, path: pathlib.Path) -> str:
    """The absolute module name a ``from ... import`` reads from."""
    if node.level == 0:
        return node.module or ""
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    package = package[: len(package) - (node.level - 1)]
    return ".".join([*package, *([node.module] if node.module else [])])


def _edges(module: str, path: pathlib.Path, modules: dict[str, pathlib.Path]) -> set[str]:
    """The modules of the repository one file imports, anywhere in it."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.update(m for a in node.names if (m := _deepest(a.name, modules)))
        elif isinstance(node, ast.ImportFrom):
            base = _base(node, module, path)
            for alias in node.names:
                if f"{base}.{alias.name}" in modules:
                    out.add(f"{base}.{alias.name}")
                elif m := _deepest(base, modules):
                    out.add(m)
    return out


def import_graph() -> dict[str, set[str]]:
    """Module -> the modules of the repository it imports."""
    modules = _modules()
    return {m: _edges(m, p, modules) for m, p in modules.items()}


def _components(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components (Tarjan, iterative), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out = []
    for start in sorted(graph):
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    comp = []
                    while True:
                        top = stack.pop()
                        on_stack.discard(top)
                        comp.append(top)
                        if top == node:
                            break
                    out.append(sorted(comp))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph.get(child, ())))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return out


def _chain(graph: dict[str, set[str]], members: set[str], start: str) -> list[str]:
    """The shortest circle from ``start`` back to it within ``members``."""
    trail, todo = {start: [start]}, [start]
    while todo:  # breadth first
        node = todo.pop(0)
        for nxt in sorted(graph[node] & members):
            if nxt == start:
                return [*trail[node], start]
            if nxt not in trail:
                trail[nxt] = [*trail[node], nxt]
                todo.append(nxt)
    raise AssertionError(f"no circle through {start}")


def circles(graph: dict[str, set[str]]) -> dict[frozenset[str], list[str]]:
    """Every circle of the graph: its modules (a strongly connected component of more than one
    module, or one importing itself) -> chains ``a -> b -> a`` that together pass through all
    of them."""
    out = {}
    for comp in _components(graph):
        members = set(comp)
        if len(comp) == 1 and comp[0] not in graph[comp[0]]:
            continue
        chains: list[str] = []
        shown: set[str] = set()
        for start in comp:
            if start not in shown:
                chain = _chain(graph, members, start)
                shown.update(chain)
                chains.append(" -> ".join(chain))
        out[frozenset(comp)] = chains
    return out


def test_the_reader_resolves_imports_as_stated(tmp_path):
    modules = {"p": tmp_path / "p/__init__.py", "p.a": tmp_path / "p/a.py",
               "p.s": tmp_path / "p/s/__init__.py", "p.s.b": tmp_path / "p/s/b.py"}
    for path in modules.values():
        path.parent.mkdir(parents=True, exist_ok=True)
    modules["p.s.b"].write_text(
        "import os\nimport p.a.x\nfrom p import a\nfrom ..s import b\nfrom . import q\n"
        "def f():\n    from p.s import c\n"
    )
    assert _edges("p.s.b", modules["p.s.b"], modules) == {"p.a", "p.s.b", "p.s"}
    modules["p.s"].write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                              "    from .b import y\n")
    assert _edges("p.s", modules["p.s"], modules) == {"p.s.b"}
    graph = {"a": {"b"}, "b": {"c", "a"}, "c": {"a", "d"}, "d": set(), "e": {"e"}}
    assert circles(graph) == {frozenset("abc"): ["a -> b -> a", "c -> a -> b -> c"],
                              frozenset("e"): ["e -> e"]}


def test_no_import_circle():
    found = circles(import_graph())
    assert not found, "import circles:\n" + "\n".join("; ".join(c) for c in found.values())
