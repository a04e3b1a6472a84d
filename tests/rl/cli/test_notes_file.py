"""The Markdown file of ``msr policy notes POLICY --file F`` and ``msr policy ship --notes F`` (issue 48, a
held-out round of tries, p25 and p27): a folder was called "no such file" although it exists, and
a file saved as "UTF-8 with BOM" put U+FEFF into policy.json's notes and the model card. A folder
is now named as such; the byte-order mark is dropped (Markdown has no use for it)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from elastica_magnetic.cli import main as msr

SHIPPED = Path(__file__).resolve().parents[3] / "rl" / "policies" / "m1-4mT"


def test_notes_file_that_is_a_folder_is_named_as_one(tmp_path, capsys):
    assert msr(["policy", "notes", "m1-4mT", "--file", str(tmp_path)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"msr policy notes: error: --file {tmp_path}: is a folder, expected a Markdown file")


def test_ship_notes_that_is_a_folder_is_named_as_one(tmp_path, capsys):
    argv = ["policy", "ship", str(tmp_path / "run"), "--name", "mine", "--out", str(tmp_path / "policies"),
            "--no-measure", "--no-progress", "--notes", str(tmp_path)]
    assert msr(argv) == 2
    assert capsys.readouterr().err.strip() == (
        f"msr policy ship: error: --notes {tmp_path}: is a folder, expected a Markdown file")
    assert not (tmp_path / "policies").exists()


@pytest.fixture
def policy(tmp_path) -> Path:
    """A copy of the shipped m1-4mT policy (its files and msr's record of them, not its per-seed
    folder: notes refuse a card msr has no record of writing)."""
    folder = tmp_path / "m1-4mT"
    shutil.copytree(SHIPPED, folder, ignore=shutil.ignore_patterns("seeds"))
    return folder


def test_notes_saved_with_a_byte_order_mark_are_written_without_it(policy, tmp_path, capsys):
    notes = tmp_path / "bom.md"
    notes.write_bytes(b"\xef\xbb\xbfBOM notes\n")
    assert msr(["policy", "notes", str(policy), "--file", str(notes), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == "BOM notes"
    assert json.loads((policy / "policy.json").read_text(encoding="utf-8"))["notes"] == "BOM notes"
    card = (policy / "MODEL_CARD.md").read_text(encoding="utf-8")
    assert "\nBOM notes\n" in card and "\ufeff" not in card


def test_an_empty_notes_file_is_refused_and_clear_removes_them(policy, tmp_path, capsys):
    """An empty --file wiped the notes without a word (round 4, S10)."""
    before = (policy / "policy.json").read_bytes()
    empty = tmp_path / "empty.md"
    empty.write_text("\n")
    assert msr(["policy", "notes", str(policy), "--file", str(empty)]) == 2
    assert "is empty; the notes were left as they are (to remove them, pass --clear)" in (
        capsys.readouterr().err)
    assert (policy / "policy.json").read_bytes() == before
    assert msr(["policy", "notes", str(policy), "--clear"]) == 0
    assert json.loads((policy / "policy.json").read_text()).get("notes") in (None, "")
