"""``msr policy ship`` and ``msr policy notes`` (rl/shipping/ship.py), on the runs trained once for the
learning package's tests (tests/rl/conftest.py: ``trained``, ``refined``)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.shipping import policy_files, policy_runs, ship
from smoke import TRAIN_STEPS, run_msr

from elastica_magnetic.cli import main as msr


def test_layer_norm_recipe_trains_ships_and_loads_with_its_critic(tmp_path):
    """``--recipe pink-ln``: the critics get layer norms (checkpoint config), and the run and its
    shipped folder (``critic.pt``, ``policy.json``'s architecture) load back with them."""
    from elastica_magnetic_rl.shipping.policy_files import resolve_policy

    assert msr(["train", "--case", "m1-4mT", "--seeds", "1", "--out", str(tmp_path), "--steps", "20",
                "--set", "learning_starts=10", "--set", "batch_size=8", "--set", "hidden_sizes=8",
                "--set", "eval_duration=0.1", "--episode-duration", "0.1", "--no-progress",
                "--recipe", "pink-ln"]) == 0
    run = tmp_path / "m1-4mT" / "seed0"
    config = load_checkpoint(run)["config"]
    assert config["critic_layer_norm"] is True and config["noise_color"] == 1.0
    loaded = resolve_policy(run)
    assert isinstance(loaded.critic.q1_net[1], torch.nn.LayerNorm)
    ship.ship(run, "ln", dest=tmp_path / "shipped", measure=False, progress=False, with_card=False)
    meta = json.loads((tmp_path / "shipped" / "ln" / "policy.json").read_text())
    assert meta["architecture"]["critic_layer_norm"] is True
    again = resolve_policy(tmp_path / "shipped" / "ln")
    for a, b in zip(again.critic.state_dict().values(), loaded.critic.state_dict().values(),
                    strict=True):
        assert torch.equal(a, b)


def test_ship_evaluates_every_seed_and_caches(refined, tmp_path, monkeypatch):
    """``evaluate_all_seeds``: each seed's final checkpoint is rolled out (accurate physics, zero
    field); the card lists them with the notes; a second ship reuses the per-seed cache."""
    info = ship.ship(refined, "m1-4mT", dest=tmp_path, measure=False, duration=0.05,
                         progress=False, evaluate_all_seeds=True, notes="Trained by a *test*.")
    meta = json.loads((tmp_path / "m1-4mT" / "policy.json").read_text())
    evaluations = meta["seeds"]["evaluations"]
    assert [e["seed"] for e in evaluations] == [0, 1] and info["evaluation"] is None
    assert all(e["global_step"] == TRAIN_STEPS and e["duration_s"] == 0.05 for e in evaluations)
    assert all("meets_target" not in e for e in evaluations)  # 0.05 s: not the 10 s criterion
    assert meta["seeds"]["meeting_target"] is None  # no verdict, so no count
    assert evaluations[0]["mid_dx_m"] != evaluations[1]["mid_dx_m"]  # two different actors
    for e in evaluations:  # and each seed's best.pt, with its own step
        best = load_checkpoint(refined.parent.parent / f"seed{e['seed']}" / "best.pt")
        assert e["best"]["global_step"] == best["global_step"]
        assert e["best"]["duration_s"] == 0.05 and "meets_target" not in e["best"]
    card = (tmp_path / "m1-4mT" / "MODEL_CARD.md").read_text()
    assert "| 0 | 240 |" in card and "| 1 | 240 |" in card and "best.pt" in card
    assert "## Notes" in card and "Trained by a *test*." in card
    cache = refined.parent / "evaluation.json"  # seed0/evaluation.json
    assert json.loads(cache.read_text())["mid_dx_m"] == evaluations[0]["mid_dx_m"]

    def no_rollout(*args, **kwargs):
        raise AssertionError("the cached evaluation should have been reused")

    monkeypatch.setattr(policy_runs, "run_policy", no_rollout)
    again = policy_runs.evaluate_seeds(refined.parent.parent, duration=0.05, progress=False)
    assert again == evaluations
    # shipping the best actor of a seed says so on the card
    ship.ship(refined.parent / "best.pt", "m1-4mT-best", dest=tmp_path, measure=False)
    card = (tmp_path / "m1-4mT-best" / "MODEL_CARD.md").read_text()
    assert "best.pt" in card and "the best of the evaluations during training" in card


def test_ship_over_a_policy_keeps_it_when_the_measurement_fails(refined, tmp_path, monkeypatch):
    """``ship --force`` computes everything before it writes: a measurement that fails (or is
    interrupted) leaves the policy it was to replace byte for byte as it was; one that succeeds
    replaces it, and the old waveform does not outlive its actor."""
    dest = tmp_path / "policies"
    ship.ship(refined, "m1-4mT", dest=dest, measure=True, duration=0.03, progress=False)
    folder = dest / "m1-4mT"
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert "fields.csv" in before

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(ship, "run_policy", interrupted)
    best = refined.parent / "best.pt"  # another actor
    with pytest.raises(KeyboardInterrupt):
        ship.ship(best, "m1-4mT", dest=dest, overwrite=True, progress=False)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    # replaced without a measurement: the replaced policy's fields.csv goes with it
    ship.ship(best, "m1-4mT", dest=dest, overwrite=True, measure=False, progress=False)
    assert not (folder / "fields.csv").exists()
    assert json.loads((folder / "policy.json").read_text())["training"]["best_evaluation"]
    assert policy_files.resolve_policy(folder).kind == "shipped"  # the new files belong together


def test_ship_then_generate_by_folder_and_name(refined, tmp_path, monkeypatch, capsys):
    dest = tmp_path / "policies"
    info = ship.ship(refined, "m1-4mT", dest=dest, measure=True, duration=0.05, progress=False)
    folder = dest / "m1-4mT"
    assert {"actor.pt", "critic.pt", "policy.json", "MODEL_CARD.md", "fields.csv"} <= set(info["files"])
    meta = json.loads((folder / "policy.json").read_text())
    assert meta["case"] == "m1-4mT" and meta["architecture"]["hidden_sizes"] == [32, 32]
    # the yardstick is named for what it is, with its source; no label of the paper's robot
    assert meta["yardstick_10s_m"] == 0.0205 and "authors" in meta["yardstick_source"]
    assert "authors_mid_dx_10s_m" not in meta
    ev = meta["evaluation"]
    assert (ev["physics"], ev["initial_field"]) == ("accurate", "zero")
    assert ev["duration_s"] == pytest.approx(0.05)
    actor_state = torch.load(folder / "actor.pt", weights_only=True)
    assert meta["actor_sha256"] == policy_files.weights_sha256(actor_state)
    assert meta["training"]["refine_steps"] == 3 and meta["seeds"]["total"] == 2
    assert meta["training"]["refine_physics"] == "accurate"  # the refinement's own run.json says so
    card = (folder / "MODEL_CARD.md").read_text()
    assert "m1-4mT" in card and "refinement steps" in card and "seeds that succeeded" in card
    # the shipped actor acts exactly as the checkpoint's
    obs = np.random.default_rng(1).normal(size=260).astype(np.float32)
    shipped = policy_files.resolve_policy(folder)
    original = policy_files.resolve_policy(refined)
    np.testing.assert_array_equal(shipped.act(obs), original.act(obs))
    # by name, from the (patched) package folder of shipped policies

    monkeypatch.setattr(policy_files, "POLICIES_DIR", dest)
    result = run_msr(capsys, "policy", "generate", "m1-4mT", "--duration", "0.03", "--out",
                     str(tmp_path / "gen"), "--no-progress", "--no-gif")
    assert result["policy"] == str(folder) and "q_values" in result["figures"]
    with pytest.raises(FileExistsError):
        ship.ship(refined, "m1-4mT", dest=dest, measure=False)


def test_notes_have_one_home_and_a_re_ship_keeps_the_seeds_table(refined, tmp_path, capsys):
    """A policy's notes live in policy.json and the card's Notes section is rendered from them:
    ``msr policy notes`` changes both together and nothing else; ``ship --force`` keeps the table of
    the case's committed seeds (``msr policy seeds --card``) in the new card."""
    from elastica_magnetic_rl.shipping.model_card import NOTES_SECTION, card_section
    from elastica_magnetic_rl.shipping.seed_report import CARD_SECTION

    dest = tmp_path / "policies"
    ship.ship(refined, "m1-4mT", dest=dest, measure=False, progress=False, notes="First.")
    folder = dest / "m1-4mT"
    seeds = folder / "seeds" / "paper" / "seeds.json"
    seeds.parent.mkdir(parents=True)
    seeds.write_text(json.dumps([{"seed": 0, "steps": 240, "distance_10s_m": 0.0221, "actor": "seed0"},
                                 {"seed": 1, "steps": 240, "distance_10s_m": 0.0018, "actor": "seed1"}]))
    ship.ship(refined.parent / "best.pt", "m1-4mT", dest=dest, overwrite=True, measure=False,
                  progress=False, notes="Second.")
    card = (folder / "MODEL_CARD.md").read_text()
    assert "| `paper` | 1 of 2 |" in card and card.index(CARD_SECTION) < card.index("## Evaluation")
    assert card_section(card, NOTES_SECTION) == "Second."

    actor = (folder / "actor.pt").read_bytes()
    new_notes = tmp_path / "notes.md"
    new_notes.write_text("- Third, *edited*.\n\n")
    assert msr(["policy", "notes", str(folder), "--file", str(new_notes)]) == 0
    info = json.loads((folder / "policy.json").read_text())
    card = (folder / "MODEL_CARD.md").read_text()
    assert info["notes"] == card_section(card, NOTES_SECTION) == "- Third, *edited*."
    assert card.count(NOTES_SECTION) == 1 and card.index(NOTES_SECTION) < card.index("## Limitations")
    assert "| `paper` | 1 of 2 |" in card and (folder / "actor.pt").read_bytes() == actor
    assert policy_files.resolve_policy(folder).kind == "shipped"
    capsys.readouterr()
    assert msr(["policy", "notes",
                str(folder)]) == 0 and capsys.readouterr().out.strip() == "- Third, *edited*."
    new_notes.write_text("\n")  # an empty file is refused (more often a mistake); --clear removes
    assert msr(["policy", "notes", str(folder), "--file", str(new_notes)]) == 2
    assert msr(["policy", "notes", str(folder), "--clear"]) == 0
    assert json.loads((folder / "policy.json").read_text())["notes"] is None
    new_notes.write_text("- Fourth.\n")
    assert NOTES_SECTION not in (folder / "MODEL_CARD.md").read_text()
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    assert msr(["policy", "notes", str(refined), "--file", str(new_notes)]) == 2  # a run has no notes
    assert "shipped policy" in capsys.readouterr().err
    assert msr(["policy", "notes", str(folder), "--file", str(tmp_path / "missing.md")]) == 2
    assert "missing.md: no such file" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()} == before


def test_a_case_without_a_yardstick_ships_none():
    from elastica_magnetic_rl.cases.case import case_from_dict, load_case

    spec = load_case("m1-4mT").to_dict()
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    mine = case_from_dict(spec, "mine.toml", default_name="mine")
    assert ship._yardstick_info(mine) == {}
    assert ship._yardstick_info(load_case("m1-4mT"))["yardstick_10s_m"] == 0.0205


def test_the_card_of_a_case_without_a_yardstick_counts_no_seed():
    """Issue 34: for a case without a yardstick, ``meeting_target`` is None and every seed's
    verdict on the card is "n/a", also from an older file's ``meets_target: true``."""
    from elastica_magnetic_rl.cases.case import case_from_dict, load_case
    from elastica_magnetic_rl.shipping.model_card import _seeds_section, seed_meets_target

    spec = load_case("m1-4mT").to_dict()
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    mine = case_from_dict(spec, "mine.toml", default_name="mine")
    base = {"global_step": 100, "duration_s": 10.0, "physics": "accurate", "initial_field": "zero",
            "node_dx_m": 0.03, "diverged": None}
    old = [{"seed": 0, **base, "mid_dx_m": 0.03, "meets_target": True,
            "best": {**base, "mid_dx_m": 0.031, "meets_target": True}},
           {"seed": 1, **base, "mid_dx_m": 0.001, "meets_target": True, "best": None}]
    assert [seed_meets_target(e, mine) for e in old] == [None, None]
    assert ship._meeting_target(old, mine) is None
    card = "\n".join(_seeds_section({"seeds": {"evaluations": old, "meeting_target": 2}}, mine))
    assert "| n/a |" in card and "| yes |" not in card and "2 of 2" not in card
    assert "no seed is judged" in card
    # with a yardstick the same distances are judged: +30 mm and +1 mm against +20.5 mm
    paper = load_case("m1-4mT")
    fresh = [{k: v for k, v in e.items() if k != "meets_target"} | {"meets_target": e["mid_dx_m"] >= 0.0205}
             for e in old]
    assert [seed_meets_target(e, paper) for e in fresh] == [True, False]
    assert ship._meeting_target(fresh, paper) == 1


def test_the_card_says_where_a_refinement_ran_and_on_which_robots():
    """A policy fine-tuned in the training physics on randomized robots (``msr refine --physics
    training --randomize default``) must not be described as refined in the accurate physics nor
    as trained for one robot; an older policy.json without ``refine_physics`` was refined in the
    accurate physics."""
    from elastica_magnetic_rl.cases.case import load_case, with_randomize
    from elastica_magnetic_rl.cases.variations import default_variations
    from elastica_magnetic_rl.shipping.model_card import model_card

    case = load_case("m1-10mT")
    info = json.loads((policy_files.POLICIES_DIR / "m1-10mT" / "policy.json").read_text())
    older = model_card(info, None, case)
    assert "refinement steps (accurate physics, dt 8e-06 s): 0" in older
    assert "Trained for one robot" in older and "drawn per episode" not in older
    info["training"].update(refine_physics="training", refine_steps=10000)
    randomized = with_randomize(case, tuple(default_variations(case.robot.tables)))
    card = model_card(info, None, randomized)
    assert "refinement steps (training physics, dt 0.0001 s): 10000" in card
    assert "Trained for one robot" not in card
    assert "magnetization 0.85:1.15" in card and "friction 0.75:1.25" in card


def test_a_best_pt_holding_the_final_actor_is_not_rolled_out_twice(trained, tmp_path, monkeypatch):
    """``evaluate_run``: when ``best.pt`` holds the final actor (same step and weights: a seed
    stopped right after its best evaluation), its evaluation is the final one's, one rollout;
    a ``best.pt`` with other weights is rolled out on its own."""
    import shutil

    run = tmp_path / "seed0"
    shutil.copytree(trained / "m1-4mT" / "seed0", run)
    shutil.copyfile(run / "checkpoint.pt", run / "best.pt")
    (run / "evaluation.json").unlink(missing_ok=True)
    calls = []
    real = policy_runs.run_policy
    monkeypatch.setattr(policy_runs, "run_policy", lambda *a, **k: calls.append(1) or real(*a, **k))
    final, best = policy_runs.evaluate_run(run, duration=0.05, progress=False)
    assert len(calls) == 1 and best == final

    other = torch.load(run / "best.pt", weights_only=False)  # same step, one weight changed
    actor = other["agent"]["actor"]
    name = next(iter(actor))
    actor[name] = actor[name] + 1.0
    torch.save(other, run / "best.pt")
    (run / "evaluation.json").unlink()
    calls.clear()
    policy_runs.evaluate_run(run, duration=0.05, progress=False)
    assert len(calls) == 2


@pytest.mark.parametrize("name", ["my pol", "../x", ".hidden", "-dash", "a/b", ""])
def test_a_policy_name_must_be_one_plain_folder_name(name):
    """A name with a space was accepted (round 4, S11) though the rule excludes it."""
    from elastica_magnetic_rl.shipping.ship import check_policy_name

    with pytest.raises(ValueError, match=r"--name .*: a policy name is one folder name of letters"):
        check_policy_name(name)
    assert check_policy_name("m1-4mT-robust_v2.1") == "m1-4mT-robust_v2.1"


def test_notes_with_headings_are_replaced_and_cleared_whole():
    """Round 9, S2: a "## " heading in the notes ended the card's Notes section early, so a later
    notes --file or --clear left the old text in MODEL_CARD.md (the card and policy.json then
    disagreed)."""
    from elastica_magnetic_rl.shipping.model_card import card_section, replace_card_section

    card = "# Card\n\n## Evaluation\n\nok\n\n## Limitations\n\nnone\n"
    notes = "First.\n\n## Bench details\n\nRun with coil set B (OLD DETAIL).\n\n### Deeper\n\nx"
    card = replace_card_section(card, "## Notes", notes, before="## Limitations")
    assert card_section(card, "## Notes") == notes
    assert "\n## Bench details" not in card and "#### Bench details" in card
    card = replace_card_section(card, "## Notes", "Second.", before="## Limitations")
    assert "OLD DETAIL" not in card and card_section(card, "## Notes") == "Second."
    card = replace_card_section(card, "## Notes", notes, before="## Limitations")
    card = replace_card_section(card, "## Notes", None, before="## Limitations")
    assert "OLD DETAIL" not in card and "Deeper" not in card and "## Limitations\n\nnone" in card
