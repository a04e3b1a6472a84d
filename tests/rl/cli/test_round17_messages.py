"""Round 17 of held-out tries (issue 48): options that could not act refused by name."""

from __future__ import annotations

import pytest

from elastica_magnetic.cli import main as msr


@pytest.mark.parametrize("option, value, message", [
    ("--repeats", "5", "--repeats 5: --quick measures at most 1"),
    ("--steps", "1000000000", "--steps 1000000000: --quick measures at most 200"),
])
def test_bench_quick_refuses_sizes_it_would_ignore(capsys, option, value, message):
    """Round 17 S: `msr bench --quick --repeats 5 --steps 1e9` measured once, 200 steps, without
    a word."""
    assert msr(["bench", "--quick", "--train-seeds", "0", option, value]) == 2
    assert message in capsys.readouterr().err


def test_a_full_disk_during_training_names_the_run_folder(tmp_path, capsys, monkeypatch):
    """Round 17 V: `msr train --out` on a full disk said 'seed0: OSError: [Errno 28] No space left
    on device', naming no file or folder."""
    import errno

    from elastica_magnetic_rl.sweep import training

    def full_disk(job):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(training, "_train_group_unlocked", full_disk)
    msr(["train", "--case", "m1-4mT", "--seeds", "1", "--workers", "1", "--steps", "100", "--set",
         "learning_starts=50", "--set", "batch_size=8", "--episode-duration", "0.1", "--no-progress",
         "--out", str(tmp_path / "runs")])
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert "No space left on device while writing the run in " in text, text
    assert str(tmp_path / "runs" / "m1-4mT" / "seed0") in text and "--resume" in text


@pytest.mark.parametrize("argv", [
    ["field", "simulate", "--duration", "0.05"],
    ["policy", "generate", "m1-4mT", "--duration", "0.05", "--no-figures"],
    ["policy", "export", "m1-4mT"],
    ["validate", "spatial-fields", "--quick"],
])
def test_whole_folder_writers_never_replace_a_shipped_policy(tmp_path, capsys, argv):
    """Round 17 D: simulate, generate, export, export-seeds and validate with --out a policy
    folder msr shipped (every file in its record) replaced it whole, without --force."""
    import shutil

    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    folder = tmp_path / "p"
    shutil.copytree(POLICIES_DIR / "m1-4mT-robust", folder)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    for force in ([], ["--force"]):
        assert msr([*argv, "--out", str(folder), *force]) == 2
        assert "holds files another msr command wrote there (" in capsys.readouterr().err
        assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
