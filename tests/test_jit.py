"""A slot's code is found from its registration (issue 62): families, stubs, the slot table."""

from __future__ import annotations

import importlib
import re

import contour_gym  # noqa: F401  (registers the built-in components)
from contour_gym.jit import binding, slot_table, slots


def test_every_dispatched_slot_is_filled_by_the_family_its_stub_names() -> None:
    for slot in slots.DISPATCHED:
        claims = [f for f in binding.FAMILIES if slot in f.slots]
        assert len(claims) == 1, (slot, [f.name for f in claims])
        named = re.search(r"Filled by :data:`([\w.]+)`", getattr(slots, slot).__doc__ or "")
        assert named is not None, f"the stub {slot} does not name its family"
        module, _, variable = named.group(1).rpartition(".")
        assert getattr(importlib.import_module(module), variable) is claims[0]


def test_the_slot_table_names_each_built_in_component_function_and_place() -> None:
    rows = slot_table()
    pid = [r for r in rows if r[0] == "CTRL_CONTROL" and r[2] == "pid"]
    assert len(pid) == 1
    where = pid[0][3]
    assert where.startswith("contour_gym.servo.") and re.search(r"\.py:\d+\)$", where)
    assert {r[0] for r in rows} == set(slots.DISPATCHED)
