"""numba's inliner with the shared-memo copy and the front end's memo gives numba's own results."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numba
import numpy as np
import pytest
from numba.core import inline_closurecall

import contour_gym  # noqa: F401  (installs them)
from contour_gym.jit import inline_copy


@numba.njit(inline="always")
def _clip(x: float, low: float, high: float) -> float:
    total = 0.0  # a local whose name the caller uses too
    if x < low:
        total = low
    elif x > high:
        total = high
    else:
        total = x
    return total


@numba.njit(inline="always")
def _clipped_sum(values: Any, low: float, high: float) -> float:
    total = 0.0
    for v in values:
        total += _clip(v, low, high)  # an inline function inside an inline function
    return total


@numba.njit
def _three_sites(values: Any) -> float:
    total = _clipped_sum(values, -1.0, 1.0)
    total += 10.0 * _clipped_sum(values, 0.0, 0.5)
    return total + _clip(total, 0.0, 3.0)


@pytest.fixture
def front_end_runs(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    runs: list[str] = []
    original = inline_closurecall.InlineWorker.run_untyped_passes

    def counted(self: Any, func: Any, enable_ssa: bool = False) -> Any:
        runs.append(func.__name__)
        return original(self, func, enable_ssa)

    monkeypatch.setattr(inline_closurecall.InlineWorker, "run_untyped_passes", counted)
    yield runs


def test_it_is_installed_and_installing_again_changes_nothing() -> None:
    installed = inline_closurecall.InlineWorker.inline_function
    assert getattr(installed, "wrapped", None) is not None
    assert inline_copy.install()
    assert inline_closurecall.InlineWorker.inline_function is installed


def test_a_function_inlined_at_many_sites_runs_its_front_end_once(
        front_end_runs: list[str]) -> None:
    values = np.array([-2.0, -0.25, 0.3, 0.7, 4.0])
    assert _three_sites(values) == _three_sites.py_func(values)
    assert front_end_runs.count("_clipped_sum") == 1
    assert front_end_runs.count("_clip") <= 2  # inside _clipped_sum's own front end, and once
