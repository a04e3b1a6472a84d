"""Result folders replaced whole or not at all, and folder locks (issue 35, mechanisms 1 and 2).

Faults are injected into real processes: a forked child writes a result over an existing one and
sends itself SIGINT, SIGTERM or SIGKILL at a chosen point (after a file, in the middle of one,
before the swap, between the swap's renames); a file-size limit makes the kernel refuse a write;
an injected ENOSPC fails one. After each, the old result is checked byte for byte (or, when the
swap was complete, the new one) and the folder's parent for anything left behind.
"""

from __future__ import annotations

import errno
import json
import multiprocessing
import os
import signal
import time
from pathlib import Path

import pytest

from elastica_magnetic import interrupts, results
from elastica_magnetic.interrupts import Interrupted
from elastica_magnetic.io import OutputPathError
from elastica_magnetic.locks import FolderLockedError
from elastica_magnetic.result_markers import MARKER, mark_folder, read_marker
from elastica_magnetic.results import (
    ResultExistsError,
    check_result_folder,
    recover,
    result_folder,
)

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals and fork are POSIX")


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder``, relative path -> bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def write_old(target: Path) -> dict[str, bytes]:
    with result_folder(target, kind="demo", subject="robot a") as r:
        (r.path / "a.txt").write_text("old a\n")
        (r.path / "sub").mkdir()
        (r.path / "sub" / "b.bin").write_bytes(bytes(range(256)) * 10)
    return snapshot(target)


NEW = {"a.txt": b"new a\n" * 500, "sub/b.bin": b"\x01" * 7000, "c.txt": b"only in the new one\n"}


def write_new(path: Path, stop=None) -> None:
    """The new result, file by file; ``stop(n)`` is called after the n-th file (n = 1, 2, 3) and
    once in the middle of the second one (n = 1.5)."""
    (path / "a.txt").write_bytes(NEW["a.txt"])
    stop and stop(1)
    (path / "sub").mkdir()
    with open(path / "sub" / "b.bin", "wb") as handle:
        handle.write(NEW["sub/b.bin"][:3000])
        handle.flush()
        stop and stop(1.5)
        handle.write(NEW["sub/b.bin"][3000:])
    stop and stop(2)
    (path / "c.txt").write_bytes(NEW["c.txt"])
    stop and stop(3)


def as_new(target: Path) -> dict[str, bytes]:
    got = snapshot(target)
    marker = json.loads(got.pop(MARKER))
    assert marker["kind"] == "demo" and marker["files"] == sorted(NEW)
    return got


# -- the checks before any work ---------------------------------------------------------------------


def test_a_new_result_and_its_marker(tmp_path):
    target = tmp_path / "deep" / "res"
    with result_folder(target, kind="demo", subject="robot a", info={"seed": 3}) as r:
        assert r.replaced is None and not target.exists()
        write_new(r.path)
        assert r.final_path(r.path / "c.txt") == target / "c.txt"
    assert as_new(target) == NEW
    marker = read_marker(target)
    assert marker["subject"] == "robot a" and marker["seed"] == 3 and marker["host"]
    assert sorted(os.listdir(target.parent)) == ["res"]  # no lock, no temporary left


def test_an_existing_result_is_replaced_only_with_force(tmp_path):
    target = tmp_path / "res"
    old = write_old(target)
    with pytest.raises(ResultExistsError, match=r"--out .*res: already holds a result of `msr policy demo` "
                       r"for robot a, written .*; pass --force to replace it, or choose another --out"):
        with result_folder(target, kind="demo", subject="robot a"):
            pytest.fail("the block must not run")
    assert snapshot(target) == old
    with result_folder(target, kind="demo", subject="robot a", force=True) as r:
        assert r.replaced["kind"] == "demo"
        write_new(r.path)
    assert as_new(target) == NEW and sorted(os.listdir(tmp_path)) == ["res"]


@pytest.mark.parametrize("kind, subject, extra, message", [
    ("other", None, None, r"holds a result of `msr policy demo` for robot a, .*not of `msr other`; choose "
                          r"another --out \(--force replaces only a result of the same command\)"),
    ("demo", "robot b", None, r"holds a result of `msr policy demo` for robot a, .*not for robot b"),
    ("demo", "robot a", "notes.txt", r"and files it did not write \(notes.txt\); move them away"),
])
def test_another_kind_subject_or_foreign_files_are_refused_even_with_force(
        tmp_path, kind, subject, extra, message):
    target = tmp_path / "res"
    write_old(target)
    if extra:
        (target / extra).write_text("mine")
    old = snapshot(target)
    with pytest.raises(ResultExistsError, match=message):
        with result_folder(target, kind=kind, subject=subject, force=True):
            pytest.fail("the block must not run")
    assert snapshot(target) == old and sorted(os.listdir(tmp_path)) == ["res"]


def test_folders_without_a_marker(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert check_result_folder(empty, kind="demo") is None  # an empty folder is free
    legacy = tmp_path / "legacy"
    legacy.mkdir()
    (legacy / "a.txt").write_text("a user's file, or one written before markers")
    for force in (False, True):  # nothing records that msr wrote it: never replaced
        with pytest.raises(ResultExistsError, match=r"holds files named like those `msr policy demo` "
                                                    r"writes \(a.txt\) but no record that msr wrote "
                                                    r"them \(no \.msr-result\.json\): they may be "
                                                    "yours, and --force replaces only a result msr "
                                                    "recorded"):
            check_result_folder(legacy, kind="demo", known_files=("a.txt", "b.txt"), force=force)
    assert (legacy / "a.txt").read_text().startswith("a user's file")
    with pytest.raises(ResultExistsError, match=r"holds files that `msr policy demo` does not write "
                                                r"\(a.txt\); choose a new or empty folder"):
        check_result_folder(legacy, kind="demo", force=True)
    afile = tmp_path / "afile"
    afile.write_text("keep")
    for out in (afile, afile / "sub"):
        with pytest.raises(OutputPathError, match=f"--out {out}: {afile} is a file, not a folder"):
            check_result_folder(out, kind="demo")


def test_a_symlinked_output_folder_is_replaced_at_its_target(tmp_path):
    real = tmp_path / "real"
    write_old(real)
    link = tmp_path / "link"
    link.symlink_to(real, target_is_directory=True)
    with result_folder(link, kind="demo", subject="robot a", force=True) as r:
        write_new(r.path)
        # the one path rule: links are resolved where the path is taken, so the result is named
        # where it really is
        assert r.final_path(r.path / "a.txt") == real / "a.txt"
    assert link.is_symlink() and as_new(real) == NEW


def test_a_failure_in_the_block_leaves_the_old_result(tmp_path):
    target = tmp_path / "res"
    old = write_old(target)
    with pytest.raises(OutputPathError, match=r"--out .*res: cannot write the result: No space left "
                                              r"on device; .*res is left as it was"):
        with result_folder(target, kind="demo", subject="robot a", force=True) as r:
            (r.path / "a.txt").write_bytes(b"partial")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    with pytest.raises(ValueError, match="bad value"):
        with result_folder(target, kind="demo", subject="robot a", force=True) as r:
            write_new(r.path)
            raise ValueError("bad value")
    assert snapshot(target) == old and sorted(os.listdir(tmp_path)) == ["res"]
    assert results.aborted_results()[-2:] == [target, target]


# -- interruptions in a real process ----------------------------------------------------------------

STOPS = (1, 1.5, 2, 3, "fsync", "rename1", "rename2", "rename3")


def _child(target: Path, signum: int, stop_at) -> None:
    # a fresh command's signal handlers: the forked pytest process may carry others (Ray's driver
    # installs its own SIGTERM handler when an earlier test started it)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for other in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(other, signal.SIG_DFL)
    def stop(point) -> None:
        if point == stop_at:
            os.kill(os.getpid(), signum)
            if not interrupts._signal_state["deferring"]:
                time.sleep(5)  # the signal ends the block: it must not come to the end of this

    real_rename, real_fsync = os.rename, results.fsync_tree
    renames = [0]

    def rename(a, b):
        real_rename(a, b)
        renames[0] += 1
        stop(f"rename{renames[0]}")

    def fsync_tree(folder):
        stop("fsync")
        real_fsync(folder)

    os.rename, results.fsync_tree = rename, fsync_tree
    try:
        with result_folder(target, kind="demo", subject="robot a", force=True) as r:
            write_new(r.path, stop)
    except Interrupted as exc:
        os._exit(128 + exc.signum)
    except KeyboardInterrupt:
        os._exit(130)
    os._exit(0)


def _run_child(target: Path, signum: int, stop_at) -> int:
    process = multiprocessing.get_context("fork").Process(target=_child,
                                                          args=(target, signum, stop_at))
    process.start()
    process.join(30)
    assert process.exitcode is not None, "the child did not end"
    return process.exitcode


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL],
                         ids=["SIGINT", "SIGTERM", "SIGKILL"])
@pytest.mark.parametrize("stop_at", STOPS, ids=[str(s) for s in STOPS])
def test_interrupted_at_every_point(tmp_path, signum, stop_at):
    target = tmp_path / "res"
    old = write_old(target)
    status = _run_child(target, signum, stop_at)
    swapped = stop_at in ("rename2", "rename3") or (stop_at == "rename1" and signum != signal.SIGKILL)
    if signum == signal.SIGKILL:
        assert status == -signal.SIGKILL
        notes = recover(target)  # what the next run does first
        assert any("took over the stale lock" in n for n in notes) and len(notes) >= 2
    else:
        # Held back during the swap: the signal ends the process once the new result is in.
        assert status == 128 + signum
        if stop_at == "rename1":
            assert not any(n.startswith(".res.msr-") for n in os.listdir(tmp_path))
    if swapped:
        assert as_new(target) == NEW
    else:
        assert snapshot(target) == old
    assert sorted(os.listdir(tmp_path)) == ["res"]  # no temporary folder, aside or lock left


def test_killed_between_the_renames_then_the_next_run_restores_and_refuses(tmp_path):
    target = tmp_path / "res"
    old = write_old(target)
    assert _run_child(target, signal.SIGKILL, "rename1") == -signal.SIGKILL
    assert not target.exists() and any(".res.msr-old-" in n for n in os.listdir(tmp_path))
    with pytest.raises(ResultExistsError, match="already holds a result of `msr policy demo`"):
        with result_folder(target, kind="demo", subject="robot a"):
            pytest.fail("the block must not run")
    assert snapshot(target) == old and sorted(os.listdir(tmp_path)) == ["res"]


def _fsize_child(target: Path) -> None:
    import resource

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # the write fails with EFBIG instead
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
    try:
        with result_folder(target, kind="demo", subject="robot a", force=True) as r:
            write_new(r.path)
    except OutputPathError as exc:
        os._exit(2 if "File too large" in str(exc) and "left as it was" in str(exc) else 3)
    os._exit(0)


def test_the_kernel_refusing_a_write_leaves_the_old_result(tmp_path):
    target = tmp_path / "res"
    old = write_old(target)
    process = multiprocessing.get_context("fork").Process(target=_fsize_child, args=(target,))
    process.start()
    process.join(30)
    assert process.exitcode == 2
    assert snapshot(target) == old and sorted(os.listdir(tmp_path)) == ["res"]


# -- locks: two real processes ----------------------------------------------------------------------

def _writer_child(target: Path, ready, go) -> None:
    with result_folder(target, kind="demo", subject="robot a", force=True) as r:
        (r.path / "a.txt").write_text("from the first process\n")
        ready.set()
        go.wait(30)
    os._exit(0)


def test_two_writers_never_mix(tmp_path):
    target = tmp_path / "res"
    write_old(target)
    ctx = multiprocessing.get_context("fork")
    ready, go = ctx.Event(), ctx.Event()
    first = ctx.Process(target=_writer_child, args=(target, ready, go))
    first.start()
    try:
        assert ready.wait(30)
        with pytest.raises(FolderLockedError, match=f"being written by pid {first.pid}"):
            with result_folder(target, kind="demo", subject="robot a", force=True) as r:
                (r.path / "a.txt").write_text("from the second process\n")
    finally:
        go.set()
        first.join(30)
    assert first.exitcode == 0
    assert (target / "a.txt").read_text() == "from the first process\n"
    assert sorted(os.listdir(tmp_path)) == ["res"]


def test_the_current_folder_is_never_swapped(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for out in (".", "..", str(tmp_path)):
        with pytest.raises(OutputPathError, match="is the current folder or one above it"):
            with result_folder(out, kind="demo", force=True):
                pytest.fail("the block must not run")
    with result_folder("sub", kind="demo") as r:  # a folder inside it is fine
        (r.path / "a.txt").write_text("a")
    assert (tmp_path / "sub" / "a.txt").read_text() == "a"
    assert sorted(os.listdir(tmp_path)) == ["sub"]


def test_a_folder_written_in_place_is_marked_and_refused_to_other_commands(tmp_path):
    seed = tmp_path / "seed0"
    seed.mkdir()
    (seed / "checkpoint.pt").write_bytes(b"weights")
    mark_folder(seed, kind="train", subject="case m1-4mT", info={"seed": 0})
    assert read_marker(seed)["files"] == ["checkpoint.pt"] and read_marker(seed)["seed"] == 0
    with pytest.raises(ResultExistsError, match=r"holds a result of `msr train` for case m1-4mT.*"
                                                r"not of `msr refine`"):
        with result_folder(seed, kind="refine", subject="case m1-4mT", force=True):
            pytest.fail("the block must not run")
    assert (seed / "checkpoint.pt").read_bytes() == b"weights"


def test_a_pre_check_after_a_kill_recovers_first_and_reports_it(tmp_path):
    """A command's pre-check (check_result_folder before long work) sees the result the user has:
    killed between the renames, the old result is aside and ``res`` absent; the check restores
    it (and would refuse without force), and the notes reach the error or the result."""
    target = tmp_path / "res"
    old = write_old(target)
    assert _run_child(target, signal.SIGKILL, "rename1") == -signal.SIGKILL
    assert not target.exists() and results.interrupted(target)
    with pytest.raises(ResultExistsError, match="already holds a result of `msr policy demo`") as caught:
        check_result_folder(target, kind="demo", subject="robot a")
    notes = caught.value.__notes__
    assert any("restored the previous result" in n for n in notes)
    assert any("took over the stale lock" in n for n in notes)
    assert snapshot(target) == old and sorted(os.listdir(tmp_path)) == ["res"]

    assert _run_child(target, signal.SIGKILL, "rename1") == -signal.SIGKILL
    assert check_result_folder(target, kind="demo", subject="robot a", force=True)["kind"] == "demo"
    with result_folder(target, kind="demo", subject="robot a", force=True) as r:
        write_new(r.path)
    assert any("restored the previous result" in n for n in r.notes)  # reported with the result
    assert as_new(target) == NEW and sorted(os.listdir(tmp_path)) == ["res"]


def test_an_earlier_result_that_cannot_be_deleted_is_named_not_called_a_killed_run(tmp_path,
                                                                                   monkeypatch):
    """Issue 48 (try b6b): an immutable file kept the earlier result's trash beside the new one,
    silently; the next run then said it removed what 'a run that was killed' left."""
    import elastica_magnetic.results as results

    target = tmp_path / "res"
    write_old(target)
    kept = []
    real_remove = results.remove_tree
    monkeypatch.setattr(results, "remove_tree",
                        lambda path: kept.append(path) if ".msr-trash-" in path.name
                        else real_remove(path))
    with pytest.warns(results.LeftoverWarning, match=r"the new result is in place, but the "
                                                     r"earlier one, renamed \.res\.msr-trash-"):
        with result_folder(target, kind="demo", subject="robot a", force=True) as r:
            write_new(r.path)
    assert as_new(target) == NEW and kept
    monkeypatch.setattr(results, "remove_tree", real_remove)
    with result_folder(target, kind="demo", subject="robot a", force=True) as r:
        write_new(r.path)
    assert any("an earlier result that an earlier run replaced but could not delete" in note
               for note in r.notes)
    assert not any("left by a run that was killed" in note for note in r.notes)


@pytest.mark.parametrize("earlier", [False, True])
def test_a_folder_that_changes_while_the_command_runs_is_not_replaced(tmp_path, earlier):
    """Round 9, D1: the swap renamed away and deleted whatever appeared in --out during the run
    (a file the user put there, another command's result written inside it). Now the swap
    refuses when --out changed since its check, leaves it as it is, and keeps the new result
    beside it under a name the error gives."""
    out = tmp_path / "out"
    if earlier:
        with result_folder(out, kind="simulate") as r:
            (r.path / "trajectory.csv").write_text("old\n")
    with pytest.raises(OutputPathError, match=r"changed while the command ran \(new or changed: "
                                              r"notes.txt\).*the new result is in .*out-new-"):
        with result_folder(out, kind="simulate", force=earlier) as r:
            (r.path / "trajectory.csv").write_text("new\n")
            out.mkdir(exist_ok=True)
            (out / "notes.txt").write_text("my lab notes\n")  # the user, meanwhile
    assert (out / "notes.txt").read_text() == "my lab notes\n"
    assert ((out / "trajectory.csv").read_text() == "old\n") if earlier else \
        not (out / "trajectory.csv").exists()
    kept = [p for p in tmp_path.iterdir() if p.name.startswith("out-new-")]
    assert len(kept) == 1 and (kept[0] / "trajectory.csv").read_text() == "new\n"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_another_result_written_inside_the_folder_meanwhile_is_kept(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(OutputPathError, match="sub/"):
        with result_folder(out, kind="simulate") as r:
            (r.path / "trajectory.csv").write_text("new\n")
            with result_folder(out / "sub", kind="simulate") as inner:
                (inner.path / "trajectory.csv").write_text("inner\n")
    assert (out / "sub" / "trajectory.csv").read_text() == "inner\n"


def test_round9_v4_a_damaged_marker_and_a_lock_inside_are_named(tmp_path):
    """Round 9, V4: a damaged .msr-result.json was called missing ("no record that msr wrote
    them"), and the lock of a folder another command writes inside --out was called a file the
    command does not write."""
    from lock_holder import held_elsewhere

    from elastica_magnetic.locks import host_name

    out = tmp_path / "sim"
    with result_folder(out, kind="simulate") as r:
        (r.path / "trajectory.csv").write_text("t\n0\n")
    marker = out / ".msr-result.json"
    marker.write_text(marker.read_text()[:50])
    with pytest.raises(ResultExistsError, match=r"its \.msr-result\.json, msr's record of the files it "
                                                r"wrote there, is damaged"):
        check_result_folder(out, kind="simulate", force=True)
    assert (out / "trajectory.csv").read_text() == "t\n0\n"

    parent = tmp_path / "parent"
    with result_folder(parent, kind="simulate") as r:
        (r.path / "trajectory.csv").write_text("t\n0\n")
    with held_elsewhere(parent / "sub") as pid:
        with pytest.raises(OutputPathError, match=rf"another msr command is writing .*sub inside "
                                                  rf"it: pid {pid}"):
            check_result_folder(parent, kind="simulate", force=True)
    # a lock left by a process that is gone is msr's own leftover, not the user's file
    (parent / ".sub.msr-lock").write_text(json.dumps({"pid": 2**22 + 12345, "host": host_name()}))
    assert check_result_folder(parent, kind="simulate", force=True)["kind"] == "simulate"


def test_round12_d1_a_users_folder_named_like_a_temporary_is_never_removed(tmp_path):
    """Round 12, D1: every folder beside --out whose name began like msr's temporaries was removed
    (a user's ``.X.msr-new-backup``, one carrying a live pid): only a killed writer's are."""
    from elastica_magnetic.locks import host_name, name_tag

    target = tmp_path / "res"
    write_old(target)
    here = name_tag(host_name())
    users = [tmp_path / ".res.msr-new-backup", tmp_path / f".res.msr-new-{here}-1-abcdef",
             tmp_path / ".res.msr-old-mine"]
    for folder in users:
        folder.mkdir()
        (folder / "notes.txt").write_text("precious")
    killed = tmp_path / f".res.msr-new-{here}-99999999-abcdef"
    killed.mkdir()
    (killed / "half.csv").write_text("1,")
    with result_folder(target, kind="demo", subject="robot a", force=True) as r:
        write_new(r.path)
    assert all((folder / "notes.txt").read_text() == "precious" for folder in users)
    assert not killed.exists() and any(killed.name in note for note in r.notes)
    assert as_new(target) == NEW


def test_round17_a_folder_holding_another_commands_recorded_file_is_no_empty_folder(tmp_path):
    """Round 17 D: a folder whose only files msr had recorded writing (a calibration JSON, a
    shipped policy) passed for an empty one and was replaced, even without --force."""
    from elastica_magnetic.result_file import result_file
    from elastica_magnetic.results import ResultExistsError, check_result_folder

    out = tmp_path / "out"
    with result_file(out / "cal.json") as f:
        f.path.write_text('{"actuation_matrix_T_per_A": []}')
    for force in (False, True):
        with pytest.raises(ResultExistsError,
                           match=r"holds files another msr command wrote there \(cal.json\)"):
            check_result_folder(out, kind="simulate", force=force)
    assert (out / "cal.json").read_text() == '{"actuation_matrix_T_per_A": []}'
