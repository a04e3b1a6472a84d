"""Round 23 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-third round of tries")."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.variations import (
    VariationError,
    parse_variation,
    resolve_variations,
    variable_keys,
)
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from elastica_magnetic_rl.shipping.tip_reach import target_notes
from elastica_magnetic_rl.td3.config import TD3Config

from elastica_magnetic.batch import BatchedPhysicsNotSupportedError, BatchedRobots
from elastica_magnetic.cli import main as msr


def _spec_with(tmp_path, name: str, extra: str = "", replace: tuple[str, str] | None = None):
    """The m1-4mT case as a spec file ``name`` with ``extra`` appended (and one text replaced)."""
    text = load_case("m1-4mT").toml()
    if replace is not None:
        assert replace[0] in text
        text = text.replace(*replace)
    path = tmp_path / name
    path.write_text(text.replace('name = "m1-4mT"', f'name = "{path.stem}"') + extra)
    return path


def _status(args: list[str]) -> int:
    """``msr`` 's exit status, also where argparse refuses an argument (it exits)."""
    try:
        return msr(args)
    except SystemExit as stop:
        return int(stop.code)


INTERACTION = "\n[robot.interaction]\nself_contact_stiffness = 40.0\nself_contact_damping = 0.004\n"
VISCOUS = ("kelvin_voigt = 0.0", "kelvin_voigt = 5.0")


def test_notes_keep_an_edited_card_and_record_the_weights_of_a_policy_copied_without_its_record(
        catheter_run, tmp_path, capsys):
    """D1: ``msr policy notes`` on a policy copied without ``.msr-files.json`` rewrote an edited card
    and recorded it (and policy.json) as msr's, the weights not: ``ship --force`` then called the
    weights not msr's, and once they were moved as told, replaced the edited card. Now the
    unrecorded card is refused by name (kept), and notes record every file of the policy."""
    assert msr(["policy", "ship", str(catheter_run), "--name", "p", "--out", str(tmp_path / "pols"),
                "--no-measure", "--checkpoint", "final", "--no-progress"]) == 0, capsys.readouterr().err
    copy = tmp_path / "copy" / "p"
    copy.mkdir(parents=True)
    for f in (tmp_path / "pols" / "p").iterdir():
        if not f.name.startswith("."):
            shutil.copy(f, copy / f.name)
    with (copy / "MODEL_CARD.md").open("a") as handle:
        handle.write("my edit\n")
    notes = tmp_path / "notes.md"
    notes.write_text("# n\nx\n")
    capsys.readouterr()
    assert msr(["policy", "notes", str(copy), "--file", str(notes)]) == 2
    err = capsys.readouterr().err
    assert "MODEL_CARD.md has no record of being written by msr" in err and "move it away" in err, err
    assert "my edit" in (copy / "MODEL_CARD.md").read_text()
    assert not (copy / ".msr-files.json").exists()
    (copy / "MODEL_CARD.md").rename(tmp_path / "my_card.md")
    assert msr(["policy", "notes", str(copy), "--file", str(notes)]) == 0, capsys.readouterr().err
    recorded = json.loads((copy / ".msr-files.json").read_text())["files"]
    assert {"actor.pt", "critic.pt", "policy.json"} <= set(recorded), recorded
    capsys.readouterr()
    assert msr(["policy", "ship", str(catheter_run), "--name", "p", "--out", str(tmp_path / "copy"),
                "--no-measure", "--checkpoint", "final", "--force", "--no-progress"]) == 0, (
        capsys.readouterr().err)


@pytest.mark.parametrize("extra, replace, named", [
    (INTERACTION, None, "[robot.interaction]"),
    ("", VISCOUS, "[robot.damping] kelvin_voigt = 5 Pa s"),
])
def test_physics_the_batched_simulator_does_not_model_is_refused_not_dropped(tmp_path, capsys, extra, replace,
                                                                            named):
    """S1: ``msr train`` (and every command on the batched simulator) trained a spec with
    ``[robot.interaction]`` or a Kelvin-Voigt viscosity bit for bit as the spec without it, while
    run.json recorded them. Now the simulator refuses them by name, and train, design and loop
    before any work."""
    spec = _spec_with(tmp_path, "mine.toml", extra, replace)
    case = load_case(spec)
    with pytest.raises(BatchedPhysicsNotSupportedError, match=named.replace("[", r"\[").replace("]", r"\]")):
        BatchedRobots(case.robot_spec("training"), 2)
    plain = BatchedRobots(load_case("m1-4mT").robot_spec("training"), 2)
    with pytest.raises(BatchedPhysicsNotSupportedError, match="robot 1"):
        plain.set_robot(1, case.robot_spec("training"))
    for command in (["train", "--case", str(spec), "--seeds", "1", "--steps", "100"],
                    ["design", str(spec), "--minutes", "1"], ["loop", str(spec), "--quick"]):
        out = tmp_path / command[0]
        assert _status([*command, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert named in err and "does not model" in err and f"msr {command[0]}" in err, err
        assert not out.exists()


def test_a_direction_is_not_varied(capsys):
    """S2: ``--vary robot.magnetization.direction=0.5:1.5`` was offered and accepted, and every
    variant was the nominal robot (a direction is made a unit vector when read). Now refused
    by name, and not among the variable keys."""
    spec = load_case("catheter-magnet-reach").to_dict()
    assert not [key for key in variable_keys(spec) if key.endswith(".direction")]
    with pytest.raises(VariationError, match=r"robot.magnetization.direction is a direction.*varies|nominal"):
        resolve_variations([parse_variation("robot.magnetization.direction=0.5:1.5")], spec)
    designed = load_case("rl/policies/m1-4mT-designed/design/best.toml").to_dict()  # segments with directions
    assert not [key for key in variable_keys(designed) if key.endswith(".direction")]
    assert "robot.magnetization.segments.0.magnitude" in variable_keys(designed)


def test_a_tip_reach_target_at_the_straight_tip_is_noted(tmp_path, capsys):
    """S3: a ``--target`` within the tolerance of the straight tip at the start was a success
    after 0.01 s without a word (a goto target there is warned about). Now noted."""
    case = load_case("catheter-magnet-reach")
    notes = target_notes(case, [[0.0502, 0.0, 0.0], [0.045, 0.005, 0.0]])
    assert len(notes) == 1 and "within the 1 mm tolerance of the straight tip at the start" in notes[0]
    out = tmp_path / "b"
    assert msr(["field", "baseline", "--case", "catheter-magnet-reach", "--target", "0.0502,0,0",
                "--duration", "0.02", "--physics", "training", "--no-figures", "--out", str(out)]) == 0
    assert "a catheter left alone succeeds there" in capsys.readouterr().err


@pytest.mark.parametrize("option", [["--out", "vs"], ["--force"]])
def test_validate_shipped_alone_refuses_an_option_it_cannot_use(tmp_path, capsys, monkeypatch, option):
    """S4: ``msr validate shipped --out DIR`` exited 0 and wrote nothing to DIR. Now refused before
    the policies are re-run, naming the option."""
    monkeypatch.chdir(tmp_path)
    assert msr(["validate", "shipped", "--quick", *option]) == 2
    err = capsys.readouterr().err
    assert f"{option[0]}: msr validate shipped alone writes no report" in err, err
    assert not (tmp_path / "vs").exists()


def test_a_result_of_another_case_is_refused_in_a_policy_s_seeds(tmp_path, capsys):
    """S5: ``msr policy export`` of the m2-4mT policy went into the catheter policy's ``seeds/``
    (export-seeds refuses it). Now every result writer refuses another case's result there."""
    policy = tmp_path / "catheter-magnet-reach"
    shutil.copytree(POLICIES_DIR / "catheter-magnet-reach", policy,
                    ignore=shutil.ignore_patterns("seeds"))
    for command in (["policy", "export", "m2-4mT"], ["policy", "generate", "m2-4mT", "--duration", "0.02",
                                                     "--physics", "training", "--no-figures"]):
        out = policy / "seeds" / command[1]
        assert msr([*command, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert "of case 'catheter-magnet-reach', and this result is of case 'm2-4mT'" in err, err
        assert not (policy / "seeds").exists()


def test_ship_of_a_tip_reach_run_takes_its_best_actor_by_default(catheter_run, tmp_path, capsys):
    """V1: ``msr policy ship RUN`` of a catheter run (``--checkpoint auto``) was refused as a command
    that "does not apply" (auto measured the actors' 10 s distance in a uniform field). Now auto is
    the run's best.pt (its final actor without one), as ``msr policy generate`` takes it."""
    assert msr(["policy", "ship", str(catheter_run), "--name", "c", "--out", str(tmp_path / "s"),
                "--duration", "0.02", "--no-progress", "--json"]) == 0, capsys.readouterr().err
    result = json.loads(capsys.readouterr().out)
    chosen = "best" if (catheter_run / "best.pt").is_file() else "final"
    assert result["actor_choice"]["actor"] == chosen, result["actor_choice"]
    info = json.loads((tmp_path / "s" / "c" / "policy.json").read_text())
    assert info["evaluation"]["tip_reach"]["policy"]["targets_m"]


def test_a_buffer_size_is_judged_with_the_run_s_own_minibatch(tmp_path, capsys):
    """V2: ``--set buffer_size=200`` was refused against TD3's default minibatch of 256, where the
    fast recipe's is 128 (and the same values in a spec were accepted). Now judged with the run's."""
    assert TD3Config.parse_setting("buffer_size", "200") == 200
    with pytest.raises(ValueError, match="buffer_size=0"):
        TD3Config.parse_setting("buffer_size", "0")
    out = tmp_path / "r"
    assert msr(["train", "--case", "m1-4mT", "--recipe", "fast", "--seeds", "1", "--steps", "300", "--set",
                "buffer_size=100", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "buffer_size (100) must be >= batch_size (128)" in err and not out.exists(), err
    assert np.isfinite(TD3Config.parse_setting("batch_size", "128"))
