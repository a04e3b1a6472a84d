"""The one path rule (issue 48) for the writing commands that need a training run to reach their
output check (``tests/cli/test_path_rule.py`` walks the parser and covers the others): the same
folder spelled ``DIR/missing/..``, ``./DIR/`` or through a link is that folder, refused naming it
when it holds what the command must not replace, and left byte for byte."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from smoke import SMOKE

from elastica_magnetic.cli import main as msr

SPELLINGS = ["{root}/D/missing/..", "./D/", "L//", "missing/../D/."]


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def user_folder(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "D"
    folder.mkdir()
    (folder / "mine.txt").write_text("the user's notes\n")
    (tmp_path / "L").symlink_to(folder, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    return folder


def _commands(trained: Path, spelled: str) -> dict[str, list[str]]:
    seed0 = str(trained / "m1-4mT" / "seed0")
    return {
        "export-seeds": ["policy", "export-seeds", str(trained / "m1-4mT"), "--out", spelled, "--force"],
        "refine": ["refine", seed0, "--checkpoint", "final", "--steps", "3", "--out", spelled],
        "diagnose": ["policy", "diagnose", seed0, "--figure", spelled],
        "ship": ["policy", "ship", seed0, "--name", "mine.txt", "--out", spelled, "--no-measure",
                 "--checkpoint", "final", "--force"],
    }


@pytest.mark.parametrize("spelling", SPELLINGS)
@pytest.mark.parametrize("command", ["export-seeds", "refine", "diagnose", "ship"])
def test_a_run_command_treats_every_spelling_as_the_folder(trained, user_folder, capsys, command,
                                                           spelling):
    if command == "diagnose":  # the figure it would draw is there already
        (user_folder / "health_m1-4mT_seed0.png").write_bytes(b"an earlier figure")
    before = _tree(user_folder)
    spelled = spelling.format(root=user_folder.parent)
    assert msr(_commands(trained, spelled)[command]) == 2
    err = capsys.readouterr().err
    assert "D" in err and "error" in err, err
    assert _tree(user_folder) == before
    assert sorted(p.name for p in user_folder.parent.iterdir()) == ["D", "L"]


@pytest.mark.parametrize("spelling", SPELLINGS)
def test_train_resumes_or_refuses_the_same_runs_folder_however_spelled(trained, user_folder,
                                                                       capsys, spelling):
    shutil.copytree(trained / "m1-4mT", user_folder / "m1-4mT")
    before = _tree(user_folder)
    spelled = spelling.format(root=user_folder.parent)
    assert msr(["train", "--case", "m1-4mT", "--seeds", "2", "--steps", "240", "--out", spelled,
                *SMOKE]) == 2
    err = capsys.readouterr().err
    assert "D/m1-4mT" in err, err
    assert _tree(user_folder) == before
