"""Round 15 of held-out tries (issue 48): specs of catheters steered by fixed coils (and a magnet)
whose source cannot do the task, each refused or warned by name; a spec's warning shown once by
msr case check."""

from __future__ import annotations

import copy
import re
import tomllib
import warnings
from pathlib import Path

import pytest
from elastica_magnetic_rl.cases.case import load_case
from spec_texts import CATHETER_MAGNET_REACH

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import SpecError

COILS = tomllib.loads((Path(__file__).parents[3] / "rl" / "specs" / "catheter-coils-reach.toml").read_text())


def coils(**changes: object) -> dict:
    """The shipped coil case with ``changes`` ("actuation.key", or "coil.key" for every coil)."""
    data = copy.deepcopy(COILS)
    data["name"] = "coils"
    for dotted, value in changes.items():
        table, key = dotted.split(".")
        for target in data["actuation"]["coils"] if table == "coil" else [data[table]]:
            target[key] = value
    return data


def warned(data) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_case(data)
    return [str(w.message) for w in caught]


def test_the_shipped_coil_and_magnet_cases_load_without_a_warning():
    assert warned(coils()) == []
    assert warned("catheter-magnet-reach") == []


@pytest.mark.parametrize(("changes", "expected"), [
    # S1: coils too weak to bend the tip to the box (8 A written in kA; a turn each)
    ({"actuation.current_limit": 0.008}, r"current_limit: the strongest field the source makes at the tip "
                                         r"\(0.0092 mT.*bends it about 0.204 mm.*17 mm the target box"),
    ({"coil.turns": 1}, r"bends it about 0.409 mm.*mA written as A, too few turns"),
    ({"actuation.current_limit": 0.1}, r"bends it about 2.56 mm"),
    # S3: a current that cannot reach its limit within the episode (kA/s written as A/s)
    ({"actuation.max_slew": 1.0}, r"max_slew: 1 A/s takes 8 s to bring a current from zero to its limit "
                                  r"\(8 A\), longer than the 3 s episode.*kA/s written as A/s"),
    ({"actuation.max_slew": 5.0}, r"max_slew: 5 A/s takes 1.6 s.*more than half of the 3 s episode"),
    # S4: 800 mA written as A, a 3 mm winding: the plausibility table's coil current and radius
    ({"actuation.current_limit": 800.0}, r"current_limit = 800 A is above 200 A.*800 mA is 0.8 A"),
    ({"actuation.current_limit": 800.0}, r"strongest field at the straight tip: 0.920217 T is above 0.1 T"),
    ({"coil.radius": 0.003}, r"coils\[0\]\] radius = 0.003 m is below 0.005 m, the smallest coils"),
])
def test_coils_that_cannot_do_the_task_are_warned_by_name(changes, expected):
    assert any(re.search(expected, message) for message in warned(coils(**changes))), \
        warned(coils(**changes))


@pytest.mark.parametrize(("changes", "expected"), [
    ({"actuation.current_limit": 1000.0}, r"strongest field at the straight tip: 1.15027 T is above 1 T"),
    ({"coil.turns": 1e5}, r"1.84043 T is above 1 T.*turns 100000"),
])
def test_coils_beyond_any_coil_system_are_refused(changes, expected):
    """S4: 1000 A (or 1e5 turns) in 40 mm windings make more than 1 T at the tip."""
    with pytest.raises(SpecError, match=expected):
        load_case(coils(**changes))


def test_coincident_coils_are_refused_and_coils_along_one_direction_warned():
    """S2: eight windings in one place cannot be built (refused, naming the pair); one coil makes
    the field at the tip along one direction only (warned)."""
    data = coils()
    data["actuation"]["coils"] = [dict(data["actuation"]["coils"][0]) for _ in range(8)]
    with pytest.raises(SpecError, match=r"coils\[1\]: its winding is coils\[0\]'s \(the same centre"):
        load_case(data)
    data["actuation"]["coils"] = data["actuation"]["coils"][:1]
    assert any("make the field at the straight tip along only 1 independent direction" in m
               for m in warned(data))
    # two windings on one centre but of different radii (nested coils) are buildable
    nested = coils()
    inner = dict(nested["actuation"]["coils"][0], radius=0.03)
    nested["actuation"]["coils"].append(inner)
    load_case(nested)


def test_a_magnet_too_weak_to_bend_the_tip_even_at_its_closest_is_warned():
    """S1 for the magnet arm: the strongest field is on the magnet's axis at min_clearance."""
    data = tomllib.loads(CATHETER_MAGNET_REACH)
    data["name"] = "cat"
    data["actuation"]["moment"] = 1e-4  # 0.1 A m^2 in mA m^2... and 10 mm away: 0.02 mT
    assert any("moment: the strongest field the source makes at the tip (0.02 mT, the magnet's on its axis"
               in m for m in warned(data))


def test_case_check_shows_each_warning_of_the_spec_once(tmp_path, capsys):
    """msr case check reads the spec twice (parsed, then checked): its warnings were printed twice."""
    path = tmp_path / "slow.toml"
    msr(["case", "show", "catheter-coils-reach", "--toml"])
    path.write_text(capsys.readouterr().out.replace("max_slew = 1000.0", "max_slew = 1.0"))
    assert msr(["case", "check", str(path)]) == 0
    err = capsys.readouterr().err
    assert err.count("warning: ") == 1 and "max_slew: 1 A/s takes 8 s" in err


def test_commands_playing_a_field_name_the_steered_case_they_refuse(tmp_path, capsys):
    """Round 15 V3: ``msr real robustness --case`` of a steered case said "the case: ...", and msr
    design advised the same robot with a crawl task, which a coil-currents [actuation] refuses."""
    fields = Path(__file__).parents[3] / "rl" / "policies" / "m1-4mT" / "fields.csv"
    with pytest.raises(SystemExit):
        msr(["real", "robustness", str(fields), "--case", "catheter-coils-reach", "--out",
             str(tmp_path / "r")])
    err = capsys.readouterr().err
    assert 'argument --case: catheter-coils-reach: [actuation] kind = "coil-currents"' in err
    with pytest.raises(SystemExit):  # refused while its SPEC is parsed
        msr(["design", "catheter-coils-reach", "--out", str(tmp_path / "d"), "--minutes", "0.1"])
    err = capsys.readouterr().err
    assert 'a uniform field\'s [actuation], kind = "field", and [task] kind = "crawl"' in err
    assert not (tmp_path / "r").exists() and not (tmp_path / "d").exists()


def test_case_show_toml_gives_every_steering_key_its_unit_and_messages_read_once(tmp_path, capsys):
    """Round 15 V6, V7: the coil keys (and the stage's) lacked their unit comments in the file to
    copy and edit; a weak magnet's message said "at the the magnet's ...". """
    assert msr(["case", "show", "catheter-coils-reach", "--toml"]) == 0
    text = capsys.readouterr().out
    for line in ("current_limit = 8.0  # A", "max_slew = 1000.0  # A/s", "insertion = [-0.01, 0.01]  # m",
                 "insertion_speed = 0.01  # m/s", "radius = 0.04  # m", "turns = 500.0  # turns"):
        assert line in text, line
    assert load_case({**tomllib.loads(text), "name": "again"}).to_dict()["actuation"] == \
        load_case("catheter-coils-reach").to_dict()["actuation"]
    weak = tmp_path / "weak.toml"
    weak.write_text(CATHETER_MAGNET_REACH.replace("moment = 1.0", "moment = 0.001"))
    msr(["case", "check", str(weak), "--no-sag"])
    out = capsys.readouterr()
    assert "bending number M B L^2 A / EI at the magnet's" in out.out + out.err
    assert "at the the" not in out.out + out.err
