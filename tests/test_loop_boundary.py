"""Nothing outside ``contour_gym/loop/`` reads the servo loop's internal arrays (issue 62).

What the env and the tasks may read of a member is the loop's record
(:mod:`contour_gym.loop.member`); what Python callers read are the loop's read-outs
(``loop.s``, ``loop.done``, ``loop.contour_error`` ...) and setters. Read statically with
``ast`` over ``contour_gym``, ``agents`` and ``benchmarks`` (the tests may look inside):

- no import of the loop's own modules but its package, its record and its thread helpers;
- no attribute named like one of the loop's arrays (:data:`contour_gym.loop.state.FLOATS`,
  ``INTS``) read off anything called ``loop`` (``loop.acc_c``, ``self.loop.ip_p``,
  ``env.loop.ccc_p``).
"""

from __future__ import annotations

import ast
import pathlib

import numba
import numpy as np
import pytest

from contour_gym.loop.member import Members, members
from contour_gym.loop.state import FLOAT_NAMES, INT_NAMES

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUTSIDE = ("contour_gym", "agents", "benchmarks")
OPEN = {"contour_gym.loop", "contour_gym.loop.member", "contour_gym.loop.threads"}


def _files() -> list[pathlib.Path]:
    inside = ROOT / "contour_gym" / "loop"
    return [p for d in OUTSIDE for p in sorted((ROOT / d).rglob("*.py"))
            if inside not in p.parents]


def _imported(tree: ast.AST) -> list[tuple[int, str]]:
    # (line, module) of every import of a contour_gym.loop module, at any depth
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            if node.module == "contour_gym" and any(a.name == "loop" for a in node.names):
                names = ["contour_gym.loop"]
            out += [(node.lineno, n) for n in names[:1] if n.startswith("contour_gym.loop")]
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names
                    if a.name.startswith("contour_gym.loop")]
    return out


def _owner(node: ast.expr) -> str:
    # the last name of an attribute's owner: "loop" for loop.x, self.loop.x, env.loop.x
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        return node.attr
    return ""


def test_no_module_outside_the_loop_imports_its_own_modules() -> None:
    found = []
    for path in _files():
        for line, module in _imported(ast.parse(path.read_text())):
            if module not in OPEN:
                found.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    assert found == [], "\n".join(found)


def test_no_module_outside_the_loop_reads_its_arrays() -> None:
    internal = set(FLOAT_NAMES) | set(INT_NAMES)
    found = []
    for path in _files():
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and node.attr in internal
                    and _owner(node.value).endswith("loop")):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno} reads loop.{node.attr}")
    assert found == [], "\n".join(found)


def test_the_check_finds_a_read_it_should() -> None:
    # the attribute rule on a made-up module: the reads the boundary forbids are found
    tree = ast.parse("def f(loop, env):\n    return loop.acc_c[0], env.loop.ip_p, env.done\n")
    reads = [n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)
             and n.attr in set(FLOAT_NAMES) and _owner(n.value).endswith("loop")]
    assert sorted(reads) == ["acc_c", "ip_p"]


@numba.njit(cache=True)
def _write_status(floats, float_layout, ints, int_layout):  # pragma: no cover - compiled
    m = members(floats, float_layout, ints, int_layout)
    m.status[0] = 1


def test_the_record_reads_the_loop_and_refuses_writes_but_two() -> None:
    from contour_gym.api import make_scenario

    loop = make_scenario(plant="xy_dc_servo").loop(batch_size=2, ccc_gains=(1.0, 0.0, 0.0))
    loop.step(50)
    fb, fl, ib, il = loop.blobs()
    record = _read(fb, fl, ib, il)
    assert record[0] == pytest.approx(loop.s[1])
    assert record[1] == pytest.approx(loop.contour_error_estimate[1, 0])
    assert record[2] == int(loop.status[1])
    with pytest.raises(numba.TypingError):
        _write_status(fb, fl, ib, il)
    _set(fb, fl, ib, il)
    assert loop.feedrate[1] == pytest.approx(0.5 * loop.nominal_feedrate)
    np.testing.assert_array_equal(loop.ccc_p[1, 0, :3], [1.0, 2.0, 3.0])
    assert Members._fields[0] == "s"


@numba.njit(cache=True)
def _read(floats, float_layout, ints, int_layout):  # pragma: no cover - compiled
    m = members(floats, float_layout, ints, int_layout)
    return m.s[1], m.estimate[1, 0], m.status[1]


@numba.njit(cache=True)
def _set(floats, float_layout, ints, int_layout):  # pragma: no cover - compiled
    m = members(floats, float_layout, ints, int_layout)
    m.override[1] = 0.5
    for g in range(3):
        m.ccc_gains[1, 0, g] = g + 1.0
