"""``msr train`` and ``msr refine`` options refused before any work (rl/cli/train_commands.py,
issue 48): a --device this PyTorch lacks (try rf8: a traceback after run.json was written) and an
--episode-duration below one control step (try o4: a run folder and a summary with nan)."""

from __future__ import annotations

import json

import pytest
import torch

from elastica_magnetic.cli import main as msr

#: A run that would start (its warm-up and minibatch inside its 20 steps).
_TINY_TRAIN = ["train", "--case", "m1-4mT", "--steps", "20", "--seeds", "1", "--workers", "1",
               "--set", "learning_starts=5", "--set", "batch_size=4", "--set", "hidden_sizes=8,8",
               "--no-progress"]


@pytest.fixture
def cpu_only_torch(monkeypatch):
    """This PyTorch as a CPU build (whatever the machine running the tests has)."""
    monkeypatch.setattr(torch.version, "cuda", None)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)


def test_refine_on_cuda_with_a_cpu_build_is_refused_writing_nothing(trained, tmp_path, capsys,
                                                                    cpu_only_torch):
    out = tmp_path / "rf8"
    assert msr(["refine", str(trained / "m1-4mT" / "seed0"), "--checkpoint", "final", "--steps",
                "2", "--episode-duration", "0.02", "--no-progress", "--device", "cuda",
                "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "msr refine: error: --device cuda: this PyTorch has no CUDA (CPU build); use " \
           "--device cpu" in err, err
    assert "Traceback" not in err and not out.exists()


def test_train_on_cuda_with_a_cpu_build_is_refused_writing_nothing(tmp_path, capsys,
                                                                   cpu_only_torch):
    out = tmp_path / "runs"
    assert msr([*_TINY_TRAIN, "--device", "cuda", "--out", str(out)]) == 2
    assert "msr train: error: --device cuda: this PyTorch has no CUDA (CPU build); use " \
           "--device cpu" in capsys.readouterr().err
    assert not out.exists()


def test_refining_a_run_trained_on_cuda_on_a_cpu_build_is_refused_naming_it(cpu_only_torch):
    from elastica_magnetic_rl.sweep.refine import _refinement_config
    from elastica_magnetic_rl.td3.config import TD3Config

    ckpt = {"config": TD3Config(device="cuda").to_dict()}
    with pytest.raises(ValueError, match=r"^run/checkpoint.pt trained on device 'cuda': this "
                                         r"PyTorch has no CUDA \(CPU build\); use --device cpu$"):
        _refinement_config(ckpt, None, "run/checkpoint.pt")
    assert _refinement_config(ckpt, "cpu", "run/checkpoint.pt").device == "cpu"


@pytest.mark.parametrize("duration", ["0.001", "0.009"])
def test_an_episode_shorter_than_one_control_step_is_refused_naming_the_option(
        duration, tmp_path, capsys):
    out = tmp_path / "runs_o4"
    assert msr([*_TINY_TRAIN, "--episode-duration", duration, "--out", str(out)]) == 2
    assert (f"msr train: error: --episode-duration {duration} s is shorter than one control step "
            "(0.01 s, 100 Hz): an episode needs at least one action; give a duration in "
            "[0.01, 3600] s") in capsys.readouterr().err
    assert not out.exists()
    assert msr(["refine", str(tmp_path / "run"), "--episode-duration", duration, "--out",
                str(tmp_path / "rf")]) == 2
    assert f"msr refine: error: --episode-duration {duration} s is shorter than one control " \
           "step" in capsys.readouterr().err
    assert not (tmp_path / "rf").exists()


def test_the_spec_key_of_the_episode_length_is_checked_alike(tmp_path, capsys):
    """[task] episode_duration sets the same length: refused at parse time, naming the key."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["task"]["episode_duration"] = 0.001
    short = tmp_path / "short.toml"
    short.write_text(dumps(spec))
    with pytest.raises(SystemExit) as exit_info:
        msr(["train", "--case", str(short), "--out", str(tmp_path / "runs"), "--no-progress"])
    assert exit_info.value.code == 2
    assert "[task] episode_duration: must be >= 0.01 (s), got 0.001" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


def test_sigterm_stops_a_training_with_the_message_of_ctrl_c(tmp_path):
    """SIGTERM ended ``msr train`` (one worker, in this process) with status 143 and no word
    (round 4, V9): now it names the signal and the checkpoints to resume from."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "runs"
    argv = [sys.executable, "-m", "elastica_magnetic.cli", "train", "--case", "m1-4mT", "--seeds", "1",
            "--threads", "1", "--workers", "1", "--set", "learning_starts=60", "--set", "batch_size=32",
            "--set", "hidden_sizes=32,32", "--episode-duration", "0.5", "--set", "eval_every=100000",
            "--set", "checkpoint_every=60", "--steps", "100000", "--out", str(out), "--no-progress"]
    proc = subprocess.Popen(argv, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "MPLBACKEND": "Agg"})
    checkpoint = out / "m1-4mT" / "seed0" / "checkpoint.pt"
    deadline = time.monotonic() + 120
    while not checkpoint.exists() and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert "interrupted (SIGTERM): training stopped. The last checkpoints are in" in err, err
    assert "--resume" in err


@pytest.mark.parametrize(("setting", "message"), [
    ("batchsize=64", "unknown setting 'batchsize'; settable: hidden_sizes, actor_hidden_sizes"),
    ("batch_size", "'batch_size': expected KEY=VALUE, e.g. batch_size=128"),
    ("batch_size=6.5", "batch_size=6.5: expected an integer"),
    ("hidden_sizes=64x64", "hidden_sizes=64x64: expected comma-separated layer widths"),
    ("gamma=1.5", "gamma=1.5: gamma must be in [0, 1], got 1.5"),
    ("critic_layer_norm=maybe", "critic_layer_norm=maybe: expected true or false"),
])
def test_set_checks_each_setting_against_the_td3_config(tmp_path, capsys, setting, message):
    """`--set KEY=VALUE` (issue 50: one option for every TD3 setting, as RL Zoo's
    --hyperparams): an unknown key, a malformed or out-of-range value named before any work."""
    with pytest.raises(SystemExit) as refused:
        msr([*_TINY_TRAIN, "--set", setting, "--out", str(tmp_path / "runs")])
    assert refused.value.code == 2
    assert f"msr train: error: argument --set: {message}" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


def test_a_setting_given_twice_is_refused_and_an_old_flag_still_sets_it(tmp_path, capsys):
    assert msr([*_TINY_TRAIN, "--set", "batch_size=8", "--out", str(tmp_path / "runs")]) == 2
    assert "--set batch_size given twice (4 and 8); give it once" in capsys.readouterr().err
    at = _TINY_TRAIN.index("batch_size=4")
    args = [*_TINY_TRAIN[:at - 1], *_TINY_TRAIN[at + 1:]]  # without --set batch_size=4
    assert msr([*args, "--batch-size", "4", "--out", str(tmp_path / "runs"), "--json"]) == 0
    captured = capsys.readouterr()
    assert "msr train: note: --batch-size is now --set batch_size=VALUE" in captured.err
    run = json.loads((tmp_path / "runs" / "m1-4mT" / "seed0" / "run.json").read_text())
    assert run["config"]["batch_size"] == 4 and run["config"]["hidden_sizes"] == [8, 8]


def test_a_bf16_fallback_is_warned_once_by_the_command(tmp_path, capfd, monkeypatch):
    """On a CPU without bfloat16 units the command says so once, as msr's warning line (its
    workers printed Python's form of it, one per worker and place)."""
    from elastica_magnetic_rl.td3 import algorithm

    monkeypatch.setattr(algorithm, "cpu_supports_bf16", lambda: False)
    assert msr([*_TINY_TRAIN, "--precision", "bf16", "--out", str(tmp_path / "runs")]) == 0
    captured = capfd.readouterr()
    err = captured.err
    assert err.count("msr train: warning: precision bf16: this CPU has no bfloat16 matrix units") == 1, err
    assert "UserWarning" not in err
    run = json.loads((tmp_path / "runs" / "m1-4mT" / "seed0" / "run.json").read_text())
    assert run["precision"] == "fp32"
    # round 15 V2: the summary said bf16 for a run that trained in fp32
    summary = json.loads((tmp_path / "runs" / "m1-4mT" / "summary.json").read_text())
    assert summary["precision"] == "fp32" and summary["precision_asked"] == "bf16"
    assert "precision: bf16" not in captured.out and "precision: fp32" in captured.out, captured.out


def test_a_fifo_at_the_case_folders_lock_name_is_refused_before_any_training(tmp_path, capsys):
    """Round 15 V4: the case folder is locked only for the summary, at the end: a FIFO at its lock
    name was refused after the whole training. Now before any seed folder is made."""
    import os

    out = tmp_path / "runs"
    out.mkdir()
    os.mkfifo(out / ".m1-4mT.msr-lock")
    assert msr([*_TINY_TRAIN, "--out", str(out)]) == 2
    assert "the lock file's name" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [".m1-4mT.msr-lock"]
