"""The run's own kernel and the built-ins' kernel (contour_gym.jit.tiers)."""

import contextlib
import os
import pickle
import re
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest

from contour_gym import jit
from contour_gym.api import make_scenario
from contour_gym.jit import precompile, tiers


def _run(loop, kernel):  # type: ignore[no-untyped-def]
    loop.use_kernel(kernel)
    loop.reset(7)
    loop.step(800)
    return loop.ax_s.copy(), loop.contour_error.copy(), loop.sums.contour.copy()


def _pickled(obj: object, folder: Path) -> Path:
    path = folder / "request.pkl"
    path.write_bytes(pickle.dumps(obj))
    return path


def test_a_workers_own_kernel_is_chosen_next_and_agrees_with_the_builtins_kernel(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    scenario = make_scenario("xy_dc_servo", estimator="tangent")
    loop = scenario.loop(batch_size=2, ccc_gains=scenario.preset.ccc_gains.as_tuple())
    own, builtins = loop.kernels()
    assert builtins is not None and builtins() is not own
    # what a background worker does with a request: unpickle, run once on the own kernel
    request = _pickled(loop, tmp_path)
    monkeypatch.setenv(precompile.IN_WORKER, tiers.OWN_WORKER)
    tiers._own_main(str(request))
    monkeypatch.delenv(precompile.IN_WORKER)
    assert not request.exists() and not jit.needs_compile(own)
    fresh = scenario.loop(batch_size=2, ccc_gains=scenario.preset.ccc_gains.as_tuple())
    assert fresh.kernel is own  # compiled: chosen from now on
    for a, b in zip(_run(fresh, own), _run(fresh, builtins()), strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_detached_worker_takes_a_request(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # the own kernel of the default loop is compiled by the test above or here, in-process
    scenario = make_scenario("xy_dc_servo", estimator="tangent")
    loop = scenario.loop(batch_size=1)
    loop.compile_own()
    monkeypatch.setenv(tiers.BACKGROUND, "1")
    request = _pickled(loop, jit.generated_dir())
    assert tiers._detach("_own_main", str(request), "own_test", "a test's kernel",
                          env={precompile.IN_WORKER: tiers.OWN_WORKER})
    deadline = time.monotonic() + 120.0
    while request.exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not request.exists()  # the worker unpickled it and ran it
    # the terminal was told what runs and how to stop it
    notice = capsys.readouterr().err
    pid = int(re.search(r"pid (\d+)", notice).group(1))  # type: ignore[union-attr]
    assert "a test's kernel in the background" in notice and f"kill {pid}" in notice


def _watching(folder: Path) -> tuple[subprocess.Popen[bytes], int]:
    """A process as :func:`tiers._detach` starts one (a session of its own), watching
    ``folder``, with a worker of its own; the process and the worker's pid."""
    code = (f"from contour_gym.jit import tiers; tiers._watch({str(folder)!r}); "
            "import subprocess, sys, time; "
            "w = subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(120)']); "
            "print(w.pid, flush=True); time.sleep(120)")
    process = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                               start_new_session=True)
    assert process.stdout is not None
    return process, int(process.stdout.readline())


def _gone(pid: int, timeout: float = 30.0) -> bool:
    """Whether ``pid`` ended within ``timeout`` s (a zombie not yet reaped counts as ended)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return True
        if state == "Z":
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(0.1)


@pytest.mark.parametrize("how", ["folder removed", "kill PID"])
def test_a_background_process_and_its_workers_end(tmp_path: Path, how: str) -> None:
    folder = tmp_path / "generated"
    folder.mkdir()
    process, worker = _watching(folder)
    try:
        time.sleep(1.0)
        assert process.poll() is None and not _gone(worker, timeout=0.0)
        if how == "folder removed":
            folder.rmdir()
        else:
            process.terminate()
        assert process.wait(timeout=30.0) == 0
        assert _gone(worker)  # the worker it started ended with it
    finally:
        process.kill()
        with contextlib.suppress(ProcessLookupError):
            os.kill(worker, signal.SIGKILL)


def _module(folder: Path, name: str, compiled: bool) -> types.ModuleType:
    module = types.ModuleType(name)
    module.__file__ = str(folder / f"{name}.py")
    if compiled:
        (folder / f"{name}.compiled").touch()
    return module


@pytest.mark.parametrize(
    ("own_compiled", "builtins_done", "worker", "picked", "later"),
    [
        (True, False, None, "own", []),
        (False, True, None, "builtins", ["own"]),
        (False, False, None, "own", ["builtins loop"]),
        (False, True, tiers.OWN_WORKER, "own", []),
        (False, False, "1", "builtins", []),
    ],
)
def test_choose_policy(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, own_compiled: bool,
                       builtins_done: bool, worker: str | None, picked: str,
                       later: list[str]) -> None:
    asked: list[str] = []
    monkeypatch.setattr(tiers, "_compile_own_later", lambda owner: asked.append("own"))
    monkeypatch.setattr(tiers, "_compile_builtins_later", lambda w: asked.append(f"builtins {w}"))
    monkeypatch.setattr(precompile, "is_done", lambda name: builtins_done)
    if worker is None:
        monkeypatch.delenv(precompile.IN_WORKER, raising=False)
    else:
        monkeypatch.setenv(precompile.IN_WORKER, worker)
    own, builtins = _module(tmp_path, "own", own_compiled), _module(tmp_path, "builtins", True)
    chosen = tiers.choose(own, lambda: builtins, "loop", object())  # type: ignore[arg-type]
    assert chosen is {"own": own, "builtins": builtins}[picked]
    tiers.start_pending()  # what a first call does once it compiled
    assert asked == later
