"""The learning package's writing commands against an existing result (issue 35): ``msr policy generate``,
``baseline``, ``demo``, ``export``, ``export-seeds``, ``ship``, ``notes`` and ``figures`` replace a
result whole or not at all, only with ``--force``, never another command's or case's; Ctrl-C in a
real ``msr policy generate`` / ``msr policy export-seeds --workers 2`` process prints one line and
leaves the earlier result byte for byte."""

from __future__ import annotations

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from smoke import run_msr

from elastica_magnetic.cli import main as msr
from elastica_magnetic.result_markers import MANIFEST, MARKER

QUICK = ["--duration", "0.05", "--physics", "training", "--no-figures", "--no-progress"]


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative path -> bytes)."""
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def leftovers(folder: Path) -> list[str]:
    """Temporary folders or lock files of the mechanism beside or inside ``folder``."""
    beside = [p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}.msr-")]
    inside = [p.name for p in folder.rglob(".msr-files-*")] if folder.is_dir() else []
    return beside + inside


def test_generate_replaces_only_its_own_result_and_only_with_force(trained, tmp_path, capsys):
    run = trained / "m1-4mT" / "seed0"
    out = tmp_path / "gen"
    first = run_msr(capsys, "policy", "generate", str(run), *QUICK, "--out", str(out))
    assert ".msr-new" not in json.dumps(first) and Path(first["fields_csv"]).parent == out
    stored = json.loads((out / "generate.json").read_text())
    assert stored["trajectory_csv"] == str(out / "trajectory.csv")  # where the file is now
    assert json.loads((out / MARKER).read_text())["subject"] == "case m1-4mT"
    before = snapshot(out)

    assert msr(["policy", "generate", str(run), *QUICK, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "already holds a result of `msr policy generate` for case m1-4mT" in err and "--force" in err
    assert msr(["field", "baseline", "--case", "m1-4mT", "--periods", "0.05", *QUICK, "--out", str(out),
                "--force"]) == 2
    assert "not of `msr field baseline`" in capsys.readouterr().err
    assert snapshot(out) == before and not leftovers(out)

    run_msr(capsys, "policy", "generate", str(run), *QUICK, "--out", str(out), "--force")
    assert (out / "fields.csv").is_file() and not leftovers(out)


def test_generate_never_writes_into_a_training_run(trained, tmp_path, capsys):
    run = tmp_path / "seed1"
    shutil.copytree(trained / "m1-4mT" / "seed1", run)
    before = snapshot(run)
    assert msr(["policy", "generate", str(trained / "m1-4mT" / "seed0"), *QUICK, "--out", str(run),
                "--force"]) == 2
    assert "a result of `msr train` for case m1-4mT" in capsys.readouterr().err
    assert snapshot(run) == before


def test_demo_replaces_its_own_demo(monkeypatch, trained, tmp_path, capsys):
    from elastica_magnetic_rl.shipping import generate as generate_module

    calls = []
    real = generate_module.generate

    def short(policy, **kwargs):
        calls.append(kwargs)
        return real(run_policy_source, **{**kwargs, "duration": 0.05, "physics": "training",
                                          "pictures": generate_module.Pictures(figures=False)})

    run_policy_source = str(trained / "m1-4mT" / "seed0")
    monkeypatch.setattr(generate_module, "generate", short)
    out = tmp_path / "demo"
    for _ in range(2):  # the README's main command stays re-runnable
        assert msr(["policy", "demo", "--out", str(out), "--no-progress", "--json"]) == 0
    assert calls[-1]["force"] is True and calls[-1]["kind"] == "demo"
    assert json.loads((out / MARKER).read_text())["kind"] == "demo"


def test_export_needs_force_to_replace(trained, tmp_path, capsys):
    run = str(trained / "m1-4mT" / "seed0")
    out = tmp_path / "export"
    run_msr(capsys, "policy", "export", run, "--out", str(out), "--checkpoint", "final")
    before = snapshot(out)
    begin = time.perf_counter()  # refused before the actors' 10 s evaluations (--checkpoint auto)
    assert msr(["policy", "export", run, "--out", str(out)]) == 2
    assert time.perf_counter() - begin < 20
    assert "already holds a result of `msr policy export`" in capsys.readouterr().err
    assert snapshot(out) == before
    result = run_msr(capsys, "policy", "export", run, "--out", str(out), "--force", "--checkpoint", "final")
    assert result["json"] == str(out / "policy.json") and not leftovers(out)


def test_ship_checks_name_and_dest_first_and_keeps_the_old_policy_on_a_full_disk(
        trained, tmp_path, capsys, monkeypatch):
    run = str(trained / "m1-4mT" / "seed0")
    for bad in ("../x", ".hidden", "a/b"):
        assert msr(["policy", "ship", run, "--name", bad, "--out", str(tmp_path), "--no-progress"]) == 2
        assert "--name" in capsys.readouterr().err
    assert not (tmp_path.parent / "x").exists()
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    begin = time.perf_counter()
    assert msr(["policy", "ship", run, "--name", "p", "--out", str(a_file), "--no-progress"]) == 2
    assert "is a file" in capsys.readouterr().err and time.perf_counter() - begin < 10

    dest = tmp_path / "policies"
    run_msr(capsys, "policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure")
    (dest / "p" / "seeds").mkdir()  # export-seeds' folder inside a shipped policy stays
    (dest / "p" / "seeds" / "keep.txt").write_text("mine")
    before = snapshot(dest / "p")
    assert msr(["policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure"]) == 2
    assert "already holds a policy" in capsys.readouterr().err

    from elastica_magnetic_rl.shipping import ship as ship_module

    def full_disk(path, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(ship_module, "atomic_write_json", full_disk)  # after actor.pt
    assert msr(["policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure", "--force"]) == 2
    assert "No space left on device" in capsys.readouterr().err
    assert snapshot(dest / "p") == before and not leftovers(dest / "p")
    monkeypatch.undo()
    run_msr(capsys, "policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure", "--force")
    assert (dest / "p" / "seeds" / "keep.txt").read_text() == "mine"


def test_notes_of_a_run_and_a_non_utf8_notes_file(trained, tmp_path, capsys):
    run = str(trained / "m1-4mT" / "seed0")
    assert msr(["policy", "notes", run]) == 2
    assert "not a shipped policy" in capsys.readouterr().err
    latin = tmp_path / "notes.md"
    latin.write_bytes("Kalibrierung f\xfcr 4 mT".encode("latin-1"))
    assert msr(["policy", "ship", run, "--name", "p", "--out", str(tmp_path), "--no-measure",
                "--notes", str(latin)]) == 2
    err = capsys.readouterr().err
    assert f"--notes {latin}: not UTF-8" in err and not (tmp_path / "p").exists()


def test_export_seeds_merges_refuses_another_case_and_labels_the_duration(trained, tmp_path, capsys):
    dest = tmp_path / "seeds"
    case_dir = str(trained / "m1-4mT")
    args = ["policy", "export-seeds", case_dir, "--out", str(dest), "--duration", "0.05", "--no-progress"]
    result = run_msr(capsys, *args)
    entry = result["seeds"][0]
    assert "distance_10s_m" not in entry and entry["duration_s"] == 0.05  # not the 10 s distance
    assert result["meeting_target"] is None  # JSON: no verdict
    # round 12: the human output said "meeting_target: none", as if no seed had met the target
    assert msr([*args[:4], str(tmp_path / "seeds2"), *args[5:]]) == 0
    assert "meeting_target: not judged: the yardstick is a distance in 10 s, these runs are " \
           "0.05 s" in capsys.readouterr().out
    before = snapshot(dest)
    assert msr(args) == 2
    assert "already holds seeds 0, 1 of case m1-4mT" in capsys.readouterr().err
    # the folder now holds another case's seeds (as m2-4mT's would be)
    policy_json = dest / "seed0" / "policy.json"
    info = json.loads(policy_json.read_text())
    info["case"], info["case_spec"]["name"] = "m2-4mT", "m2-4mT"
    policy_json.write_text(json.dumps(info))
    before = snapshot(dest)
    assert msr([*args, "--force"]) == 2
    assert "trained on another spec of case 'm2-4mT' than this run's 'm1-4mT'" in capsys.readouterr().err
    assert snapshot(dest) == before and not leftovers(dest)
    # round 18 V104: a spec of the same name that differs in its robot names the key, not the case twice
    info["case"], info["case_spec"]["name"] = "m1-4mT", "m1-4mT"
    info["case_spec"]["robot"]["magnetization"]["magnitude"] = 90e3
    policy_json.write_text(json.dumps(info))
    before = snapshot(dest)
    assert msr([*args, "--force"]) == 2
    assert "(they differ at [robot.magnetization] magnitude)" in capsys.readouterr().err
    assert snapshot(dest) == before and not leftovers(dest)


def test_figures_name_a_damaged_log_and_replace_their_own_figures(trained, tmp_path, capsys):
    runs = tmp_path / "runs"
    shutil.copytree(trained, runs)
    first = run_msr(capsys, "policy", "figures", str(runs))
    drawn = Path(first["learning_curves_m1-4mT"]).read_bytes()
    assert msr(["policy", "figures", str(runs)]) == 2  # an existing figure is replaced only with --force
    assert "already holds learning_curves_m1-4mT.png; pass --force" in capsys.readouterr().err
    assert Path(first["learning_curves_m1-4mT"]).read_bytes() == drawn
    again = run_msr(capsys, "policy", "figures", str(runs), "--force")
    assert first == again and Path(first["learning_curves_m1-4mT"]).is_file()
    episodes = runs / "m1-4mT" / "seed1" / "episodes.csv"
    lines = episodes.read_text().splitlines()
    lines[2] = lines[2].replace(lines[2].split(",")[2], "abc", 1)
    episodes.write_text("\n".join(lines) + "\n")
    assert msr(["policy", "figures", str(runs), "--force"]) == 2
    err = capsys.readouterr().err
    assert f"{episodes}: damaged log: row 3, column 'return': 'abc'" in err
    assert not leftovers(runs)
    # a damaged evaluations.csv (a third round of tries: KeyError / TypeError tracebacks)
    episodes.write_text("\n".join(line for line in episodes.read_text().splitlines()
                                  if "abc" not in line) + "\n")
    evaluations = runs / "m1-4mT" / "seed0" / "evaluations.csv"
    header, first, *rest = evaluations.read_text().splitlines()
    fields = first.split(",")
    fields[header.split(",").index("mean_return")] = "abc"
    for damaged, named in (("step,mean_distance\n100,1.0\n", "the header lacks global_step"),
                           ("\n".join([header, ",".join(fields), *rest]) + "\n",
                            "row 2, column 'mean_return': 'abc'")):
        evaluations.write_text(damaged)
        assert msr(["policy", "figures", str(runs), "--force"]) == 2
        err = capsys.readouterr().err
        assert f"{evaluations}: damaged log" in err and named in err and "Traceback" not in err


# -- Ctrl-C in a real process ----------------------------------------------------------------------

MSR = "import sys; from elastica_magnetic.cli import main; sys.exit(main(sys.argv[1:]))"


def interrupt_when_writing(args: list[str], out: Path, cwd: Path,
                           delay: float) -> subprocess.CompletedProcess:
    """Run ``msr ARGS`` in its own process group; once its temporary result folder beside
    ``out`` exists, wait ``delay`` s and send SIGINT to the group (as a terminal's Ctrl-C)."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-c", MSR, *args], cwd=cwd, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,
                            # as from a terminal, also when the suite runs as a background job
                            # (which starts with SIGINT ignored, and children inherit that)
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 180
    while not any(p.name.startswith(f".{out.name}.msr-new-") for p in out.parent.iterdir()):
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            raise AssertionError(f"never started writing: {proc.communicate()}")
        time.sleep(0.05)
    time.sleep(delay)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    return subprocess.CompletedProcess(args, proc.returncode, stdout, stderr)


@pytest.mark.skipif(os.name != "posix", reason="signals are POSIX")
def test_ctrl_c_in_generate_leaves_the_earlier_result(refined, tmp_path, capsys):
    out = tmp_path / "gen"
    run_msr(capsys, "policy", "generate", str(refined), *QUICK, "--out", str(out))
    before = snapshot(out)
    begin = time.perf_counter()
    done = interrupt_when_writing(["policy", "generate", str(refined), "--duration", "5", "--no-progress",
                                   "--out", str(out), "--force"], out, tmp_path, 0.5)
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip().splitlines() == [
        # the folder named as the user sees it from where they stand (the process's cwd)
        f"msr policy generate: interrupted (SIGINT); {out.relative_to(tmp_path)} was left as it was (a "
        "result folder is "
        "replaced whole or not at all)"]
    assert time.perf_counter() - begin < 60
    assert snapshot(out) == before and not leftovers(out)


@pytest.mark.skipif(os.name != "posix", reason="signals are POSIX")
def test_ctrl_c_in_export_seeds_with_workers_leaves_the_earlier_result(trained, tmp_path, capsys):
    dest = tmp_path / "seeds"
    runs = tmp_path / "runs"
    shutil.copytree(trained / "m1-4mT", runs / "m1-4mT")
    args = ["policy", "export-seeds", str(runs / "m1-4mT"), "--out", str(dest), "--duration", "0.05",
            "--no-progress"]
    run_msr(capsys, *args)
    before = snapshot(dest)
    for evaluation in (runs / "m1-4mT").glob("seed*/evaluation.json"):
        evaluation.unlink()  # no cached evaluation: the workers have minutes of work
    done = interrupt_when_writing(["policy", "export-seeds", str(runs / "m1-4mT"), "--out", str(dest),
                                   "--duration", "20", "--workers", "2", "--no-progress",
                                   "--force"], dest, tmp_path, 3.0)
    assert done.returncode == 130, done.stderr
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr, done.stderr
    assert lines[0] == (f"msr policy export-seeds: interrupted (SIGINT); {dest.relative_to(tmp_path)} "
                        "was left as it was (a "
                        "result folder is replaced whole or not at all)"), done.stderr
    assert len(lines) == 1, done.stderr
    assert snapshot(dest) == before and not leftovers(dest)


def test_round12_v5_figures_redrawn_into_a_result_are_replaced_with_it(tmp_path, capsys):
    """Round 12, V5: after `msr policy figures OUT --force`, `msr policy generate --force --out OUT`
    was refused for msr's own record of the figures (.msr-files.json)."""
    from elastica_magnetic.cli import main

    out = tmp_path / "g1"
    args = ["policy", "generate", "m1-4mT", "--no-figures", "--no-gif", "--no-progress", "--physics",
            "training", "--duration", "0.1", "--out", str(out)]
    assert main(args) == 0
    assert main(["policy", "figures", str(out), "--no-gif", "--force"]) == 0
    assert (out / MANIFEST).is_file()
    assert main([*args, "--force"]) == 0, capsys.readouterr().err
    assert not (out / MANIFEST).exists()  # the result was replaced whole


def test_ship_force_keeps_a_model_card_edited_since_and_says_the_notes_are_not_carried_over(
        trained, tmp_path, capsys):
    """Round 14 D1: `ship --force` replaced a hand-edited MODEL_CARD.md (msr records what it wrote,
    so it can tell), and dropped the replaced policy's notes without a word."""
    run = str(trained / "m1-4mT" / "seed0")
    dest = tmp_path / "policies"
    notes = tmp_path / "notes.md"
    notes.write_text("Calibrated on coil set B.")
    run_msr(capsys, "policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure", "--notes",
            str(notes))
    card = dest / "p" / "MODEL_CARD.md"
    card.write_text(card.read_text() + "\n## My hand-written analysis\n")
    before = snapshot(dest / "p")
    assert msr(["policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure", "--force"]) == 2
    assert "MODEL_CARD.md: not written by msr" in capsys.readouterr().err
    assert snapshot(dest / "p") == before and not leftovers(dest / "p")
    card.unlink()  # moved away: the re-ship goes on, and says the notes are not carried over
    assert msr(["policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure", "--force"]) == 0
    err = capsys.readouterr().err
    assert "the replaced policy's notes (policy.json) are not carried over" in err
    # round 17 V: the command it named, `msr policy notes p`, looked for a shipped policy p in
    # rl/policies: the folder is named where it is not one of the package's
    assert f"msr policy notes {dest / 'p'} --file F" in err, err


def test_ship_force_keeps_a_model_card_msr_has_no_record_of(trained, tmp_path, capsys):
    """Round 15 D1: a policy as committed had no .msr-files.json, so `ship --force` adopted its
    hand-edited MODEL_CARD.md as msr's and replaced it. The shipped policies now carry their
    records (an edited card is refused as changed since), and a card without a record (its record
    removed) is refused too; the weights and policy.json of such a policy are still adopted."""
    import shutil

    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR, SHIPPED_FILES

    for shipped in sorted(POLICIES_DIR.iterdir()):  # every committed policy has its record
        if (shipped / "policy.json").is_file():
            recorded = json.loads((shipped / MANIFEST).read_text())["files"]
            assert sorted(recorded) == sorted(n for n in SHIPPED_FILES if (shipped / n).is_file()), shipped
    run = str(trained / "m1-4mT" / "seed0")
    dest = tmp_path / "pol"
    shutil.copytree(POLICIES_DIR / "m1-4mT", dest / "m1-4mT")
    card = dest / "m1-4mT" / "MODEL_CARD.md"
    card.write_text(card.read_text() + "\n## Maintainer's hand-written analysis\n")
    args = ["policy", "ship", run, "--name", "m1-4mT", "--out", str(dest), "--no-measure", "--force"]
    before = snapshot(dest / "m1-4mT")
    assert msr(args) == 2
    assert "MODEL_CARD.md: not written by msr" in capsys.readouterr().err
    (dest / "m1-4mT" / MANIFEST).unlink()  # no record at all: the card may still be someone's
    before = snapshot(dest / "m1-4mT")
    assert msr(args) == 2
    assert "MODEL_CARD.md has no record of being written by msr" in capsys.readouterr().err
    assert snapshot(dest / "m1-4mT") == before and "hand-written" in card.read_text()
    card.unlink()
    assert msr(args) == 0  # the rest adopted and replaced
    assert "hand-written" not in card.read_text()


def test_round16_d1_ship_force_keeps_a_file_of_the_users_in_the_policy_folder(trained, tmp_path, capsys):
    """Round 16 D1: `ship --force` into a policy folder with msr's record removed a fields.csv the
    user had put there (the new policy, not measured, has none: msr removes the replaced policy's
    files the new one lacks, and took every file of a policy's names as its own)."""
    run = str(trained / "m1-4mT" / "seed0")
    dest = tmp_path / "shipD"
    args = ["policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure"]
    run_msr(capsys, *args)
    (dest / "p" / "fields.csv").write_text("t,my,own,waveform\n")
    before = snapshot(dest / "p")
    assert msr([*args, "--force"]) == 2
    assert "fields.csv: not written by msr" in capsys.readouterr().err
    assert snapshot(dest / "p") == before and not leftovers(dest / "p")
    (dest / "p" / "fields.csv").unlink()  # moved away: the re-ship goes on
    assert msr([*args, "--force"]) == 0


def test_round16_s07_generate_with_another_cases_checkpoint_names_both_cases(trained, tmp_path, capsys):
    """Round 16 S07 (V): it said "the case: ... plays a uniform field" (a catheter's checkpoint)."""
    import shutil

    import torch
    from elastica_magnetic_rl.cases.case import load_case

    run = trained / "m1-4mT" / "seed0"
    shutil.copytree(run, tmp_path / "other")
    other = tmp_path / "other" / "checkpoint.pt"
    ckpt = torch.load(other, map_location="cpu", weights_only=True)
    ckpt["metadata"]["case"] = "m2-4mT"  # as if another case's checkpoint (of the same shapes)
    ckpt["metadata"]["case_spec"] = load_case("m2-4mT").to_dict()
    torch.save(ckpt, other)
    assert msr(["policy", "generate", str(run), "--checkpoint", str(other), "--duration", "0.1",
                "--out", str(tmp_path / "g")]) == 2
    err = capsys.readouterr().err
    assert f"--checkpoint {other}: a checkpoint of case 'm2-4mT', not of {run}'s case 'm1-4mT'" in err
    assert not (tmp_path / "g").exists()


def test_round17_ship_force_never_replaces_another_cases_policy(trained, tmp_path, capsys):
    """Round 17 D: `ship --force` put a policy of case m1-4mT where a policy of another case was
    shipped under the same name, without a word (export and generate refuse another case)."""
    import shutil

    import torch
    from elastica_magnetic_rl.cases.case import load_case

    other = tmp_path / "other"
    shutil.copytree(trained / "m1-4mT" / "seed0", other)
    ckpt = torch.load(other / "checkpoint.pt", map_location="cpu", weights_only=True)
    ckpt["metadata"]["case"] = "m2-4mT"  # another case's run (of the same shapes)
    ckpt["metadata"]["case_spec"] = load_case("m2-4mT").to_dict()
    torch.save(ckpt, other / "checkpoint.pt")
    dest = tmp_path / "ship"
    run_msr(capsys, "policy", "ship", str(other), "--name", "p", "--out", str(dest), "--no-measure")
    before = snapshot(dest / "p")
    assert msr(["policy", "ship", str(trained / "m1-4mT" / "seed0"), "--name", "p", "--out", str(dest),
                "--no-measure", "--force"]) == 2
    err = capsys.readouterr().err
    assert "holds the shipped policy of case 'm2-4mT', and this run is of case 'm1-4mT'" in err
    assert snapshot(dest / "p") == before and not leftovers(dest / "p")


def test_round17_generate_of_a_shipped_policy_refuses_a_checkpoint_file(trained, tmp_path, capsys):
    """Round 17 S: `generate SHIPPED --checkpoint FILE` played the file and dropped the shipped
    policy named as POLICY without a note."""
    checkpoint = trained / "m1-4mT" / "seed0" / "checkpoint.pt"
    assert msr(["policy", "generate", "m1-4mT", "--checkpoint", str(checkpoint), "--duration", "0.1",
                "--out", str(tmp_path / "g")]) == 2
    err = capsys.readouterr().err
    assert "m1-4mT is not a run folder (a shipped policy or an actor file)" in err
    assert "or give that checkpoint itself in place of m1-4mT" in err and not (tmp_path / "g").exists()


def test_round17_export_seeds_never_replaces_a_shipped_policy_folder(trained, tmp_path, capsys):
    """Round 17 D: `export-seeds --out` a shipped policy's folder (no --force) deleted its actor,
    critic, policy.json and card: the files msr had recorded there counted as nothing to keep."""
    run = str(trained / "m1-4mT" / "seed0")
    dest = tmp_path / "ship"
    run_msr(capsys, "policy", "ship", run, "--name", "p", "--out", str(dest), "--no-measure")
    before = snapshot(dest / "p")
    for force in ([], ["--force"]):
        assert msr(["policy", "export-seeds", str(trained / "m1-4mT"), "--out", str(dest / "p"),
                    "--duration", "0.05", "--no-progress", *force]) == 2
        err = capsys.readouterr().err
        assert "holds files another msr command wrote there (" in err and "actor.pt" in err, err
        assert snapshot(dest / "p") == before and not leftovers(dest / "p")


def test_round17_generate_refuses_another_runs_checkpoint_and_names_a_folder(trained, tmp_path, capsys):
    """Round 17 S and V: `generate RUN_A --checkpoint RUN_B/best.pt` of the same case played RUN_B's
    actor with RUN_A dropped; a folder given to --checkpoint was "no such checkpoint file"."""
    run, other = trained / "m1-4mT" / "seed0", trained / "m1-4mT" / "seed1" / "checkpoint.pt"
    assert msr(["policy", "generate", str(run), "--checkpoint", str(other), "--duration", "0.05",
                "--out", str(tmp_path / "g")]) == 2
    assert f"--checkpoint {other}: not one of {run}'s checkpoints" in capsys.readouterr().err
    assert msr(["policy", "generate", str(run), "--checkpoint", str(trained), "--duration", "0.05",
                "--out", str(tmp_path / "g")]) == 2
    err = capsys.readouterr().err
    assert f"--checkpoint {trained}: a folder; give one of the run's checkpoint files" in err
    assert not (tmp_path / "g").exists()
