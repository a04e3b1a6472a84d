"""``msr policy seeds``: every committed seed of a case by recipe, judged by the case's own test."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.shipping.seed_report import (
    CARD_SECTION,
    case_seeds,
    learning_curves_by_recipe,
    update_model_card,
)

from elastica_magnetic.cli import main as msr


def _write_seeds(root: Path, case: str, folder: str, distances: dict[int, float], **extra) -> None:
    path = root / case / "seeds" / folder / "seeds.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps([{"seed": s, "steps": 100000, "distance_10s_m": d,
                                 "actor": f"seed{s}", **extra} for s, d in distances.items()]))


def test_seeds_are_judged_by_the_case_yardstick_paper_recipe_first(tmp_path):
    case = load_case("m1-4mT")  # +20.5 mm in 10 s
    _write_seeds(tmp_path, "m1-4mT", "pink", {1: 0.0204, 0: 0.0205})
    _write_seeds(tmp_path, "m1-4mT", "paper", {0: 0.0221, 1: 0.0018, 2: 0.0300})
    groups = case_seeds(case, tmp_path)
    assert [g.folder for g in groups] == ["paper", "pink"]
    assert groups[0].succeeded == [True, False, True] and groups[0].summary == "2 of 3"
    assert [e["seed"] for e in groups[1].entries] == [0, 1]  # ordered by seed
    assert groups[1].succeeded == [True, False]  # 20.5 mm meets the target, 20.4 mm does not


def test_a_reach_case_needs_the_stored_verdicts(tmp_path):
    case = load_case("m1-4mT-reach")
    _write_seeds(tmp_path, "m1-4mT-reach", "paper", {0: 0.0094})
    with pytest.raises(ValueError, match="meets_target"):
        case_seeds(case, tmp_path)
    _write_seeds(tmp_path, "m1-4mT-reach", "paper", {0: 0.0094}, meets_target=True)
    assert case_seeds(case, tmp_path)[0].succeeded == [True]


def test_msr_seeds_prints_draws_and_keeps_the_model_card_current(tmp_path, capsys):
    _write_seeds(tmp_path, "m1-4mT", "paper", {0: 0.0221, 1: 0.0018})
    card = tmp_path / "m1-4mT" / "MODEL_CARD.md"
    card.write_text("# Model card\n\n## Training\n\n- seed: 0\n\n## Evaluation (accurate)\n\n- +22.1 mm\n")
    capsys.readouterr()
    assert msr(["policy", "seeds", "m1-4mT", "--policies", str(tmp_path), "--figure", str(tmp_path / "fig"),
                "--card", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["cases"][0]
    assert report["recipes"][0]["succeeded"] == 1 and report["card_updated"] is True
    assert (tmp_path / "fig" / "seeds_m1-4mT.png").stat().st_size > 1000
    assert "learning_curves" not in report  # no seed kept its training log
    text = card.read_text()
    assert text.index(CARD_SECTION) < text.index("## Evaluation") and "| `paper` | 1 of 2 |" in text
    # a new seed replaces the section, which stays single; an unchanged table leaves the card alone
    _write_seeds(tmp_path, "m1-4mT", "paper", {0: 0.0221, 1: 0.0018, 2: 0.0230})
    case = load_case("m1-4mT")
    assert update_model_card(card, case, case_seeds(case, tmp_path)) is True
    text = card.read_text()
    assert text.count(CARD_SECTION) == 1 and "| `paper` | 2 of 3 |" in text and "- +22.1 mm" in text
    assert update_model_card(card, case, case_seeds(case, tmp_path)) is False
    # another policy of the case (say m1-4mT-robust) carries the same table; another case's does not
    for name, its_case in (("m1-4mT-robust", "m1-4mT"), ("m2-4mT", "m2-4mT")):
        (tmp_path / name).mkdir()
        (tmp_path / name / "policy.json").write_text(json.dumps(
            {"case": its_case, "architecture": {"obs_dim": 260, "act_dim": 2, "hidden_sizes": [8]}}))
        (tmp_path / name / "MODEL_CARD.md").write_text(f"# {name}\n\n## Evaluation (accurate)\n")
    capsys.readouterr()
    assert msr(["policy", "seeds", "m1-4mT", "--policies", str(tmp_path), "--card", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)["cases"][0]
    assert report["cards"] == [str(card), str(tmp_path / "m1-4mT-robust" / "MODEL_CARD.md")]
    assert report["card_updated"] is True
    assert "| `paper` | 2 of 3 |" in (tmp_path / "m1-4mT-robust" / "MODEL_CARD.md").read_text()
    assert CARD_SECTION not in (tmp_path / "m2-4mT" / "MODEL_CARD.md").read_text()


def test_msr_seeds_names_a_broken_seeds_file(tmp_path, capsys):
    path = tmp_path / "m1-4mT" / "seeds" / "paper" / "seeds.json"
    path.parent.mkdir(parents=True)
    path.write_text('[{"seed": 0}]')
    assert msr(["policy", "seeds", "m1-4mT", "--policies", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "distance_10s_m" in err


def test_the_shipped_seed_folders_read():
    """Every committed seeds.json of a shipped case reads and has an actor folder per seed."""
    from elastica_magnetic_rl.cases.case import case_names
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    for name in case_names():
        for group in case_seeds(load_case(name)):
            for entry in group.entries:
                folder = POLICIES_DIR / name / "seeds" / group.folder / entry["actor"]
                assert (folder / "actor.pt").is_file() and (folder / "policy.json").is_file()


def test_learning_curves_come_from_the_logs_the_exported_seeds_keep(tmp_path):
    case = load_case("m1-4mT")
    _write_seeds(tmp_path, "m1-4mT", "paper", {0: 0.0221, 1: 0.0018})
    _write_seeds(tmp_path, "m1-4mT", "pink", {0: 0.0230})
    assert learning_curves_by_recipe(case, case_seeds(case, tmp_path), tmp_path / "c.png") is None
    log = tmp_path / "m1-4mT" / "seeds" / "paper" / "seed0" / "episodes.csv"
    log.parent.mkdir(parents=True)
    log.write_text("episode,global_step,return,length,terminated,truncated,wall_time_s\n"
                   + "".join(f"{i},{2000 * (i + 1)},{10.0 * i},2000,0,1,{i}.0\n" for i in range(10)))
    out = learning_curves_by_recipe(case, case_seeds(case, tmp_path), tmp_path / "c.png")
    assert out == tmp_path / "c.png" and out.stat().st_size > 1000


def test_the_recipes_table_across_cases(tmp_path, capsys):
    """One row per recipe folder with its change from the paper's recipe, one column per case."""
    _write_seeds(tmp_path, "m1-4mT", "paper", {0: 0.0221, 1: 0.0018})
    _write_seeds(tmp_path, "m1-4mT", "pink-ln", {0: 0.0221})
    _write_seeds(tmp_path, "m1-10mT", "paper", {0: 0.170, 1: 0.019, 2: 0.150})
    capsys.readouterr()
    assert msr(["policy", "seeds", "m1-4mT", "m1-10mT", "--policies", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    table = out[out.index("## Recipes across the cases"):]
    assert "| recipe (folder) | change from the paper's | m1-4mT | m1-10mT |" in table
    assert "| `paper` | none (the authors' settings) | 1 of 2 | 2 of 3 |" in table
    assert ("| `pink-ln` | `noise_color = 1.0`, `noise_horizon = 2000`, `critic_layer_norm = True` "
            "| 1 of 1 |  |") in table


def test_every_shipped_card_is_current_with_its_policy_and_seeds(tmp_path):
    """A shipped card's Notes are its policy.json's notes, and its seeds table is the one the
    committed seeds.json give (``msr policy seeds --card`` would not change it)."""
    import shutil

    from elastica_magnetic_rl.shipping.model_card import NOTES_SECTION, card_section
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

    folders = sorted(p.parent for p in POLICIES_DIR.glob("*/MODEL_CARD.md"))
    assert len(folders) >= 4
    for folder in folders:
        info = json.loads((folder / "policy.json").read_text())
        card = (folder / "MODEL_CARD.md").read_text()
        assert card_section(card, NOTES_SECTION) == ((info.get("notes") or "").strip() or None), folder
        case = load_case(info["case"])
        groups = case_seeds(case)
        if groups:
            copy = tmp_path / f"{folder.name}.md"
            shutil.copy(folder / "MODEL_CARD.md", copy)
            assert update_model_card(copy, case, groups) is False, f"{folder}: run msr policy seeds --card"


def test_absent_seeds_say_where_they_are_and_leave_the_card(tmp_path, monkeypatch, capsys):
    from elastica_magnetic_rl.shipping import seed_report

    # an installed package: its policies folder holds the shipped policy, not its seeds/
    installed = tmp_path / "site" / "policies"
    (installed / "m1-4mT").mkdir(parents=True)
    card = installed / "m1-4mT" / "MODEL_CARD.md"
    card.write_text(f"# Model card\n\n{CARD_SECTION}\n\n| `paper` | 5 of 8 | ... |\n\n## Evaluation\n")
    monkeypatch.setattr(seed_report, "POLICIES_DIR", installed)
    case = load_case("m1-4mT")
    message = seed_report.no_seeds_message(case, installed)
    assert "repository" in message and "--policies <clone>/rl/policies" in message
    mine = tmp_path / "mine"
    assert "msr policy export-seeds" in seed_report.no_seeds_message(case, mine)  # a folder of the user's
    assert msr(["policy", "seeds", "m1-4mT", "--policies", str(installed)]) == 0
    assert "--policies <clone>/rl/policies" in capsys.readouterr().out
    before = card.read_text()
    assert msr(["policy", "seeds", "m1-4mT", "--policies", str(installed), "--card"]) == 2
    assert "left as it is" in capsys.readouterr().err and card.read_text() == before
    with pytest.raises(ValueError, match="left as it is"):
        update_model_card(card, case, [])


def _no_yardstick_case():
    from elastica_magnetic_rl.cases.case import case_from_dict

    spec = load_case("m1-4mT").to_dict() | {"name": "nostick"}
    spec["yardstick"] = {"distance_10s": 0.0, "source": ""}
    return case_from_dict(spec, "nostick.toml")


def test_seeds_of_a_case_without_a_yardstick_are_not_judged(tmp_path):
    """Issue 34: no success count for a case without a yardstick, even from an older seeds.json
    that stored ``meets_target: true`` for every seed that moved."""
    from elastica_magnetic_rl.shipping.seed_report import recipes_markdown, seeds_figure, seeds_markdown

    case = _no_yardstick_case()
    _write_seeds(tmp_path, "nostick", "paper", {0: 0.0339, 1: 0.0001}, meets_target=True)
    (group,) = case_seeds(case, tmp_path)
    assert group.succeeded == [None, None] and group.count is None and not group.judged
    assert group.summary == "n/a (2 seeds)"
    data = group.to_dict()
    assert data["succeeded"] is None and [s["succeeded"] for s in data["per_seed"]] == [None, None]
    table = seeds_markdown(case, [group])
    assert "| `paper` | n/a (2 seeds) | 0: +33.9, 1: +0.1 |" in table
    assert "**" not in table and "no seed is judged" in table
    assert "n/a (2 seeds)" in recipes_markdown({"nostick": [group]})
    assert seeds_figure(case, [group], tmp_path / "s.png").stat().st_size > 1000


def test_hu2018_crawls_committed_seeds_meet_its_yardstick():
    """The committed hu2018-crawl material agrees with its spec's yardstick (+25.3 mm): both seeds
    meet it in msr policy seeds, seeds.json and the shipped policy.json, whose case_spec is the spec's."""
    from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR, read_policy_json, resolve_policy

    case = load_case("hu2018-crawl")
    groups = {g.folder: g for g in case_seeds(case)}
    group = groups["paper"]
    assert group.succeeded == [True, True] and group.summary == "2 of 2"
    assert all(e["meets_target"] is True and e["distance_10s_m"] >= 0.0253 for e in group.entries)
    fast = groups["fast-envs8"]  # the 10-minute run: seed 0 beats the yardstick, seed 1 does not
    assert fast.succeeded == [True, False] and fast.summary == "1 of 2"
    assert [e["distance_10s_m"] >= 0.0253 for e in fast.entries] == [True, False]
    info = read_policy_json(POLICIES_DIR / "hu2018-crawl" / "policy.json")
    assert info["yardstick_10s_m"] == 0.0253 and info["target"] == "+25.3 mm in 10 s"
    assert info["seeds"]["meeting_target"] == 2
    assert resolve_policy("hu2018-crawl").case.to_dict() == case.to_dict()
    for each in groups.values():
        for entry in each.entries:
            seed_info = read_policy_json(each.path / entry["actor"] / "policy.json")
            assert seed_info["case_spec"] == case.to_dict() and seed_info["yardstick_10s_m"] == 0.0253
