"""Fault injection for the writers brought under the result mechanisms by issue 48: ``msr
export-firmware`` (a result folder), ``msr real calibrate`` (one result file) and ``msr policy figures``
(a set of files in a folder holding other things). Each runs in a real process (``tests/faults.py``),
killed or interrupted while writing, or on a full disk: the earlier result stays byte for byte
("old or new, whole"), a file of the user's beside it is never touched, and the next run cleans
up what a kill left. Without ``--force`` an earlier result is refused; a read-only folder is named
before any work.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
from faults import Fault

from elastica_magnetic.cli import main
from elastica_magnetic.result_markers import MANIFEST

pytestmark = pytest.mark.skipif(os.name != "posix", reason="signals are POSIX")

ROOT = Path(__file__).resolve().parents[2]
FIELD_CSV = ROOT / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT" / "magnetic_field.csv"
CALIBRATION = ROOT / "stm32" / "calibration" / "default.json"
MEASUREMENTS = ("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n1,1,0,2,2,0\n")


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def lab(tmp_path: Path) -> Path:
    """A folder with a user's file, measurements and an earlier export and calibration."""
    (tmp_path / "notes.txt").write_text("the user's notes\n")
    (tmp_path / "meas.csv").write_text(MEASUREMENTS)
    assert main(["real", "firmware", str(FIELD_CSV), "--calibration", str(CALIBRATION), "--out",
                 str(tmp_path / "fw")]) == 0
    assert main(["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(tmp_path / "cal.json")]) == 0
    return tmp_path


def _export(lab: Path, *extra: str) -> list[str]:
    # another waveform than the earlier export's: a new result differs from the old
    zeros = lab / "zeros.csv"
    if not zeros.exists():
        zeros.write_text("index,mag_x,mag_y,mag_z\n" + "".join(f"{i},0,0,0\n" for i in range(50)))
    return ["real", "firmware", str(zeros), "--calibration", str(CALIBRATION), "--out",
            str(lab / "fw"), *extra]


def _calibrate(lab: Path, *extra: str) -> list[str]:
    return ["real", "calibrate", str(lab / "meas.csv"), "--name", "again", "--out", str(lab / "cal.json"),
            *extra]


@pytest.mark.parametrize("command", [_export, _calibrate], ids=["export-firmware", "calibrate"])
def test_an_earlier_result_is_replaced_only_with_force(lab, capsys, command):
    before = snapshot(lab)
    assert main(command(lab)) == 2
    assert "pass --force" in capsys.readouterr().err
    assert snapshot(lab) == {**before, **{k: v for k, v in snapshot(lab).items() if k == "zeros.csv"}}
    assert main(command(lab, "--force")) == 0
    after = snapshot(lab)
    assert after["notes.txt"] == before["notes.txt"]
    changed = "fw/waveform_table.c" if command is _export else "cal.json"
    assert after[changed] != before[changed]


@pytest.mark.parametrize("command", [_export, _calibrate], ids=["export-firmware", "calibrate"])
@pytest.mark.parametrize("fault, status", [
    (Fault("open", r"\.msr-new-", "SIGINT", nth=1), 130),
    (Fault("open", r"\.msr-new-", "SIGTERM", nth=1), 143),
    (Fault("enospc", r"\.msr-new-", after=10), 2),
], ids=["SIGINT", "SIGTERM", "ENOSPC"])
def test_interrupted_or_full_disk_keeps_the_old_result_whole(fault_server, lab, command, fault,
                                                             status):
    _export(lab)  # the other waveform exists before the snapshot
    before = snapshot(lab)
    names = sorted(os.listdir(lab))
    done = fault_server.run(command(lab, "--force"), fault)
    assert done.returncode == status, done.stderr
    assert "Traceback" not in done.stderr
    assert "left as it was" in done.stderr or "interrupted" in done.stderr, done.stderr
    assert snapshot(lab) == before
    assert sorted(os.listdir(lab)) == names  # no temporary file or folder, no lock


@pytest.mark.parametrize("command", [_export, _calibrate], ids=["export-firmware", "calibrate"])
def test_killed_while_writing_then_the_next_run_cleans_up(fault_server, lab, capsys, command):
    _export(lab)
    before = snapshot(lab)
    done = fault_server.run(command(lab, "--force"), Fault("open", r"\.msr-new-", "SIGKILL", nth=1))
    assert done.returncode == -signal.SIGKILL
    assert any(".msr-" in name for name in os.listdir(lab))  # what a kill leaves
    left = snapshot(lab)
    assert {k: v for k, v in left.items()
            if not k.split("/")[0].startswith(".") or k == MANIFEST} == before
    assert main(command(lab)) == 2  # without --force: cleans up, then refuses
    err = capsys.readouterr().err
    assert "note: " in err and "pass --force" in err
    assert snapshot(lab) == before
    assert not any(name.startswith(".") and name != MANIFEST for name in os.listdir(lab))


def test_figures_interrupted_leave_the_earlier_figures(fault_server, tmp_path, capsys):
    seeds = ROOT / "rl" / "policies" / "m1-4mT" / "seeds" / "paper"
    out = tmp_path / "figs"
    out.mkdir()
    (out / "notes.txt").write_text("the user's notes\n")
    assert main(["policy", "figures", str(seeds), "--out", str(out)]) == 0
    before = snapshot(out)
    assert main(["policy", "figures", str(seeds), "--out", str(out)]) == 2
    assert "pass --force" in capsys.readouterr().err
    done = fault_server.run(["policy", "figures", str(seeds), "--out", str(out), "--force"],
                            Fault("open", r"\.msr-files-", "SIGINT", nth=1))
    assert done.returncode == 130, done.stderr
    assert snapshot(out) == before and sorted(os.listdir(tmp_path)) == ["figs"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root ignores permissions")
@pytest.mark.parametrize("command", [_export, _calibrate], ids=["export-firmware", "calibrate"])
def test_a_read_only_folder_is_named_before_any_work(tmp_path, capsys, command):
    (tmp_path / "meas.csv").write_text(MEASUREMENTS)
    locked = tmp_path / "ro"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        argv = command(tmp_path, "--force")
        argv[argv.index("--out") + 1] = str(locked / "x")
        assert main(argv) == 2
        assert "Permission denied" in capsys.readouterr().err
    finally:
        locked.chmod(0o755)


@pytest.mark.parametrize(("argv", "option", "kind"), [
    (["real", "calibrate", "{lab}/meas.csv", "--out", "{file}"], "--out", "a calibration JSON"),
    (["real", "stream", str(FIELD_CSV), "--port", "socket://127.0.0.1:1", "--log", "{file}"], "--log",
     "a board log"),
    (["real", "stream", str(FIELD_CSV), "--port", "socket://127.0.0.1:1", "--codes-out", "{file}"],
     "--codes-out", "an expected-DAC-codes CSV"),
    (["field", "baseline", "--case", "m1-4mT", "--set-yardstick", "{file}"], "--set-yardstick",
     "a spec file"),
], ids=["calibrate", "stream --log", "stream --codes-out", "baseline --set-yardstick"])
def test_force_never_replaces_a_file_of_the_users(argv, option, kind, lab, capsys):
    """``--force`` replaces an earlier result, not whatever has the name (round 4, D2: ``msr
    calibrate --out notes.txt --force`` turned the user's notes into a calibration)."""
    before = snapshot(lab)
    argv = [a.replace("{lab}", str(lab)).replace("{file}", str(lab / "notes.txt")) for a in argv]
    assert main([*argv, "--force"]) == 2
    err = capsys.readouterr().err
    assert f"{option} " in err and f"notes.txt: is not {kind}" in err and "move it away" in err, err
    assert snapshot(lab) == before
