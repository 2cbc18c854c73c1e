"""The README's Python examples run as written (each block in a fresh namespace)."""

import importlib.util
import pathlib
import re
import sys

import numpy as np
import pytest

from contour_gym import simulate
from contour_gym.contour.base import ESTIMATORS
from contour_gym.envs.registration import scenario_table
from contour_gym.presets import PRESETS

README = pathlib.Path(__file__).parent.parent / "README.md"
TEXT = README.read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", TEXT, flags=re.S)


@pytest.fixture
def clean_registries():
    yield
    for registry, name in ((PRESETS, "my_mill"), (ESTIMATORS, "toy_tangent")):
        if name in registry:
            registry.unregister(name)


def test_the_readme_has_its_examples():
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("i", range(len(BLOCKS)))
def test_a_readme_example_runs(i, clean_registries, tmp_path):
    name = f"readme_block_{i}"  # a module of its own, as a user's is (numba caches by file)
    script = tmp_path / f"{name}.py"
    script.write_text(BLOCKS[i])
    spec = importlib.util.spec_from_file_location(name, script)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
        _check_registrations(vars(module))
    finally:
        del sys.modules[name]


def _check_registrations(namespace):
    if "my_mill" in namespace:  # the machine it registers runs
        m = simulate(plant="my_mill")
        assert m["finished"] == 1.0 and 0 < m["max_contour_error"] < 1e-3
    if "toy_foot" in namespace:  # the estimator it registers runs
        a = simulate(plant="xy_dc_servo", estimator="toy_tangent",
                     estimator_options={"bias": 2e-6}, ccc_gains=(2e3, 2e4, 0.0))  # fmt: skip
        assert np.isfinite(a["max_contour_error"])


def test_the_readme_env_table_is_the_registration_table():
    for row in scenario_table():
        name = row["id"].split("/")[1]
        line = next((ln for ln in TEXT.splitlines() if ln.startswith(f"| `{name}` |")), None)
        assert line is not None, f"README lacks {name}"
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[2] == f"`{row['plant']}`" and cells[4] == str(row["laps"])
        assert cells[6] == row["estimator"] and cells[7] == f"{row['tolerance'] * 1e6:.1f} um"
        assert cells[8] == row["axis_controller"] and cells[9] == row["ccc_injection"]
