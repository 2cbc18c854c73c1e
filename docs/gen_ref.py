"""Generate the API reference pages at build time (mkdocs-gen-files; see mkdocs.yml).

Walks the packages ``contour_gym`` and ``agents`` on disk and writes one page per public module
(a module is public if no component of its dotted path starts with ``_``; a package's
``__init__.py`` is the package itself) under ``reference/``, plus ``reference/index.md``, a
table of every module with the first line of its docstring. Modules added or split later get
their pages without any edit here. It also appends the registered environment ids, and the
spec of each id's class, to ``environments.md``, and every registered preset's settings and
notes to ``machines.md``.

``public_modules()`` is imported by ``tests/test_docs.py``, which checks that every public
module has a page.
"""

from __future__ import annotations

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PACKAGES = ("contour_gym", "agents")



def _module_name(path: pathlib.Path, root: pathlib.Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _in_a_package(path: pathlib.Path, root: pathlib.Path) -> bool:
    """Whether every folder from the top package down to the file's has an ``__init__.py``."""
    folder = path.parent
    while folder != root:
        if not (folder / "__init__.py").is_file():
            return False
        folder = folder.parent
    return True


def public_modules(root: pathlib.Path = ROOT) -> list[str]:
    """Every public module of the packages, by dotted name, sorted."""
    names = set()
    for package in PACKAGES:
        for path in (root / package).rglob("*.py"):
            if not _in_a_package(path, root):
                continue
            name = _module_name(path, root)
            if any(part.startswith("_") for part in name.split(".")):
                continue
            names.add(name)
    return sorted(names)


def page_path(module: str) -> str:
    """The page of a module, relative to docs/."""
    return f"reference/{module}.md"


def _summary(module: str) -> str:
    path = ROOT / module.replace(".", "/")
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
    return doc.strip().splitlines()[0].replace("|", "\\|") if doc.strip() else ""


def reference_pages() -> dict[str, str]:
    """Page path -> Markdown, for every public module and the index."""
    pages = {}
    rows = ["| module | what it is |", "|---|---|"]
    for module in public_modules():
        pages[page_path(module)] = f"::: {module}\n"
        rows.append(f"| [`{module}`]({module}.md) | {_summary(module)} |")
    pages["reference/index.md"] = (
        "# API reference\n\nGenerated from the docstrings of every public module of "
        "`contour_gym` and `agents` (a module is public if no component of its dotted path "
        "starts with `_`).\n\n" + "\n".join(rows) + "\n"
    )
    return pages


def environment_specs() -> str:
    """Markdown: each registered id, its keyword arguments and its class's spec."""
    import gymnasium as gym

    import contour_gym  # noqa: F401  (registers the ids)

    lines = ["", "## Every registered id", ""]
    classes: list[str] = []
    for env_id, spec in gym.registry.items():  # in registration order
        if not env_id.startswith("contour_gym/"):
            continue
        entry = str(spec.entry_point).replace(":", ".")
        if entry not in classes:
            classes.append(entry)
        kwargs = ", ".join(f"`{k}={v!r}`" for k, v in spec.kwargs.items())
        kwargs = kwargs or "none (the generic id: every argument is the caller's)"
        lines.append(f"- `{env_id}`: spec [`{entry.rsplit('.', 1)[1]}`](#{entry}); "
                     f"registered arguments: {kwargs}")
    lines += ["", "## The specs", "",
              "Each id's class docstring is its spec: action and observation tables, reward, "
              "episode end, arguments.", ""]
    for entry in classes:
        lines += [f"::: {entry}", "    options:", "      heading_level: 3",
                  "      show_root_full_path: false", ""]
    return "\n".join(lines) + "\n"


def preset_notes() -> str:
    """Markdown: every registered preset with its settings and notes, as the code has them."""
    from contour_gym.presets import PRESETS, get_preset

    lines = ["", "## Each preset, as registered", "",
             "Generated at build time from `contour_gym.presets.get_preset(name)`: the paper, "
             "the axes, the servo period, the scenario, and the notes saying which numbers are "
             "published and which are chosen.", ""]
    for name in PRESETS.names():
        preset = get_preset(name)
        stage = preset.stage
        axes = ", ".join(a.name for a in stage.axes)
        lines += [
            f"### `{name}`", "",
            f"Paper {preset.paper}; axes {axes}; servo period {stage.ts * 1e3:g} ms; path "
            f"`{preset.path}`; estimator `{preset.estimator}`; tolerance "
            f"{preset.tolerance * 1e6:.1f} um.", "",
            f"*Machine:* {stage.notes}", "", f"*Scenario:* {preset.notes}", "",
        ]
    return "\n".join(lines) + "\n"


def main() -> None:
    """Write the pages through mkdocs-gen-files."""
    import mkdocs_gen_files

    for path, text in reference_pages().items():
        with mkdocs_gen_files.open(path, "w") as f:
            f.write(text)
    with mkdocs_gen_files.open("environments.md", "a") as f:
        f.write(environment_specs())
    with mkdocs_gen_files.open("machines.md", "a") as f:
        f.write(preset_notes())


if __name__ in ("__main__", "<run_path>"):
    main()
