"""Training runs and their folders (issue 35): a seed's folder has one writer, processes
training different seeds of one ``--out`` share its ``summary.json``, ``msr refine`` never
writes into a training run, a damaged log is named before any work, ``summary.json`` reports the
checkpoint's step."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from lock_holder import held_elsewhere
from smoke import SMOKE

from elastica_magnetic.cli import main as msr
from elastica_magnetic.result_markers import read_marker


def test_a_seed_being_trained_is_refused_naming_the_owner(tmp_path, capsys):
    seed = tmp_path / "runs" / "m1-4mT" / "seed0"
    seed.parent.mkdir(parents=True)
    with held_elsewhere(seed) as pid:  # another process trains seed0
        status = msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "80", "--out",
                      str(tmp_path / "runs"), *SMOKE])
    assert status == 2
    err = capsys.readouterr().err
    assert f"being written by pid {pid}" in err
    assert not (seed / "checkpoint.pt").exists()


def test_seed_folders_are_marked_and_summary_reports_the_checkpoint_step(trained):
    from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint

    summary = json.loads((trained / "m1-4mT" / "summary.json").read_text())
    for entry in summary["seeds"]:
        run = trained / "m1-4mT" / f"seed{entry['seed']}"
        assert entry["global_step"] == int(load_checkpoint(run, with_buffer=False)["global_step"])
        marker = read_marker(run)
        assert marker["kind"] == "train" and marker["subject"] == "case m1-4mT"


def test_refine_never_writes_into_a_training_run(trained, tmp_path, capsys):
    run = tmp_path / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    before = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()}
    assert msr(["refine", str(run), "--resume", "--out", str(run), "--steps", "2",
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert f"--out {run}: is the folder of a `msr train` run for case m1-4mT" in err
    assert {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()} == before


def test_a_damaged_episode_log_is_named_before_resuming(trained, tmp_path, capsys):
    runs = tmp_path / "runs"
    shutil.copytree(trained, runs)
    episodes = runs / "m1-4mT" / "seed0" / "episodes.csv"
    text = episodes.read_text()
    episodes.write_text(text[: len(text) // 2] + "\n\x00\x00garbage,,\n")
    before = (runs / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes()
    assert msr(["train", "--case", "m1-4mT", "--seeds", "2", "--steps", "400", "--resume",
                "--out", str(runs), *SMOKE]) == 2
    err = capsys.readouterr().err
    assert f"{episodes}: damaged log: row" in err
    assert (runs / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes() == before


def test_a_replay_file_cut_short_is_named_before_resuming(trained, tmp_path, capsys):
    """Round 9, V3: a replay.bin cut short was found after the other seed had trained, as
    "seed0: ValueError: ... holds 0 transitions", without a fix."""
    runs = tmp_path / "runs"
    shutil.copytree(trained, runs)
    replay = runs / "m1-4mT" / "seed0" / "replay.bin"
    replay.write_bytes(replay.read_bytes()[:1000])
    before = {p.name: p.read_bytes() for p in (runs / "m1-4mT" / "seed1").iterdir() if p.is_file()}
    assert msr(["train", "--case", "m1-4mT", "--seeds", "2", "--steps", "400", "--resume",
                "--out", str(runs), *SMOKE]) == 2
    err = capsys.readouterr().err
    assert f"cannot resume {replay.parent}: {replay}: holds" in err and "the file was cut short" in err
    assert "restore it" in err and "ValueError" not in err
    after = {p.name: p.read_bytes() for p in (runs / "m1-4mT" / "seed1").iterdir() if p.is_file()}
    assert after == before  # the other seed did not train meanwhile


MSR = "import sys; from elastica_magnetic.cli import main; sys.exit(main(sys.argv[1:]))"


@pytest.mark.slow
def test_two_processes_train_different_seeds_of_one_out(tmp_path):
    out = tmp_path / "runs"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    procs = [subprocess.Popen([sys.executable, "-c", MSR, "train", "--case", "m1-4mT", "--seeds",
                               "1", "--seed-offset", str(k), "--steps", "80", "--workers", "1",
                               "--out", str(out), *SMOKE], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True)
             for k in (0, 1)]
    for proc in procs:
        stdout, stderr = proc.communicate(timeout=300)
        assert proc.returncode == 0, stderr
    summary = json.loads((out / "m1-4mT" / "summary.json").read_text())
    assert sorted(e["seed"] for e in summary["seeds"]) == [0, 1]
    assert not list((out / "m1-4mT").glob(".*.msr-lock")) and not list(out.glob(".*.msr-lock"))


def test_case_given_twice_trains_both(monkeypatch):
    from elastica_magnetic_rl.sweep import training

    seen = {}

    def fake(cases, **kwargs):
        seen["cases"] = [c.name for c in cases]
        return {}

    monkeypatch.setattr(training, "train_cases", fake)
    msr(["train", "--case", "m1-4mT", "--case", "m2-4mT", "--seeds", "1", "--no-progress"])
    assert seen["cases"] == ["m1-4mT", "m2-4mT"]


def _copy_runs(trained, tmp_path) -> Path:
    runs = tmp_path / "runs"
    shutil.copytree(trained, runs)
    return runs


def test_resume_refuses_a_changed_hyperparameter_naming_both_values(trained, tmp_path, capsys):
    runs = _copy_runs(trained, tmp_path)
    before = (runs / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes()
    base = ["train", "--case", "m1-4mT", "--seeds", "2", "--steps", "400", "--resume", "--out",
            str(runs)]
    smoke = [a for a in SMOKE]
    for old, value, expected in (("hidden_sizes=32,32", "hidden_sizes=64,64",
                                  "--set hidden_sizes: the run's (32, 32), given (64, 64)"),
                                 ("batch_size=32", "batch_size=64",
                                  "--set batch_size: the run's 32, given 64")):
        args = list(smoke)
        args[args.index(old)] = value
        assert msr([*base, *args]) == 2
        err = capsys.readouterr().err
        assert "cannot resume" in err and expected in err, err
    assert (runs / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes() == before


def test_resume_refuses_another_cases_checkpoint(trained, tmp_path, capsys):
    import torch

    runs = _copy_runs(trained, tmp_path)
    path = runs / "m1-4mT" / "seed1" / "checkpoint.pt"
    ckpt = torch.load(path, weights_only=True)
    ckpt["metadata"]["case"] = "m2-4mT"  # as if m2-4mT's checkpoint had been copied here
    torch.save(ckpt, path)
    assert msr(["train", "--case", "m1-4mT", "--seeds", "2", "--steps", "400", "--resume",
                "--out", str(runs), *SMOKE]) == 2
    err = capsys.readouterr().err
    assert f"{path}: a checkpoint of case 'm2-4mT', not of 'm1-4mT'" in err


def test_a_run_no_episode_ends_in_is_refused_naming_milliseconds(tmp_path, capsys):
    """Round 6, O15: ``--episode-duration 2000`` (ms meant) on a 300-step run trained, measured
    no return and reported "still improving"."""
    smoke = [a for a in SMOKE if a not in ("--episode-duration", "0.8")]
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "300", "--episode-duration",
                "2000", "--out", str(tmp_path / "runs"), *smoke]) == 2
    err = capsys.readouterr().err
    assert "no training episode ends within the run: --episode-duration 2000 s (" in err, err
    assert ("is 200000 steps of 0.01 s, and --steps 300 over 1 robot(s) gives each 300") in err
    assert "2000 ms is 2 s" in err and not (tmp_path / "runs").exists()


def test_a_trial_run_shorter_than_the_specs_episode_says_so(tmp_path, capsys):
    """The spec's own 20 s episodes in a 150-step trial run: not refused (a first look at a
    shipped case), but warned, and the summary says no episode ended instead of a NaN return."""
    smoke = [a for a in SMOKE if a not in ("--episode-duration", "0.8")]
    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "150", "--workers", "1",
                "--out", str(tmp_path / "runs"), *smoke]) == 0
    captured = capsys.readouterr()
    assert "warning: no training episode ends within the run: [task] episode_duration = 20 s" in captured.err
    assert "20 ms" not in captured.err  # 20 s episodes are the paper's: no unit mistake named
    assert "no training episode ended (the run was shorter than one episode)" in captured.out
    assert "nan" not in captured.out


def test_resume_keeps_the_runs_crawlers_and_refuses_an_edited_record(trained, tmp_path, capsys):
    """Round 6, A12 (``--resume --envs 2`` on a one-crawler run went on, rewriting run.json) and
    W04 (an edited seed or field limit in run.json was ignored and overwritten)."""
    runs = _copy_runs(trained, tmp_path)
    before = (runs / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes()
    base = ["train", "--case", "m1-4mT", "--seeds", "1", "--steps", "400", "--resume", "--out",
            str(runs), *SMOKE]
    assert msr([*base, "--envs", "2"]) == 2
    assert "--envs 2 differs from the run's 1" in capsys.readouterr().err
    run_json = runs / "m1-4mT" / "seed0" / "run.json"
    original = run_json.read_text()
    for key, value in (("seed", 5), ("field_limit_T", 0.01)):
        record = json.loads(original)
        record[key] = value
        run_json.write_text(json.dumps(record))
        assert msr(base) == 2
        err = capsys.readouterr().err
        assert f"run.json: {key} is {value!r} but the run's" in err and "was edited" in err, err
    for key, value in (("precision", "fp64"), ("shared_simulator_seeds", 2)):  # round 7, O01
        record = json.loads(original)
        record[key] = value
        run_json.write_text(json.dumps(record))
        assert msr(base) == 2
        assert "run.json: edited since msr wrote it" in capsys.readouterr().err
    assert (runs / "m1-4mT" / "seed0" / "checkpoint.pt").read_bytes() == before


def test_a_seed_whose_every_episode_diverged_is_failed_not_improving(tmp_path, capsys):
    """Round 11, S4: a spec whose time step blows the robot up trained 100 one-step episodes of
    the divergence penalty and was reported "failed seeds: none ... still improving"."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["physics"]["training"]["dt"] = 1.25e-4  # between the estimated stable step and the bare limit
    path = tmp_path / "coarse.toml"
    path.write_text(dumps(spec))
    status = msr(["train", "--case", str(path), "--seeds", "1", "--steps", "100", "--out",
                  str(tmp_path / "runs"), *SMOKE, "--json"])
    out = capsys.readouterr()
    assert "likely unstable" in out.err
    summary = json.loads((tmp_path / "runs" / "m1-4mT" / "summary.json").read_text())
    assert status == 1 and summary["failed"] == [0], out.out
    assert "every training episode diverged at its first step (100 of 100" in summary["seeds"][0]["error"]
