"""The documentation site: an API page for every public module, the env table, the nav.

``mkdocs build --strict`` (CI, after the tests) renders the pages; these checks need no mkdocs.
The docs say what is: a guide is at most 300 lines, no docstring or comment of ``contour_gym``
and ``agents`` carries a date or a commit (dated histories live in ``docs/measurements.md``),
and no page cites a path outside the repository (the papers are cited by title in
``docs/references.md``).
"""

import ast
import importlib.util
import io
import pathlib
import re
import tokenize

import pytest
import yaml

from contour_gym.envs.registration import scenario_table

ROOT = pathlib.Path(__file__).parent.parent
DOCS = ROOT / "docs"


def _load_gen_ref():
    spec = importlib.util.spec_from_file_location("gen_ref", DOCS / "gen_ref.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


gen_ref = _load_gen_ref()


def _public_modules_by_rule(root):
    """The rule, stated again: a module is public if no part of its dotted path starts with _."""
    names = set()
    for package in ("contour_gym", "agents"):
        for path in (root / package).rglob("*.py"):
            rel = path.relative_to(root)
            if not all((root / rel.parents[i] / "__init__.py").exists()
                       for i in range(len(rel.parents) - 1)):
                continue  # not in a package (a folder without __init__.py)
            parts = list(rel.with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            if not any(p.startswith("_") for p in parts):
                names.add(".".join(parts))
    return names


def test_every_public_module_has_an_api_page():
    modules = _public_modules_by_rule(ROOT)
    assert {"contour_gym", "contour_gym.envs.ccc", "agents.rl.train"} <= modules
    assert set(gen_ref.public_modules()) == modules
    pages = gen_ref.reference_pages()
    for module in modules:
        assert pages[f"reference/{module}.md"].startswith(f"::: {module}\n"), module
        assert f"]({module}.md)" in pages["reference/index.md"], module


def test_the_module_walker_follows_the_rule(tmp_path):
    files = ["contour_gym/__init__.py", "contour_gym/a.py", "contour_gym/_b.py",
             "contour_gym/sub/__init__.py", "contour_gym/sub/c.py", "contour_gym/_p/__init__.py",
             "contour_gym/_p/d.py", "contour_gym/loose/e.py", "agents/__init__.py",
             "agents/tune/__init__.py", "agents/tune/_impl.py"]
    for f in files:
        (tmp_path / f).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / f).write_text('"""Doc."""\n')
    expected = ["agents", "agents.tune", "contour_gym", "contour_gym.a", "contour_gym.sub",
                "contour_gym.sub.c"]
    assert gen_ref.public_modules(tmp_path) == expected
    assert sorted(_public_modules_by_rule(tmp_path)) == expected


def test_the_docs_links_to_api_pages_exist():
    modules = set(gen_ref.public_modules())
    for page in DOCS.glob("*.md"):
        for module in re.findall(r"\]\(reference/([\w.]+)\.md", page.read_text()):
            assert module == "index" or module in modules, f"{page.name} links {module}"


def test_every_page_is_in_the_nav_and_exists():
    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    nav = [next(iter(item.values())) for item in config["nav"]]
    assert "reference/index.md" in nav
    written = {p.name for p in DOCS.glob("*.md")}
    assert written == {p for p in nav if "/" not in p}


ENV_PAGE = (DOCS / "environments.md").read_text()


@pytest.mark.parametrize("row", scenario_table(), ids=lambda r: r["id"])
def test_the_env_table_is_the_registration_table(row):
    name = row["id"].split("/")[1]
    line = next((ln for ln in ENV_PAGE.splitlines() if ln.startswith(f"| `{name}` |")), None)
    assert line is not None, f"docs/environments.md lacks {name}"
    cells = [c.strip() for c in line.strip("|").split("|")]
    assert cells[2] == f"`{row['plant']}`" and cells[4] == str(row["laps"])
    assert cells[6] == row["estimator"] and cells[7] == f"{row['tolerance'] * 1e6:.1f} um"
    assert cells[8] == row["axis_controller"] and cells[9] == row["ccc_injection"]


def test_the_env_table_has_no_stale_row():
    ids = {row["id"].split("/")[1] for row in scenario_table()}
    listed = set(re.findall(r"^\| `([\w-]+-v\d+)` \|", ENV_PAGE, flags=re.M))
    assert listed == ids


HISTORY_PAGES = {"measurements.md"}  # dated measurement histories: no line limit
GUIDE_LINES = 300
DATE = re.compile(r"\b20\d\d-\d\d-\d\d\b")
# a commit named as one: "at 0717f9e", "commit c608166" (7-40 hex digits, a digit and a letter)
COMMIT = re.compile(r"\b(?:at|commit)\s+`?(?=[0-9a-f]*[0-9])(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b")
OUTSIDE = re.compile(r"\.\./shared|(?<![\w.])shared/seeds|(?<![\w.])/work/")


GUIDES = sorted(p.name for p in DOCS.glob("*.md") if p.name not in HISTORY_PAGES)


@pytest.mark.parametrize("page", GUIDES)
def test_a_guide_is_at_most_300_lines(page):
    lines = len((DOCS / page).read_text().splitlines())
    assert lines <= GUIDE_LINES, f"docs/{page}: {lines} lines (histories go to measurements.md)"


def _notes(path):
    """``(line, text)`` of every docstring line and comment of a Python file."""
    source = path.read_text()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=False)
            if doc is not None:
                for i, text in enumerate(doc.splitlines()):
                    yield node.body[0].lineno + i, text
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string


def test_no_docstring_or_comment_carries_a_date_or_a_commit():
    found = []
    for package in ("contour_gym", "agents"):
        for path in sorted((ROOT / package).rglob("*.py")):
            for line, text in _notes(path):
                if DATE.search(text) or COMMIT.search(text):
                    found.append(f"{path.relative_to(ROOT)}:{line}: {text.strip()}")
    message = "dated or commit-stamped notes (say what is; histories go to docs/measurements.md)"
    assert not found, message + ":\n" + "\n".join(found)


def test_the_docs_cite_no_path_outside_the_repository():
    pages = [ROOT / "README.md", ROOT / "ARCHITECTURE.md",  # docs/architecture.md includes it
             *(p for p in DOCS.rglob("*") if p.suffix in (".md", ".py"))]
    found = []
    for page in pages:
        for i, line in enumerate(page.read_text().splitlines(), 1):
            if OUTSIDE.search(line):
                found.append(f"{page.relative_to(ROOT)}:{i}: {line.strip()}")
    message = "paths outside the repository (cite the papers by title: docs/references.md)"
    assert not found, message + ":\n" + "\n".join(found)


def test_the_references_page_cites_every_paper():
    text = (DOCS / "references.md").read_text()
    for paper in ("000", "001", "002", "003", "004"):
        assert f"**{paper}.**" in text, paper
