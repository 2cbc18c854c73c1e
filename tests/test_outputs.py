"""Outputs go only where a file may be (issue 63): links written through, the rest refused."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from agents.cli import main
from contour_gym.files import OutputPathError, output_file, output_folder, write_atomically


def _write(target: Path, text: str) -> None:
    write_atomically(target, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))


def test_a_regular_file_is_replaced_whole_and_a_link_is_written_through(tmp_path: Path) -> None:
    plot = tmp_path / "results" / "plot.png"
    _write(plot, "old")
    _write(plot, "new")
    assert plot.read_text() == "new"
    link = tmp_path / "link.png"
    link.symlink_to(plot)
    _write(link, "through the link")
    assert link.is_symlink() and plot.read_text() == "through the link"
    assert sorted(p.name for p in plot.parent.iterdir()) == ["plot.png"]  # no temp file left


def _special(tmp_path: Path, kind: str) -> Path:
    path = tmp_path / kind
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "folder":
        path.mkdir()
    elif kind == "device_link":
        path.symlink_to("/dev/null")
    return path


@pytest.mark.parametrize("kind, said", [("fifo", "a FIFO"), ("folder", "a folder"),
                                        ("device_link", "a character device")])
def test_anything_but_a_file_is_refused_naming_what_it_is(tmp_path: Path, kind: str,
                                                          said: str) -> None:
    path = _special(tmp_path, kind)
    with pytest.raises(OutputPathError, match=f"{kind}.* is {said}, not a file"):
        output_file(path)
    with pytest.raises(OutputPathError):
        _write(path, "x")
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())


def test_a_folder_output_that_is_a_file_is_refused(tmp_path: Path) -> None:
    (tmp_path / "runs").write_text("a file")
    with pytest.raises(OutputPathError, match="runs is a file, not a folder"):
        output_folder(tmp_path / "runs")
    assert output_folder(tmp_path / "new") == tmp_path / "new"


@pytest.mark.parametrize("argv", [["simulate", "--out"], ["bench", "--out"],
                                  ["tune", "000_circle", "--out"], ["train", "--out"]])
def test_the_command_line_refuses_before_any_work(tmp_path: Path, argv: list[str],
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    fifo = _special(tmp_path, "fifo")
    assert main([*argv, str(fifo)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("contour-gym: error: --out ") and "FIFO" in err[0]


@pytest.mark.parametrize("command, kept", [(["bench", "--suite", "tiny"], "cells computed"),
                                           (["tune", "000_circle"], "generations so far")])
def test_ctrl_c_ends_with_one_line_of_what_was_kept(command: list[str], kept: str,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    import agents.bench
    import agents.tune

    def interrupted(*args: object, **kwargs: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(agents.bench, "run_suite", interrupted)
    monkeypatch.setattr(agents.tune, "tune", interrupted)
    monkeypatch.setattr("agents.cli._compile_up_front", lambda *a, **k: None)
    assert main(command) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("contour-gym: interrupted; ") and kept in err[0]
