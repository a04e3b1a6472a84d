"""``msr refine`` (rl/sweep/refine.py): a trained run continued in the accurate physics, its agent and
replay buffer kept (the ``trained`` and ``refined`` runs: tests/rl/conftest.py)."""

from __future__ import annotations

import json

import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from smoke import TRAIN_STEPS


def test_refine_continues_agent_and_buffer_in_accurate_physics(trained, refined):
    source = load_checkpoint(trained / "m1-4mT" / "seed0")
    ckpt = load_checkpoint(refined)
    assert ckpt["global_step"] == TRAIN_STEPS + 3
    assert ckpt["buffer"]["size"] == TRAIN_STEPS + 3  # the training transitions are kept
    assert torch.equal(ckpt["buffer"]["obs"][:TRAIN_STEPS], source["buffer"]["obs"])
    # learning happened (past the warm-up): more critic updates, different weights
    assert ckpt["agent"]["num_updates"] == source["agent"]["num_updates"] + 3
    assert not torch.equal(ckpt["agent"]["critic"]["q1_net.0.weight"],
                           source["agent"]["critic"]["q1_net.0.weight"])
    meta = ckpt["metadata"]
    assert meta["physics"] == "accurate" and meta["command"] == "refine"
    assert meta["refine_steps"] == 3 and meta["training_steps"] == TRAIN_STEPS
    assert json.loads((refined / "run.json").read_text())["physics"] == "accurate"


def test_refine_reports_a_stale_lock_it_takes_over(trained, tmp_path, capsys):
    import json
    import shutil
    import subprocess
    import sys

    from elastica_magnetic.cli import main as msr
    from elastica_magnetic.locks import host_name, lock_path

    run = tmp_path / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run, ignore=shutil.ignore_patterns("refined", "*.msr-lock"))
    (run / "refined").mkdir()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = {"pid": dead.pid, "host": host_name(), "command": "msr refine",
             "started_utc": "2026-01-01T00:00:00Z"}
    lock_path(run / "refined").write_text(json.dumps(stale))
    assert msr(["refine", str(run), "--checkpoint", "final", "--steps", "3", "--episode-duration", "0.02",
                "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert f"took over the stale lock of pid {dead.pid} on {host_name()} (`msr refine`" in err
    assert not lock_path(run / "refined").exists()


def test_refine_on_a_spec_with_other_physical_values_records_them(trained, tmp_path, capsys):
    """--spec: the run's robot with other physical values (as msr real identify writes it) is refined
    on that robot, the changes recorded; another robot (elements, task) is refused by name."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.cli import main as msr
    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["robot"]["magnetization"]["magnitude"] *= 0.9
    spec["robot"]["ground"]["kinetic_mu"] = 0.5
    identified = tmp_path / "identified.toml"
    identified.write_text(dumps(spec))
    run = trained / "m1-4mT" / "seed0"
    out = tmp_path / "refined"
    args = ["refine", str(run), "--checkpoint", "final", "--steps", "2", "--episode-duration", "0.02",
            "--no-progress"]
    assert msr([*args, "--out", str(out), "--spec", str(identified)]) == 0
    capsys.readouterr()
    record = json.loads((out / "run.json").read_text())
    assert record["spec_from"] == str(identified)
    nominal = load_case("m1-4mT").to_dict()["robot"]
    assert record["physical_changes"] == {
        "robot.ground.kinetic_mu": [nominal["ground"]["kinetic_mu"], 0.5],
        "robot.magnetization.magnitude": [nominal["magnetization"]["magnitude"],
                                          spec["robot"]["magnetization"]["magnitude"]]}
    magnitude = spec["robot"]["magnetization"]["magnitude"]
    assert record["case_spec"]["robot"]["magnetization"]["magnitude"] == magnitude
    assert record["case"] == "m1-4mT"
    other = load_case("m1-4mT").to_dict()
    other["robot"]["n_elements"] = 32
    bad = tmp_path / "other.toml"
    bad.write_text(dumps(other))
    assert msr([*args, "--out", str(tmp_path / "refused"), "--spec", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "robot.n_elements" in err and "only physical values" in err
    assert not (tmp_path / "refused").exists()


def test_refine_fine_tunes_on_randomized_robots_in_the_training_physics(trained, tmp_path, capsys):
    """--physics training --randomize default: the nominal run's agent continues on robots drawn
    from the default variation set (each crawler's draw in the checkpoint, not all nominal), the
    setting recorded; --randomize none on a nominal run keeps the nominal robot."""
    import numpy as np

    from elastica_magnetic.cli import main as msr

    run = trained / "m1-4mT" / "seed0"
    args = ["refine", str(run), "--checkpoint", "final", "--physics", "training", "--steps", "162",
            "--episode-duration", "0.04", "--no-progress"]
    out = tmp_path / "robust"
    assert msr([*args, "--randomize", "default", "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["physics"] == "training" and record["refine_randomize"] == "default"
    varied = record["case_spec"]["training"]["randomize"]
    assert varied == {"magnetization": "0.85:1.15", "modulus": "0.8:1.2", "friction": "0.75:1.25",
                      "density": "0.9:1.1"}
    ckpt = load_checkpoint(out)
    assert ckpt["global_step"] == TRAIN_STEPS + 162  # 40 episodes of 4 steps, 2 steps into the next
    assert ckpt["metadata"]["physics"] == "training"
    drawn = np.asarray(ckpt["vector"]["env_state"]["robot_settings"])  # the robot of that episode
    assert drawn.shape[1] == len(varied) and not np.allclose(drawn, 1.0)
    # the source run was nominal: without --randomize its refinement stays nominal
    assert msr([*args, "--steps", "2", "--out", str(tmp_path / "nominal")]) == 0
    nominal = json.loads((tmp_path / "nominal" / "run.json").read_text())
    assert "randomize" not in nominal["case_spec"].get("training", {})
    assert "refine_randomize" not in nominal
    capsys.readouterr()
    with pytest.raises(SystemExit) as exit_info:  # argparse's choices
        msr([*args, "--randomize", "corners", "--out", str(tmp_path / "bad")])
    assert exit_info.value.code == 2
    assert "--randomize: invalid choice: 'corners'" in capsys.readouterr().err


def test_refine_on_a_spec_applies_its_randomize_table_and_refuses_a_disagreeing_option(
        trained, tmp_path, capsys):
    """--spec with a [training.randomize] table: the refinement's robots are drawn from it (each
    crawler's draw in the checkpoint) and run.json records it; a --randomize that disagrees with
    the table is refused by name before any work."""
    import numpy as np
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.cli import main as msr
    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["robot"]["ground"]["kinetic_mu"] = 0.5
    spec["training"]["randomize"] = {"friction": "0.5:1.5"}
    identified = tmp_path / "identified.toml"
    identified.write_text(dumps(spec))
    run = trained / "m1-4mT" / "seed0"
    args = ["refine", str(run), "--checkpoint", "final", "--physics", "training", "--steps", "2",
            "--episode-duration", "0.04", "--no-progress", "--spec", str(identified)]
    out = tmp_path / "refined"
    assert msr([*args, "--out", str(out)]) == 0
    record = json.loads((out / "run.json").read_text())
    assert record["refine_randomize"] == "spec" and record["spec_from"] == str(identified)
    assert record["case_spec"]["training"]["randomize"] == {"friction": "0.5:1.5"}
    ckpt = load_checkpoint(out)
    assert ckpt["metadata"]["case_spec"]["training"]["randomize"] == {"friction": "0.5:1.5"}
    drawn = np.asarray(ckpt["vector"]["env_state"]["robot_settings"])  # mid-episode: saved
    assert drawn.shape[1] == 1 and not np.allclose(drawn, 1.0)
    capsys.readouterr()
    for option, meant in (("none", "the nominal robot"), ("default", "the default variation set")):
        assert msr([*args, "--randomize", option, "--out", str(tmp_path / option)]) == 2
        err = capsys.readouterr().err
        assert (f"msr refine: error: --spec {identified}: its [training.randomize] (friction = "
                f"'0.5:1.5') disagrees with --randomize {option} ({meant}") in err
        assert not (tmp_path / option).exists()


def test_a_refinement_inside_its_runs_warm_up_is_refused():
    from elastica_magnetic_rl.sweep.refine import _check_refinement_learns

    ckpt = {"global_step": 2000, "config": {"learning_starts": 2500}}
    with pytest.raises(ValueError, match=r"run/checkpoint.pt is at step 2000, inside its warm-up "
                                         r"\(learning_starts 2500.*--steps 500 ends it at step "
                                         r"2500; give --steps above 500"):
        _check_refinement_learns(ckpt, "run/checkpoint.pt", 500)
    _check_refinement_learns(ckpt, "run/checkpoint.pt", 501)
