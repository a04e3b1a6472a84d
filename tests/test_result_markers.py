"""What msr wrote (elastica_magnetic.result_markers): markers and the files no record names."""

from __future__ import annotations

import json

from elastica_magnetic.result_markers import (
    MARKER,
    describe_result,
    mark_folder,
    read_marker,
    unrecorded_files,
)


def test_a_marker_lists_the_files_it_found_and_reads_back(tmp_path):
    (tmp_path / "a.csv").write_text("1\n")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "b.png").write_bytes(b"x")
    mark_folder(tmp_path, kind="simulate", subject="robot r", info={"seed": 3})
    marker = read_marker(tmp_path)
    assert marker["files"] == ["a.csv", "sub/b.png"] and marker["seed"] == 3
    assert "`msr field simulate` for robot r" in describe_result(marker)


def test_files_no_record_names_are_the_users(tmp_path):
    (tmp_path / "a.csv").write_text("1\n")
    mark_folder(tmp_path, kind="simulate")
    (tmp_path / "notes.txt").write_text("mine")           # the user's, after msr wrote
    (tmp_path / ".msr-something").write_text("")          # msr's bookkeeping
    (tmp_path / ".inner.msr-lock").write_text("")
    inner = tmp_path / "inner"
    inner.mkdir()
    (inner / "x.csv").write_text("")
    mark_folder(inner, kind="replay")                      # the nearest marker above decides
    (inner / "y.csv").write_text("")
    shared = tmp_path / "figs"
    shared.mkdir()
    (shared / "f.png").write_bytes(b"")
    (shared / "g.png").write_bytes(b"")
    (shared / ".msr-files.json").write_text(json.dumps({"files": {"f.png": {}}}))
    assert unrecorded_files(tmp_path) == ["figs/g.png", "inner/y.csv", "notes.txt"]


def test_a_damaged_marker_is_no_record(tmp_path):
    (tmp_path / "a.csv").write_text("1\n")
    (tmp_path / MARKER).write_text("{not json")
    assert read_marker(tmp_path) is None
    assert unrecorded_files(tmp_path) == ["a.csv"]
    assert unrecorded_files(tmp_path / "absent") == []


def test_a_file_changed_since_msr_recorded_it_is_the_users(tmp_path):
    import hashlib

    from elastica_magnetic.result_markers import MANIFEST, in_manifest

    (tmp_path / "f.png").write_bytes(b"drawn by msr")
    digest = hashlib.sha256(b"drawn by msr").hexdigest()
    (tmp_path / MANIFEST).write_text(json.dumps({"files": {"f.png": digest}}))
    assert in_manifest(tmp_path, "f.png") and unrecorded_files(tmp_path) == []
    (tmp_path / "f.png").write_bytes(b"edited by the user")
    assert not in_manifest(tmp_path, "f.png") and unrecorded_files(tmp_path) == ["f.png"]
