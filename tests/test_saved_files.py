"""A saved agent is whole or refused naming the file (issue 63, item 3)."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import pytest
import yaml

from agents.rl.saved import META_FILE, MODEL_FILE, STATS_FILE, TRAINED_DIR, SavedAgent, record_files

AGENT = "ppo_ccc_circle"


@pytest.fixture()
def folder(tmp_path: Path) -> Path:
    dest = tmp_path / AGENT
    shutil.copytree(TRAINED_DIR / AGENT, dest)
    return dest


def test_a_shipped_agent_lists_its_files_and_loads(folder: Path) -> None:
    meta = yaml.safe_load((folder / META_FILE).read_text())
    assert set(meta["files"]) == {MODEL_FILE, STATS_FILE}
    agent = SavedAgent(folder)
    assert agent.model is not None and agent.normalizer is not None


@pytest.mark.parametrize("damage, said", [
    (lambda f: (f / STATS_FILE).unlink(), f"{STATS_FILE} is missing"),
    (lambda f: (f / MODEL_FILE).write_bytes((f / MODEL_FILE).read_bytes()[:1000]),
     f"{MODEL_FILE} is corrupt or changed"),
    (lambda f: (f / STATS_FILE).write_bytes(b"not a pickle"), f"{STATS_FILE} is corrupt"),
])
def test_a_missing_or_damaged_file_is_refused_naming_agent_and_file(folder: Path, damage,
                                                                   said: str) -> None:
    damage(folder)
    with pytest.raises(ValueError, match=f"agent '{AGENT}': .*{said}"):
        SavedAgent(folder).model  # noqa: B018 (reading the model checks the files)


def test_an_unlisted_folder_warns_and_a_damaged_one_names_the_file(folder: Path) -> None:
    meta = yaml.safe_load((folder / META_FILE).read_text())
    del meta["files"]
    (folder / META_FILE).write_text(yaml.safe_dump(meta, sort_keys=False))
    with pytest.warns(UserWarning, match="lists no files to check"):
        SavedAgent(folder).model  # noqa: B018
    (folder / MODEL_FILE).write_bytes(b"PK truncated")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=f"agent '{AGENT}': cannot load .*{MODEL_FILE}"):
            SavedAgent(folder).model  # noqa: B018
    shutil.copyfile(TRAINED_DIR / AGENT / MODEL_FILE, folder / MODEL_FILE)
    assert set(record_files(folder)) == {MODEL_FILE, STATS_FILE}
    assert SavedAgent(folder).model is not None
