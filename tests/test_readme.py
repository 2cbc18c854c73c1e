"""The README's and the docs' Python examples run as written (each block in a fresh namespace).

The README keeps a short tour; the reference examples (your machine, your estimator, policies,
environments) live in ``docs/*.md``. Every ```python block of both runs here, a block shared
by both once.
"""

import importlib.util
import pathlib
import re
import sys

import numpy as np
import pytest

from contour_gym import simulate
from contour_gym.contour.base import ESTIMATORS
from contour_gym.presets import PRESETS
from contour_gym.tasks import TASKS

ROOT = pathlib.Path(__file__).parent.parent
README = ROOT / "README.md"
TEXT = README.read_text()
DOCS = sorted((ROOT / "docs").glob("*.md"))
FENCE = re.compile(r"```python\n(.*?)```", flags=re.S)


def python_blocks(path):
    """The ```python blocks of a Markdown file, in order."""
    return FENCE.findall(path.read_text())


def _all_blocks():
    seen, blocks = set(), []
    for path in (README, *DOCS):
        for i, block in enumerate(python_blocks(path)):
            if block not in seen:
                seen.add(block)
                blocks.append(pytest.param(block, id=f"{path.name}:{i}"))
    return blocks


BLOCKS = _all_blocks()
# the two Quick-start commands, byte for byte (.ci/run runs the second)
QUICK_START = (
    'pip install torch==2.13.0 && pip install ".[rl]" && contour-gym bench',
    'pip install torch==2.13.0 && pip install -e ".[rl,zoo,dev,ray]" && ruff check . && mypy && '
    "python -m pytest",
)


@pytest.fixture
def clean_registries():
    yield
    from agents.rl.algorithms import ALGORITHMS

    for registry, name in ((PRESETS, "my_mill"), (ESTIMATORS, "toy_tangent"),
                           (TASKS, "kp_only"), (ALGORITHMS, "my_a2c")):
        if name in registry:
            registry.unregister(name)


def test_the_readme_has_its_examples():
    assert len(python_blocks(README)) >= 2
    assert len(BLOCKS) >= 6


def test_the_quick_start_commands_are_unchanged():
    quick_start = TEXT.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    commands = re.findall(r"```bash\n(.*?)\n```", quick_start, flags=re.S)
    assert tuple(commands) == QUICK_START
    assert QUICK_START[1] in (ROOT / ".ci" / "run").read_text()


def test_the_readme_is_short():
    assert len(TEXT.splitlines()) <= 200


def test_the_extension_examples_are_run():
    # the blocks that register a machine and an estimator are among those run (below)
    text = "\n".join(b.values[0] for b in BLOCKS)
    assert 'register_preset("my_mill"' in text and "toy_foot" in text
    assert "class KpEnv" in text and 'Algorithm("my_a2c"' in text


@pytest.mark.parametrize("block", BLOCKS)
def test_an_example_runs(block, clean_registries, tmp_path, request):
    # a module of its own, as a user's is (numba caches by file)
    name = "example_" + re.sub(r"\W", "_", request.node.callspec.id)
    script = tmp_path / f"{name}.py"
    script.write_text(block)
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
                     estimator_options={"bias": 2e-6}, ccc_gains=(2e3, 2e4, 0.0))
        assert np.isfinite(a["max_contour_error"])
    if "KpEnv" in namespace:  # the task it registers makes an env of its spaces
        env = namespace["KpEnv"]()
        assert env.action_space.shape == (1,) and env.observation_space["kp"].shape == (1,)
    if "register_algorithm" in namespace:  # the algorithm it registers is usable by name
        from agents.rl.config import algo_class

        assert algo_class("my_a2c").__name__ == "A2C"
