"""Round 19 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A nineteenth round of tries")."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from elastica_magnetic_rl.cases.case import SPECS_DIR

from elastica_magnetic.cli import main as msr

MEASUREMENTS = ("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n"
                "1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n1,1,0,2,2,0\n")


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


def test_one_file_results_go_into_no_other_commands_result(tmp_path, capsys):
    """D4, S29, S33: ``msr real calibrate --out RESULT/cal.json`` (and ``--set-yardstick
    RESULT/y.toml``) wrote into another command's result, which its ``--force`` then removed
    without a word."""
    result = tmp_path / "sim"
    assert msr(["field", "simulate", "--duration", "0.02", "--no-progress", "--out", str(result)]) == 0
    before = _files(result)
    (tmp_path / "meas.csv").write_text(MEASUREMENTS)
    capsys.readouterr()
    assert msr(["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(result / "cal.json")]) == 2
    assert "lies in" in capsys.readouterr().err
    assert msr(["field", "baseline", "--case", "m1-4mT", "--periods", "1", "--duration", "10",
                "--out", str(tmp_path / "b"), "--set-yardstick", str(result / "y.toml"),
                "--no-progress"]) == 2
    assert "lies in" in capsys.readouterr().err
    assert _files(result) == before and not (tmp_path / "b").exists()
    assert msr(["real", "calibrate", str(tmp_path / "meas.csv"), "--out", str(tmp_path / "cal.json")]) == 0


def test_ship_goes_into_no_other_result_and_no_policy(trained, tmp_path, capsys):
    """D5: ``msr policy ship --out DEST`` put a policy inside a simulation's result (which could
    then not be replaced), inside a training's seed folder and inside another policy."""
    run = trained / "m1-4mT" / "seed0"
    sim = tmp_path / "sim"
    assert msr(["field", "simulate", "--duration", "0.02", "--no-progress", "--out", str(sim)]) == 0
    ship = ["policy", "ship", str(run), "--no-measure", "--checkpoint", "final"]
    assert msr([*ship, "--name", "p1", "--out", str(tmp_path / "ship")]) == 0
    before = {folder: _files(folder) for folder in (sim, run, tmp_path / "ship" / "p1")}
    shipped = tmp_path / "ship" / "p1"
    for dest, words in ((sim, "lies in"), (run, "lies in"), (shipped, "is a shipped policy")):
        capsys.readouterr()
        assert msr([*ship, "--name", "p2", "--out", str(dest)]) == 2
        assert words in capsys.readouterr().err
    assert {folder: _files(folder) for folder in before} == before
    assert msr([*ship, "--name", "p2", "--out", str(tmp_path / "ship")]) == 0  # beside another: fine


def test_notes_from_the_policys_own_card_are_refused(trained, tmp_path, capsys):
    """S6: ``msr policy notes P --file P/MODEL_CARD.md`` nested the card in its own notes."""
    run = trained / "m1-4mT" / "seed0"
    assert msr(["policy", "ship", str(run), "--no-measure", "--checkpoint", "final", "--name", "p",
                "--out", str(tmp_path)]) == 0
    policy = tmp_path / "p"
    before = {name: (policy / name).read_bytes() for name in ("MODEL_CARD.md", "policy.json")}
    for name in before:
        capsys.readouterr()
        assert msr(["policy", "notes", str(policy), "--file", str(policy / name)]) == 2
        assert f"is the policy's own {name}" in capsys.readouterr().err
    assert {name: (policy / name).read_bytes() for name in before} == before


def test_a_specs_device_this_pytorch_lacks_is_refused_before_any_work(tmp_path, capsys):
    """V10: ``[training.td3] device = "cuda"`` on a CPU build failed every seed after the run
    folders were made (``--device cuda`` was refused up front)."""
    import torch

    if torch.version.cuda is not None:
        pytest.skip("this PyTorch has CUDA")
    spec = tmp_path / "gpu.toml"
    text = (SPECS_DIR / "m1-4mT.toml").read_text()
    assert "[training.td3]" not in text
    spec.write_text(text + '\n[training.td3]\ndevice = "cuda"\n')
    capsys.readouterr()
    assert msr(["train", "--case", str(spec), "--steps", "10", "--out", str(tmp_path / "runs"),
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"{spec}: [training.td3] device = cuda: this PyTorch has no CUDA" in err
    assert not (tmp_path / "runs").exists()


@pytest.mark.skipif(os.name != "posix", reason="signals are POSIX")
def test_sigterm_ends_any_command_as_ctrl_c_does(tmp_path):
    """S7: ``msr field baseline --set-yardstick F`` killed with SIGTERM ended with no message and
    left its lock file beside F (SIGINT did both right): every command now takes SIGTERM as Ctrl-C."""
    folder = tmp_path / "yst"
    folder.mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "elastica_magnetic.cli", "field", "baseline", "--case", "m1-4mT", "--periods",
         "1", "--duration", "10", "--workers", "1", "--out", str(tmp_path / "b"), "--set-yardstick",
         str(folder / "y.toml"), "--no-progress", "--no-figures"], stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    try:
        while not any(folder.iterdir()) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
        assert any(folder.iterdir()), "the command took no lock to interrupt"
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "interrupted (SIGTERM)" in err and "Traceback" not in err
    assert list(folder.iterdir()) == [] and not (tmp_path / "b").exists()


def test_a_calibration_for_a_skipped_firmware_step_is_refused(tmp_path, capsys):
    """S12: ``msr loop --skip firmware --calibration FILE``: the one step that reads the file is
    skipped; it was accepted (or refused for what that step would have done)."""
    from pathlib import Path

    calibration = Path(__file__).resolve().parents[3] / "stm32" / "calibration" / "default.json"
    assert msr(["loop", "m1-4mT", "--out", str(tmp_path / "L"), "--skip", "firmware", "--calibration",
                str(calibration), "--quick"]) == 2
    assert "--skip firmware skips that step" in capsys.readouterr().err
    assert not (tmp_path / "L").exists()


def test_nothing_goes_into_a_trainings_case_folder_or_another_result(trained, tmp_path, capsys):
    """D4, D5, D6: ``generate``/``refine --out RUNS/<case>/x`` left a training's folder that
    ``train --resume`` then refused; ``refine --out EXPORT/ref`` and ``seeds --figure EXPORT`` wrote
    inside an export (which ``export --force`` then removed or refused). A refinement's own place,
    RUN/refined, stays allowed."""
    import shutil

    runs = tmp_path / "runs"
    shutil.copytree(trained / "m1-4mT", runs / "m1-4mT")
    run = runs / "m1-4mT" / "seed0"
    export = tmp_path / "export"
    assert msr(["policy", "export", str(run), "--out", str(export), "--checkpoint", "final",
                "--no-progress"]) == 0
    before = {folder: _files(folder) for folder in (runs, export)}
    tries = [
        (["policy", "generate", str(run), "--out", str(runs / "m1-4mT" / "gen"), "--duration", "0.05",
          "--no-figures", "--no-progress", "--checkpoint", "final"], "holds the runs of a training (seed0"),
        (["refine", str(run), "--steps", "3", "--checkpoint", "final", "--out", str(runs / "m1-4mT" / "ref"),
          "--no-progress"], "holds the runs of a training (seed0"),
        (["refine", str(run), "--steps", "3", "--checkpoint", "final", "--out", str(export / "ref"),
          "--no-progress"], "lies in"),
        (["policy", "seeds", "m1-4mT", "--figure", str(export)], "no part of it"),
    ]
    for argv, words in tries:
        capsys.readouterr()
        assert msr(argv) == 2, argv
        assert words in capsys.readouterr().err, argv
    assert {folder: _files(folder) for folder in before} == before


def test_a_run_still_being_trained_is_not_shipped_or_played(trained, tmp_path, capsys):
    """S15, S16: ``ship``/``generate --checkpoint final`` of a run a live ``msr train`` wrote took
    a checkpoint of step 200 of 1500 as the final actor, without a word."""
    import shutil

    from lock_holder import held_elsewhere

    run = tmp_path / "runs" / "m1-4mT" / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    with held_elsewhere(run) as pid:
        for argv in (["policy", "ship", str(run), "--no-measure", "--checkpoint", "final", "--name", "q",
                      "--out", str(tmp_path / "ship")],
                     ["policy", "generate", str(run), "--out", str(tmp_path / "gen"), "--duration", "0.05",
                      "--no-figures", "--no-progress", "--checkpoint", "final"]):
            capsys.readouterr()
            assert msr(argv) == 2, argv
            assert f"is being trained by pid {pid}" in capsys.readouterr().err
    assert not (tmp_path / "ship").exists() and not (tmp_path / "gen").exists()
