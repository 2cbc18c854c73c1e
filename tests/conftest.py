"""Session set-up: no background compiles; the built-ins' kernels compiled once up front."""

import os

import pytest

# detached compiles of each combination's own kernel (contour_gym.jit.tiers) would compete with
# the tests for the cores and outlive the session; tests/test_tiers.py runs them explicitly
os.environ.setdefault("CONTOUR_GYM_BACKGROUND", "0")


@pytest.fixture(scope="session", autouse=True)
def _builtin_kernels() -> None:
    # every combination of built-ins then runs on the built-ins' kernel at once (one compile
    # per cache folder: pytest-xdist's workers wait on its lock)
    import contour_gym

    contour_gym.precompile(["loop", "env"], progress=False)
