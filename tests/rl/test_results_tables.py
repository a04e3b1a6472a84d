"""benchmarks/results_tables.py: the "Campaigns at a glance" tables of benchmarks/results/LOG.md
are what the JSON records beside it give; an edited record or a hand edit of a table is caught."""

from __future__ import annotations

import json
import re
import shutil

import pytest
from benchmark_scripts import ROOT, load_benchmark

RESULTS = ROOT / "benchmarks" / "results"
KNOWN = "campaign_fast128_m1-10mT_zen5_2026-11-27.json"
PAPER_ORDER = ("m1-4mT", "m2-4mT", "m1-10mT", "m2-10mT")


@pytest.fixture(scope="module")
def tables():
    return load_benchmark("results_tables")


@pytest.fixture
def copies(tables, tmp_path, monkeypatch):
    """The records and LOG.md copied to ``tmp_path``, the script pointed at the copies."""
    folder = tmp_path / "results"
    folder.mkdir()
    for path in RESULTS.glob("*.json"):
        shutil.copy(path, folder)
    shutil.copy(RESULTS / "LOG.md", folder)
    monkeypatch.setattr(tables, "RESULTS", folder)
    monkeypatch.setattr(tables, "LOG", folder / "LOG.md")
    return folder


def test_the_committed_tables_are_what_the_records_give(tables):
    text = (RESULTS / "LOG.md").read_text()
    assert tables.replace_tables(text, tables.render(*tables.read_records(RESULTS))) == text, \
        "run: python benchmarks/results_tables.py --write"


def test_a_row_checked_by_hand_against_its_record(tables):
    """The m1-10mT campaign of the first version on Zen 5, from its JSON: seeds' accurate 10 s
    distances 153.0, 13.4, 154.7, 142.3, 146.7, 171.9, 147.8, 164.3 mm, all but seed 1 meeting
    the target (7, while the summary's training-physics count says 6); median (147.8 + 153.0) / 2
    = 150.4, best 171.9; wall_s 1572.5 = 26.2 min; steps run 0.6825."""
    record = json.loads((RESULTS / KNOWN).read_text())
    assert [s["accurate_10s_mm"] for s in record["seeds"].values()] == \
        [153.0, 13.4, 154.7, 142.3, 146.7, 171.9, 147.8, 164.3]
    assert record["summary"]["succeeded"] == 6
    expected = (f"| `m1-10mT` | 2026-11-27 | 8 | 7 of 8 | +150.4 | +171.9 | 100,000 | 0.68 | 26.2 "
                f"| `{KNOWN}` |")
    log = (RESULTS / "LOG.md").read_text()
    section = log.split("#### `fast`, first version: minibatches of 128; AMD EPYC (Zen 5)")[1]
    assert expected in section.split("####")[0]


def test_an_edited_record_or_a_hand_edited_table_is_caught(tables, copies):
    assert tables.main(["--check"]) == 0
    log = copies / "LOG.md"
    committed = log.read_text()
    log.write_text(committed.replace("| 7 of 8 | +150.4 |", "| 8 of 8 | +150.4 |"))
    assert tables.main(["--check"]) == 1
    log.write_text(committed)
    record = json.loads((copies / KNOWN).read_text())
    record["seeds"]["seed5"]["accurate_10s_mm"] = 181.9
    (copies / KNOWN).write_text(json.dumps(record))
    assert tables.main(["--check"]) == 1
    assert tables.main(["--write"]) == 0 and tables.main(["--check"]) == 0
    assert "| +150.4 | +181.9 |" in log.read_text()
    assert log.read_text().replace("+181.9", "+171.9") == committed  # only the tables changed


def test_a_record_lacking_a_value_is_left_out_with_the_reason(tables, copies):
    record = json.loads((copies / KNOWN).read_text())
    cases = {
        "campaign_fast128_nomachine_2026-11-27.json": ({"what": "8 seeds, 2 cores"}, "machine"),
        "campaign_fast256_x_2026-11-27.json": ({}, "recipe version `fast256`"),
        "campaign_fast128_nodate.json": ({}, "no date"),
        "campaign_fast128_nodistance_2026-11-27.json": (
            {"seeds": {**record["seeds"], "seed3": {"meets_target": True}}}, "seed3 has no"),
    }
    for name, (change, _) in cases.items():
        (copies / name).write_text(json.dumps({**record, **change}))
    campaigns, skipped = tables.read_records(copies)
    assert not {c.record for c in campaigns} & set(cases)
    for name, (_, reason) in cases.items():
        assert reason in skipped[name]
    assert skipped["td3_pendulum.json"] == "no `msr train` summary"
    assert "`campaign_fast128_nodate.json`" in tables.render(campaigns, skipped)


def test_the_training_pages_fast_row_is_the_campaign_records(tables):
    """docs/training.md's recipes table: `fast` (first version) on each machine, seeds that
    succeed per paper case and the range of the campaigns' wall times, as the records give them."""
    page = (ROOT / "docs" / "training.md").read_text()
    number = r"(\d+(?:\.\d+)?)"
    quoted = re.findall(rf"(\d), (\d), (\d), (\d) in {number}-{number} min on a 2-core ([^;|]+?) ?[;|]",
                        page.split("| `fast` |")[1].split("\n")[0])
    assert [machine for *_, machine in quoted] == ["AMD EPYC (Zen 5)", "Intel Xeon with AMX"]
    campaigns, _ = tables.read_records(RESULTS)
    for *successes, low, high, machine in quoted:
        mine = {c.case: c for c in campaigns if c.machine == machine
                and c.recipe == tables.RECIPE_VERSIONS["fast"]}
        assert [int(n) for n in successes] == [mine[case].successes for case in PAPER_ORDER]
        walls = [mine[case].wall_s / 60 for case in PAPER_ORDER]
        unit = 10.0 ** -len(low.partition(".")[2])
        assert abs(float(low) - min(walls)) < unit and abs(float(high) - max(walls)) < unit, walls


def test_the_readmes_fast_wall_time_and_successes_are_the_zen5_records(tables):
    """README.md's `msr train --recipe fast` row: the range of wall times and of seeds reaching the
    authors' distance of the first version's four paper campaigns on the AMD EPYC (Zen 5)."""
    (quoted,) = re.findall(r"in (\d+)-(\d+) min on 2 cores of an AMD EPYC Zen 5, (\d)-(\d) of 8",
                           (ROOT / "README.md").read_text())
    campaigns, _ = tables.read_records(RESULTS)
    mine = [c for c in campaigns if c.machine == "AMD EPYC (Zen 5)" and c.case in PAPER_ORDER
            and c.recipe == tables.RECIPE_VERSIONS["fast"]]
    assert sorted(c.case for c in mine) == sorted(PAPER_ORDER)
    walls = [c.wall_s / 60 for c in mine]
    low, high, fewest, most = map(int, quoted)
    assert abs(low - min(walls)) < 1 and abs(high - max(walls)) < 1, walls
    assert (fewest, most) == (min(c.successes for c in mine), max(c.successes for c in mine))
