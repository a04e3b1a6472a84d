"""Corrupted or mismatched policy files get an error naming the file (issue 15, item 7)."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.shipping.policy_files import (
    POLICIES_DIR,
    PolicyFileError,
    PolicyNotFoundError,
    read_policy_json,
    resolve_policy,
)

from elastica_magnetic.cli import main


@pytest.fixture
def folder(tmp_path):
    target = tmp_path / "m1"
    target.mkdir()
    for name in ("actor.pt", "critic.pt", "policy.json"):
        shutil.copy(POLICIES_DIR / "m1-4mT" / name, target / name)
    return target


def test_shipped_policies_carry_a_matching_checksum():
    for name in ("m1-4mT", "m2-4mT", "m1-10mT", "m2-10mT"):
        assert "actor_sha256" in json.loads((POLICIES_DIR / name / "policy.json").read_text())
        assert resolve_policy(name).case.name == name


@pytest.mark.parametrize("size", [0, 1000])
def test_empty_or_truncated_actor(folder, size):
    data = (folder / "actor.pt").read_bytes()
    (folder / "actor.pt").write_bytes(data[:size])
    with pytest.raises(PolicyFileError, match=r"actor\.pt: cannot be read as a torch file"):
        resolve_policy(folder)


def test_truncated_policy_json(folder):
    text = (folder / "policy.json").read_text()
    (folder / "policy.json").write_text(text[: len(text) // 2])
    with pytest.raises(PolicyFileError, match=r"policy\.json: not readable as JSON \(line \d+ "
                                              r"column \d+.*ship the policy again"):
        resolve_policy(folder)


def test_hidden_sizes_that_do_not_match_the_weights(folder):
    meta = json.loads((folder / "policy.json").read_text())
    meta["architecture"]["hidden_sizes"] = [128, 128]
    del meta["actor_sha256"]
    (folder / "policy.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyFileError, match=r"actor\.pt: the actor weights do not fit the "
                       r"architecture it declares \(observations 260, actions 2, "
                       r"hidden sizes \[128, 128\]\)"):
        resolve_policy(folder)


def test_actor_of_another_policy_is_refused(folder, capsys):
    shutil.copy(POLICIES_DIR / "m2-4mT" / "actor.pt", folder / "actor.pt")
    with pytest.raises(PolicyFileError, match=r"actor\.pt: its weights do not match the actor_sha256"):
        resolve_policy(folder)
    assert main(["policy", "export", str(folder), "--out", str(folder / "export")]) == 2
    assert "the files come from different policies" in capsys.readouterr().err
    assert not (folder / "export").exists()


def test_corrupted_checkpoint(tmp_path, capsys):
    (tmp_path / "checkpoint.pt").write_bytes(b"PK\x03\x04 not a checkpoint")
    with pytest.raises(PolicyFileError, match=r"checkpoint\.pt: cannot be read as a checkpoint"):
        resolve_policy(tmp_path)
    assert main(["policy", "generate", str(tmp_path), "--out", str(tmp_path / "g"), "--no-progress"]) == 2
    assert "checkpoint.pt: cannot be read as a checkpoint" in capsys.readouterr().err


def test_unknown_policy_is_a_clear_error(tmp_path):
    with pytest.raises(PolicyNotFoundError, match="shipped"):
        resolve_policy(tmp_path / "nothing-here")


def test_a_case_spec_that_contradicts_the_recorded_limits_is_refused(folder, capsys):
    meta = json.loads((folder / "policy.json").read_text())
    meta["case_spec"]["actuation"]["field_limit"] = 0.010  # edited: 10 mT, trained for 4 mT
    (folder / "policy.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyFileError, match=r"policy\.json: field_limit_T = 0\.004 but its "
                       r"case_spec gives 0\.01: the file contradicts itself"):
        resolve_policy(folder)
    assert main(["policy", "generate", str(folder), "--out", str(folder.parent / "gen"),
                 "--no-progress"]) == 2
    assert "contradicts itself" in capsys.readouterr().err
    assert not (folder.parent / "gen").exists()


def test_a_case_name_that_contradicts_the_case_spec_is_refused(folder, capsys):
    meta = json.loads((folder / "policy.json").read_text())
    meta["case"] = "m1-10mT"  # edited by hand: the case_spec (what the policy runs on) is m1-4mT's
    (folder / "policy.json").write_text(json.dumps(meta))
    assert main(["policy", "generate", str(folder), "--out", str(folder.parent / "gen"),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "policy.json: case = 'm1-10mT' but its case_spec is of case 'm1-4mT': the file contradicts " \
           "itself" in err, err
    assert not (folder.parent / "gen").exists()


@pytest.mark.parametrize("old", [0.0205, None])
def test_older_policy_json_keys_are_read_by_todays_names(folder, old):
    """Files shipped before the yardstick was named for what it is (``authors_mid_dx_10s_m``,
    ``None`` for a case without one) load, their yardstick read as ``yardstick_10s_m``."""
    path = folder / "policy.json"
    info = json.loads(path.read_text())
    info.pop("yardstick_10s_m", None)
    info.pop("yardstick_source", None)
    info["authors_mid_dx_10s_m"] = old
    path.write_text(json.dumps(info))
    read = read_policy_json(path)
    assert "authors_mid_dx_10s_m" not in read
    assert read.get("yardstick_10s_m") == old
    assert resolve_policy(folder).case.name == "m1-4mT"


@pytest.mark.parametrize("deleted, named", [
    (["policy.json"], "without policy.json"),
    (["actor.pt"], "without actor.pt"),
    (["actor.pt", "policy.json"], "without actor.pt and policy.json"),
])
def test_a_policy_folder_missing_a_file_names_it(folder, deleted, named, capsys):
    # issue 48 m8/m13: "not a run directory, checkpoint, shipped-policy folder or ..." before
    for name in deleted:
        (folder / name).unlink()
    with pytest.raises(PolicyNotFoundError, match=named):
        resolve_policy(folder)
    assert main(["policy", "generate", str(folder), "--physics", "training", "--duration", "0.02",
                 "--no-progress", "--out", str(folder.parent / "gen")]) == 2
    err = capsys.readouterr().err
    assert named in err and "critic.pt" in err and "not a run directory" not in err, err
    assert not (folder.parent / "gen").exists()


def test_an_empty_folder_is_still_not_a_policy(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(PolicyNotFoundError, match="not a run directory"):
        resolve_policy(tmp_path / "empty")


@pytest.mark.parametrize(("edit", "message"), [
    (lambda m: m.update(robot="yao2023-m2"), r"robot = 'yao2023-m2' but its case_spec"),
    (lambda m: m.update(task="reach"), r"task = 'reach' but its case_spec"),
    (lambda m: m["architecture"].update(activation="tanh"), r"architecture\.activation = 'tanh'"),
    (lambda m: m["observation"]["scales"].update(field_amplitude=0.2),
     r"observation\.scales\.field_amplitude = 0\.2 but its case_spec"),
    (lambda m: m.update(format="msr-policy-v9"), r"format 'msr-policy-v9' is not one this msr reads"),
], ids=["robot", "task", "activation", "scale", "format"])
def test_every_copy_of_the_case_spec_must_agree_with_it(edit, message, folder):
    """Edits of policy.json's copies of its case_spec ran as the unedited policy, without a word
    (round 4, S5), and an unknown format was read (S6)."""
    meta = json.loads((folder / "policy.json").read_text())
    assert "field_amplitude" in meta["observation"]["scales"]
    edit(meta)
    (folder / "policy.json").write_text(json.dumps(meta))
    with pytest.raises(PolicyFileError, match=message):
        resolve_policy(folder)
