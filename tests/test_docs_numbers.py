"""Numbers the README and the pages quote agree with their one source: a shipped policy's distance
(and the reach policy's error and settling time) with its ``rl/policies/<name>/policy.json``,
rounded as written; the seeds of a recipe that meet a case's target with the committed seeds'
``seeds.json``; and no page quotes a test count (it goes stale with every test added)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
POLICIES = ROOT / "rl" / "policies"
NUMBER = r"([+-]?\d+(?:\.\d+)?)"
PAGES = [ROOT / "README.md", POLICIES / "README.md", ROOT / "benchmarks" / "README.md",
         *sorted((ROOT / "docs").glob("*.md"))]


def shipped() -> dict[str, dict]:
    """Every shipped policy's policy.json, by name."""
    return {p.parent.name: json.loads(p.read_text()) for p in sorted(POLICIES.glob("*/policy.json"))}


def mm(info: dict) -> float:
    """The policy's measured distance: the middle of the robot in 10 s, accurate physics, mm."""
    return info["evaluation"]["mid_dx_m"] * 1e3


def reach_error_mm(info: dict) -> float:
    return info["evaluation"]["reach"]["final_error_m"] * 1e3


def settle_s(info: dict) -> float:
    return info["evaluation"]["reach"]["settle_time_s"]


def pattern(text: str) -> re.Pattern:
    """``text`` as written on the page, each ``#`` a number; any run of spaces may be a line break."""
    pieces = [re.escape(piece) for piece in text.split("#")]
    return re.compile(NUMBER.join(pieces).replace(r"\ ", r"\s+"))


def agrees(written: str, value: float) -> bool:
    """``written`` is ``value`` rounded to the digits written (a sign written is checked too)."""
    decimals = len(written.partition(".")[2])
    if written[0] in "+-":
        return f"{value:+.{decimals}f}" == written
    return f"{value:.{decimals}f}" == written


def four_mT(p):
    return [mm(p["m1-4mT"]), mm(p["m2-4mT"])]


def robust_10mT(p):
    return [mm(p["m1-10mT-robust"]), mm(p["m2-10mT-robust"])]


# (page, the words around the numbers, what each number is: a value, or values it stands for
# together). Each phrase must be found once: a page reworded fails here, to be updated, rather
# than leaving its numbers unchecked.
QUOTES = [
    ("README.md", "`m1-4mT` # mm and `m2-4mT` # mm (inchworm",
     [lambda p: mm(p["m1-4mT"]), lambda p: mm(p["m2-4mT"])]),
    ("README.md", "`m1-10mT` # mm and `m2-10mT` # mm (rolling",
     [lambda p: mm(p["m1-10mT"]), lambda p: mm(p["m2-10mT"])]),
    ("README.md", "learns to move # mm in 10 s (a rotating", [lambda p: mm(p["hu2018-crawl"])]),
    ("README.md", "and stop (within # mm, settled after # s)",
     [lambda p: abs(reach_error_mm(p["m1-4mT-reach"])), lambda p: settle_s(p["m1-4mT-reach"])]),
    ("README.md", "(`m1-4mT-designed`) crawls # mm in 10 s", [lambda p: mm(p["m1-4mT-designed"])]),
    ("rl/policies/README.md",
     "| `m1-4mT-designed` | 3 (`fast` with a yardstick warm-up, `best.pt`) | 12k | no | # mm",
     [lambda p: mm(p["m1-4mT-designed"])]),
    ("docs/design.md", "Seed 3 (# mm) is shipped", [lambda p: mm(p["m1-4mT-designed"])]),
    ("rl/policies/README.md",
     "| `m1-4mT-designed-robust` | 1 (`fast` with a warm-up of the robust field, `best.pt`) | 12k | no "
     "| # mm",
     [lambda p: mm(p["m1-4mT-designed-robust"])]),
    ("docs/design.md", "seeds +11.1 and # mm) goes # mm on the nominal",
     [lambda p: mm(p["m1-4mT-designed-robust"]), lambda p: mm(p["m1-4mT-designed-robust"])]),
    ("docs/training.md", "At 10 mT the learned policies go farther (# mm)",
     [lambda p: [mm(p["m1-10mT"]), mm(p["m2-10mT"])]]),
    ("docs/training.md", "the shipped # to # mm (and the authors'",
     [lambda p: min(four_mT(p)), lambda p: max(four_mT(p))]),
    ("docs/training.md", "(`hu2018-crawl`, # mm in 10 s", [lambda p: mm(p["hu2018-crawl"])]),
    ("docs/training.md", "(`m1-4mT-reach`, within # mm, settled after # s)",
     [lambda p: abs(reach_error_mm(p["m1-4mT-reach"])), lambda p: settle_s(p["m1-4mT-reach"])]),
    ("docs/extra_physics.md", "shipped on the evening of 2026-11-25 (# mm in 10 s",
     [lambda p: mm(p["m2-10mT"])]),
    ("docs/sim_to_real.md", "nominal distance: # to # mm against # mm for the shipped nominal",
     [lambda p: min(robust_10mT(p)), lambda p: max(robust_10mT(p)),
      lambda p: [mm(p["m1-10mT"]), mm(p["m2-10mT"])]]),
    ("rl/policies/README.md", "the shipped `m2-10mT` is now a `pink-ln-unsat` seed (# mm)",
     [lambda p: mm(p["m2-10mT"])]),
    ("rl/policies/README.md", "(error # mm), settled after # s",
     [lambda p: reach_error_mm(p["m1-4mT-reach"]), lambda p: settle_s(p["m1-4mT-reach"])]),
    ("rl/policies/m1-4mT-reach/MODEL_CARD.md", "final position error # mm; settles within the "
     "tolerance after # s",
     [lambda p: reach_error_mm(p["m1-4mT-reach"]), lambda p: settle_s(p["m1-4mT-reach"])]),
]


@pytest.mark.parametrize("page, words, values", QUOTES, ids=[f"{q[0]}: {q[1][:30]}" for q in QUOTES])
def test_a_quoted_number_is_its_policy_json(page, words, values):
    found = pattern(words).findall((ROOT / page).read_text())
    assert len(found) == 1, f"{page}: '{words}' found {len(found)} times (reworded? update QUOTES)"
    written = found[0] if isinstance(found[0], tuple) else (found[0],)
    policies = shipped()
    for number, value in zip(written, values, strict=True):
        expected = value(policies)
        for one in expected if isinstance(expected, list) else [expected]:
            assert agrees(number, one), f"{page}: '{words}': {number}, policy.json {one}"


def _tip_reach(info: dict) -> bool:
    return "tip_reach" in (info.get("evaluation") or {})


def _goto(info: dict) -> bool:
    return "ring" in (info.get("evaluation") or {})


def test_the_shipped_policies_table_is_their_policy_json():
    """rl/policies/README.md: one row per shipped policy; its seed and its 10 s distance (a
    tip-reach policy: its row in the catheters' table, its seed and its held-out targets reached,
    beside the yardstick's; a goto policy: its row in the goto table, its seed and its ring's
    targets reached, beside the yardstick's)."""
    policies = shipped()
    rows, six_cells = {}, {}
    for line in (POLICIES / "README.md").read_text().splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        name = re.fullmatch(r"`(\S+)`", cells[0])
        if name and name.group(1) in policies and len(cells) == 8:
            rows[name.group(1)] = cells
        elif name and name.group(1) in policies and len(cells) == 6:
            six_cells[name.group(1)] = cells
    reach_rows = {n: c for n, c in six_cells.items() if _tip_reach(policies[n])}
    goto_rows = {n: c for n, c in six_cells.items() if _goto(policies[n])}
    assert sorted(rows) == sorted(n for n, info in policies.items() if not (_tip_reach(info) or _goto(info)))
    assert sorted(reach_rows) == sorted(n for n, info in policies.items() if _tip_reach(info))
    assert sorted(goto_rows) == sorted(n for n, info in policies.items() if _goto(info))
    for name, cells in goto_rows.items():
        ring, theirs = policies[name]["evaluation"]["ring"], policies[name]["evaluation"]["yardstick_ring"]
        assert int(re.match(r"\d+", cells[1]).group()) == policies[name]["training"]["seed"], name
        assert cells[3].startswith(f"{ring['successes']} of {ring['targets']}"), (name, cells[3])
        assert cells[4].startswith(f"{theirs['successes']} of {theirs['targets']}"), (name, cells[4])
        assert cells[5].startswith(f"{ring['mean_time_to_target_s']:.1f} s"), (name, cells[5])
    for name, cells in reach_rows.items():
        judged = policies[name]["evaluation"]["tip_reach"]
        assert int(re.match(r"\d+", cells[1]).group()) == policies[name]["training"]["seed"], name
        assert cells[3].startswith(f"{judged['policy']['successes']} of 20"), (name, cells[3])
        assert cells[4].startswith(f"{judged['yardstick']['successes']} of 20"), (name, cells[4])
    for name, cells in rows.items():
        seed, distance = re.match(r"\d+", cells[1]).group(), re.match(NUMBER + " mm", cells[4])
        assert int(seed) == policies[name]["training"]["seed"], name
        assert distance and agrees(distance.group(1), mm(policies[name])), (name, cells[4])


def test_the_fine_tuned_seeds_shipped_are_the_robust_policies():
    """docs/sim_to_real.md's fine-tuning table: a row marked ``(shipped)`` is ``<case>-robust``,
    its seed and its fine-tuned distance (accurate) those of the policy; every ``-robust`` policy
    fine-tuned on randomized robots has its row (``m1-4mT-designed-robust``, a clone of a robust
    design's field, is docs/design.md's)."""
    policies = shipped()
    rows = re.findall(r"^\| `(\S+)` \| (\d+) \(shipped\) \| [^|]+ \| " + NUMBER + r" \|",
                      (ROOT / "docs" / "sim_to_real.md").read_text(), flags=re.M)
    fine_tuned = [n for n, info in policies.items()
                  if "-robust" in n and info["training"].get("refine_steps")]
    assert sorted(f"{case}-robust" for case, _, _ in rows) == sorted(fine_tuned)
    for case, seed, distance in rows:
        info = policies[f"{case}-robust"]
        assert int(seed) == info["training"]["seed"] and agrees(distance, mm(info)), (case, distance)


def test_every_model_card_states_its_policy_json_distance():
    for name, info in shipped().items():
        card = (POLICIES / name / "MODEL_CARD.md").read_text()
        if _tip_reach(info):  # its card's table: the held-out targets reached, its and the yardstick's
            judged = info["evaluation"]["tip_reach"]
            assert f"| this policy | {judged['policy']['successes']} of 20 |" in card, name
            assert f"| the steering yardstick | {judged['yardstick']['successes']} of 20 |" in card, name
            continue
        (written,) = pattern("middle of the robot moved # mm in 10 s").findall(card)
        assert agrees(written, mm(info)), (name, written)


def test_agrees_reads_the_digits_as_written():
    assert agrees("+22.8", 22.814) and agrees("22.81", 22.814) and agrees("23", 22.814)
    assert not agrees("+22.9", 22.814) and not agrees("-22.8", 22.814) and not agrees("22.82", 22.814)


def seeds_meeting(case: str, recipe: str) -> list[int]:
    """[seeds meeting the case's target, seeds] of a recipe's committed seeds (their seeds.json)."""
    seeds = json.loads((POLICIES / case / "seeds" / recipe / "seeds.json").read_text())
    return [sum(bool(seed["meets_target"]) for seed in seeds), len(seeds)]


def counts(recipe: str, cases: str) -> list[int]:
    """Seeds meeting the target of each case of ``cases`` (space-separated), in that order."""
    return [seeds_meeting(case, recipe)[0] for case in cases.split()]


def of(recipe: str, cases: str) -> list[int]:
    """``k of n`` of each case of ``cases``, in that order, flattened."""
    return [n for case in cases.split() for n in seeds_meeting(case, recipe)]


PAPER_ORDER = "m1-4mT m2-4mT m1-10mT m2-10mT"
# (page, the words around the counts, the counts in the order written): seed counts whose source
# is the committed seeds' seeds.json.
SEED_COUNTS = [
    ("README.md", "with the paper's recipe: # of # (# of # with `pink` or `pink-ln`), # of # (# of # "
     "with `pink-ln`), # of # (# of # with `pink-ln`) and # of # (# of # with `pink-ln`)",
     lambda: [*of("paper", "m1-4mT"), *of("pink-ln", "m1-4mT"), *of("paper", "m2-4mT"),
              *of("pink-ln", "m2-4mT"), *of("paper", "m1-10mT"), *of("pink-ln", "m1-10mT"),
              *of("paper", "m2-10mT"), *of("pink-ln", "m2-10mT")]),
    ("rl/policies/README.md", "reaches the paper's 3 of 8 for `m1-4mT` (# of #), `m2-4mT` (# of #), "
     "`m2-10mT` (# of #) and, just, `m1-10mT` (# of #;",
     lambda: of("paper", "m1-4mT m2-4mT m2-10mT m1-10mT")),
    ("rl/policies/README.md", "critics): `m1-4mT` # of #, `m1-10mT` # of #, `m2-4mT` # of #, "
     "`m2-10mT` # of #.", lambda: of("pink-ln", "m1-4mT m1-10mT m2-4mT m2-10mT")),
    ("docs/training.md", "| `paper` | none: the authors' settings | #, #, #, # |",
     lambda: counts("paper", PAPER_ORDER)),
    ("docs/training.md", "**The default** | **#, #, #, #** |", lambda: counts("pink-ln", PAPER_ORDER)),
    ("docs/training.md", "(# of # seeds against # of #; `m1-10mT` # against #)",
     lambda: [sum(counts("pink-ln", PAPER_ORDER)), sum(of("pink-ln", PAPER_ORDER)[1::2]),
              sum(counts("paper", PAPER_ORDER)), sum(of("paper", PAPER_ORDER)[1::2]),
              *counts("pink-ln", "m1-10mT"), *counts("paper", "m1-10mT")]),
]


@pytest.mark.parametrize("page, words, expected", SEED_COUNTS,
                         ids=[f"{q[0]}: {q[1][:30]}" for q in SEED_COUNTS])
def test_a_quoted_seed_count_is_the_committed_seeds(page, words, expected):
    found = pattern(words).findall((ROOT / page).read_text())
    assert len(found) == 1, f"{page}: '{words}' found {len(found)} times (reworded? update SEED_COUNTS)"
    assert [int(n) for n in found[0]] == expected(), page


def test_the_readmes_pink_or_pink_ln_count_holds_for_both():
    """README.md: ``m1-4mT`` "(6 of 8 with `pink` or `pink-ln`)": one count for two recipes."""
    assert of("pink", "m1-4mT") == of("pink-ln", "m1-4mT")


def test_no_page_quotes_a_test_count():
    """A count of tests (``759 passed``, ``758 tests``) is stale at the next test added; the pages
    say how long the suite takes, not how many tests it has."""
    counts = [f"{page.relative_to(ROOT)}: {m.group()}" for page in PAGES
              for m in re.finditer(r"\b\d[\d,]* (tests|passed|skipped)\b", page.read_text())]
    assert not counts, counts
