"""A set of files put into a shared folder all together or not at all (issue 35)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import time

import pytest

from elastica_magnetic.filesets import check_files, recover_files, replace_files
from elastica_magnetic.result_markers import MANIFEST
from elastica_magnetic.results import ResultExistsError

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals and fork are POSIX")
NAMES = ("fig.png", "data/summary.json")


def shared(tmp_path):
    """A folder with someone else's figure beside an earlier set msr wrote (and recorded)."""
    folder = tmp_path / "figures"
    folder.mkdir()
    (folder / "other.png").write_bytes(b"someone else's figure")
    with replace_files(folder, NAMES) as files:
        (files.path / "fig.png").write_bytes(b"old figure")
        (files.path / "data").mkdir()
        (files.path / "data" / "summary.json").write_text('{"old": true}')
    return folder


def contents(folder):
    """The folder's files (msr's record of them left out)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != MANIFEST}


def test_force_never_replaces_a_file_msr_did_not_write(tmp_path):
    """A file of the user's under a name msr writes (a hand-made fig.png), or one msr wrote and
    the user changed since, is refused even with force; a caller that recognised the folder as
    its own (a shipped policy from before records) adopts its files."""
    folder = tmp_path / "figs"
    folder.mkdir()
    (folder / "fig.png").write_bytes(b"my own drawing")
    for force in (False, True):
        with pytest.raises(ResultExistsError, match="fig.png" if force else "pass --force"):
            with replace_files(folder, ("fig.png",), force=force):
                pytest.fail("the block must not run")
    with pytest.raises(ResultExistsError, match=r"fig.png: not written by msr \(no record in "
                                                r"\.msr-files\.json\) or changed since; --force "
                                                "replaces only files msr wrote"):
        check_files(folder, ("fig.png",), force=True)
    assert (folder / "fig.png").read_bytes() == b"my own drawing"
    with replace_files(folder, ("fig.png",), force=True, adopt=True) as files:
        (files.path / "fig.png").write_bytes(b"msr's figure")
    with replace_files(folder, ("fig.png",), force=True) as files:  # recorded now: replaced
        (files.path / "fig.png").write_bytes(b"msr's second figure")
    (folder / "fig.png").write_bytes(b"touched up by hand")  # changed since msr wrote it
    with pytest.raises(ResultExistsError, match="or changed since"):
        with replace_files(folder, ("fig.png",), force=True):
            pytest.fail("the block must not run")
    assert (folder / "fig.png").read_bytes() == b"touched up by hand"


def write(files, stop=None):
    (files.path / "fig.png").write_bytes(b"new figure")
    stop and stop("first")
    (files.path / "data").mkdir()
    (files.path / "data" / "summary.json").write_text('{"new": true}')


NEW = {"data/summary.json": b'{"new": true}', "fig.png": b"new figure",
       "other.png": b"someone else's figure"}


def test_the_files_go_in_together_and_nothing_else_is_touched(tmp_path):
    folder = shared(tmp_path)
    old = contents(folder)
    with pytest.raises(ResultExistsError, match=r"already holds fig.png, data/summary.json; pass "
                                                r"--force to replace"):
        with replace_files(folder, NAMES):
            pytest.fail("the block must not run")
    with pytest.raises(RuntimeError):
        with replace_files(folder, NAMES, force=True) as files:
            write(files)
            raise RuntimeError("failed halfway")
    with pytest.raises(ValueError, match="wrote extra.txt, not among the declared names"):
        with replace_files(folder, NAMES, force=True) as files:
            write(files)
            (files.path / "extra.txt").write_text("x")
    assert contents(folder) == old
    with replace_files(folder, NAMES, force=True) as files:
        write(files)
        assert files.final_path(files.path / "fig.png") == folder / "fig.png"
    assert contents(folder) == NEW
    assert sorted(os.listdir(tmp_path)) == ["figures"]  # no lock left
    new = tmp_path / "fresh"
    with replace_files(new, NAMES) as files:
        write(files)
    assert contents(new) == {k: v for k, v in NEW.items() if k != "other.png"}


def _child(folder, signum, at):
    # Ctrl-C's Python behaviour, also when the suite runs as a background job (SIGINT ignored)
    signal.signal(signal.SIGINT, signal.default_int_handler)

    def stop(point):
        if point == at:
            os.kill(os.getpid(), signum)
            time.sleep(5)

    real_replace = os.replace
    moves = [0]

    def replace(a, b):
        real_replace(a, b)
        if str(a).endswith(".msr-commit.tmp"):
            stop("commit")
        else:
            moves[0] += 1
            stop(f"move{moves[0]}")

    os.replace = replace
    try:
        with replace_files(folder, NAMES, force=True) as files:
            write(files, stop)
    except KeyboardInterrupt:
        os._exit(130)
    os._exit(0)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
@pytest.mark.parametrize("at", ["first", "commit", "move1"])
def test_killed_at_any_point_the_set_is_old_or_new_after_recovery(tmp_path, signum, at):
    folder = shared(tmp_path)
    old = contents(folder)
    process = multiprocessing.get_context("fork").Process(target=_child, args=(folder, signum, at))
    process.start()
    process.join(30)
    if signum == signal.SIGKILL:
        assert process.exitcode == -signal.SIGKILL
        notes = recover_files(folder)
        assert any("stale lock" in n for n in notes)
        if at != "first":
            assert any("finished moving" in n for n in notes)
    else:
        assert process.exitcode == 130  # held back during the moves: after them
    assert contents(folder) == (old if at == "first" else NEW)
    assert sorted(os.listdir(tmp_path)) == ["figures"]
    assert not any(n.startswith(".msr-files-") for n in os.listdir(folder))


def test_files_the_new_set_lacks_are_removed_in_the_same_commit(tmp_path, monkeypatch):
    folder = shared(tmp_path)
    (folder / "critic.pt").write_bytes(b"a file of the user's under a name of the set")
    before = contents(folder)
    with pytest.raises(ResultExistsError, match="critic.pt: not written by msr"):  # round 16 D1
        with replace_files(folder, NAMES, force=True, remove=["critic.pt"]):
            pytest.fail("the block must not run")
    assert contents(folder) == before
    with replace_files(folder, ["critic.pt"], force=True, adopt=True) as files:  # the old set's, recorded
        (files.path / "critic.pt").write_bytes(b"the old set's optional file")
    with pytest.raises(ValueError, match="fig.png both written and removed"):
        with replace_files(folder, NAMES, force=True, remove=["fig.png"]):
            pytest.fail("the block must not run")
    # killed after the first move (the commit record was written): the next run rolls forward,
    # and removes what the commit removes
    real_replace, moves = os.replace, [0]

    def replace_then_die(a, b):
        real_replace(a, b)
        if not str(a).endswith(".msr-commit.tmp"):
            moves[0] += 1
            raise SystemExit("killed")  # stands for SIGKILL: no clean-up runs after it

    monkeypatch.setattr(os, "replace", replace_then_die)
    monkeypatch.setattr("elastica_magnetic.filesets.remove_tree", lambda path: None)
    with pytest.raises(SystemExit):
        with replace_files(folder, NAMES, force=True, remove=["critic.pt", "absent.txt"]) as files:
            write(files)
    monkeypatch.undo()
    assert moves == [1] and (folder / "critic.pt").exists()  # a mix, until recovered
    notes = recover_files(folder)
    assert any("finished moving 1 file(s)" in n for n in notes), notes
    assert contents(folder) == NEW  # critic.pt is gone with the old set
    assert not any(n.startswith(".msr-files-") for n in os.listdir(folder))


# -- one result file (issue 48) --------------------------------------------------------------------

def test_a_result_file_is_refused_without_force_and_replaced_whole_with_it(tmp_path):
    from elastica_magnetic.result_file import result_file
    from elastica_magnetic.results import ResultExistsError

    target = tmp_path / "cal.json"
    with result_file(target) as written:  # an earlier result
        written.path.write_text("old")
    with pytest.raises(ResultExistsError, match="cal.json: already exists; pass --force"):
        with result_file(target):
            raise AssertionError("the block must not run")
    with pytest.raises(RuntimeError), result_file(target, force=True) as written:
        written.path.write_text("half")
        raise RuntimeError("a failure in the middle")
    assert target.read_text() == "old" and sorted(os.listdir(tmp_path)) == [MANIFEST, "cal.json"]
    with result_file(tmp_path / "missing" / ".." / "cal.json", force=True) as written:
        assert written.path.parent == tmp_path and written.path.suffix == ".json"
        written.path.write_text("new")
    assert target.read_text() == "new" and sorted(os.listdir(tmp_path)) == [MANIFEST, "cal.json"]


def test_force_never_replaces_a_single_file_msr_did_not_write(tmp_path):
    """Round 9, D2: --force on a single-file output (--set-yardstick, hw calibrate --out) replaced
    the user's own file of that kind (another robot's spec, a hand-tuned calibration). A result
    file is recorded in its folder's .msr-files.json; --force replaces only a recorded file,
    unchanged since."""
    from elastica_magnetic.result_file import result_file
    from elastica_magnetic.results import ResultExistsError

    mine = tmp_path / "labB_calibration.json"
    mine.write_text('{"description": "HAND-TUNED, do not lose"}')
    with pytest.raises(ResultExistsError, match="labB_calibration.json: was not written by msr"):
        with result_file(mine, force=True):
            raise AssertionError("the block must not run")
    assert "HAND-TUNED" in mine.read_text()
    ours = tmp_path / "cal.json"
    with result_file(ours) as written:
        written.path.write_text("msr's")
    ours.write_text("edited by hand since")  # no longer what msr wrote
    with pytest.raises(ResultExistsError, match="or changed since"):
        with result_file(ours, force=True):
            raise AssertionError("the block must not run")
    assert ours.read_text() == "edited by hand since"


@pytest.mark.parametrize("make, kind", [
    (lambda p: os.mkfifo(p), "a named pipe"),
    (lambda p: p.mkdir(), "a folder"),
])
def test_a_result_file_never_replaces_what_is_not_a_regular_file(tmp_path, make, kind):
    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.result_file import check_result_file

    target = tmp_path / "out.json"
    make(target)
    with pytest.raises(OutputPathError, match=f"out.json: is {kind}"):
        check_result_file(target, force=True)
    assert target.exists() and not target.is_file()


def test_a_killed_writer_of_a_result_file_is_cleaned_up_by_the_next(tmp_path):
    from elastica_magnetic.result_file import check_result_file, result_file
    from elastica_magnetic.results import ResultExistsError

    target = tmp_path / "log.txt"
    with result_file(target) as written:  # an earlier result
        written.path.write_text("old")
    (tmp_path / ".log.msr-new-vm-99999999-abcdef.txt").write_text("half")  # a writer killed outright
    with pytest.raises(ResultExistsError) as refused:
        check_result_file(target)
    assert any("removed .log.msr-new-vm-99999999-abcdef.txt" in note for note in refused.value.__notes__)
    assert sorted(os.listdir(tmp_path)) == [MANIFEST, "log.txt"]
    with result_file(target, force=True) as written:
        written.path.write_text("new")
    assert target.read_text() == "new"


def test_a_full_disk_while_writing_names_the_file_not_its_temporary(tmp_path):
    """Round 5, D07: `msr policy figures` on a full disk said `.../.msr-files-vm-27526-1147f2/
    field_polar.png: cannot write`; the message names the file the user looks for and says the
    earlier files are left as they were."""
    import errno

    from elastica_magnetic.io import OutputPathError, atomic_write_text

    folder = tmp_path / "figs"
    with replace_files(folder, ["a.png"]) as files:  # an earlier figure msr wrote
        (files.path / "a.png").write_text("old")
    with pytest.raises(OutputPathError) as refused:
        with replace_files(folder, ["a.png"], force=True, option="--out") as files:
            def full(*args, **kwargs):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

            target = files.path / "a.png"
            original = os.replace
            os.replace = full  # the rename of the atomic write fails as on a full disk
            try:
                atomic_write_text(target, "new")
            finally:
                os.replace = original
    message = str(refused.value)
    assert ".msr-files-" not in message and str(folder / "a.png") in message, message
    assert message.endswith(f"{folder}: nothing in it changed"), message
    assert (folder / "a.png").read_text() == "old" and sorted(os.listdir(folder)) == [MANIFEST, "a.png"]


def test_round12_d1_a_users_file_or_folder_named_like_a_temporary_file_is_kept(tmp_path):
    """Round 12, D1: only a killed writer's temporary file (named HOST-PID-RANDOM, its process gone)
    is removed beside a result file; a user's file or folder named like one stays."""
    from elastica_magnetic.locks import host_name, name_tag
    from elastica_magnetic.result_file import result_file

    here = name_tag(host_name())
    keep = [tmp_path / ".cal.msr-new-backup.json", tmp_path / f".cal.msr-new-{here}-1-abcdef.json"]
    for path in keep:
        path.write_text("mine")
    folder = tmp_path / f".cal.msr-new-{here}-99999998-abcdef.json"
    folder.mkdir()
    killed = [tmp_path / f".cal.msr-new-{here}-99999999-abcdef.json",
              tmp_path / f"..cal.msr-new-{here}-99999999-abcdef.tmp99999999.json"]
    for path in killed:
        path.write_text("half")
    with result_file(tmp_path / "cal.json") as out:
        out.path.write_text("{}")
    assert all(path.read_text() == "mine" for path in keep) and folder.is_dir()
    assert not any(path.exists() for path in killed)
    assert sum("left by a run that was killed" in note for note in out.notes) == 2


def test_round17_force_never_replaces_another_commands_result_file(tmp_path):
    """Round 17 D: `msr real stream --log cal.json --force` replaced the calibration JSON `msr real
    calibrate` wrote (a file msr recorded was its own whatever it held), and `calibrate --out
    b.log --force` the board log `stream` wrote."""
    from elastica_magnetic.hardware.calibration import CALIBRATION_FILE
    from elastica_magnetic.hardware.stream import BOARD_LOG_FILE
    from elastica_magnetic.result_file import result_file
    from elastica_magnetic.results import ResultExistsError

    calibration, log = tmp_path / "cal.json", tmp_path / "b.log"
    with result_file(calibration, kind=CALIBRATION_FILE) as f:
        f.path.write_text('{"actuation_matrix_T_per_A": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}')
    with result_file(log, kind=BOARD_LOG_FILE) as f:
        f.path.write_text("MSR-FW 1.0\nPONG\n")
    before = {p.name: p.read_bytes() for p in (calibration, log)}
    with pytest.raises(ResultExistsError, match=r"cal.json: is a calibration JSON .*another command's "
                                                 r"result; --force replaces only a board log"):
        with result_file(calibration, force=True, option="--log", kind=BOARD_LOG_FILE):
            pass
    with pytest.raises(ResultExistsError, match=r"b.log: is a board log .*--force replaces only a "
                                                 r"calibration JSON"):
        with result_file(log, force=True, kind=CALIBRATION_FILE):
            pass
    assert {p.name: p.read_bytes() for p in (calibration, log)} == before
    with result_file(log, force=True, option="--log", kind=BOARD_LOG_FILE) as f:  # its own kind
        f.path.write_text("MSR-FW 1.1\n")
    assert log.read_text() == "MSR-FW 1.1\n"
