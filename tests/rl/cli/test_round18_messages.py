"""Round 18 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "An eighteenth round of tries")."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.design.outputs import judged_periods
from elastica_magnetic_rl.loop.state import STEPS, LoopError, LoopState, plan_loop
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main as msr
from elastica_magnetic.results import ResultExistsError


def test_ship_force_refuses_a_policy_of_another_spec_under_the_same_case_name(tmp_path):
    """D30: a run of a user's spec file named m2-4mT.toml (another magnetization) replaced the
    shipped m2-4mT policy with ``--force``: the same name is not the same case."""
    from elastica_magnetic_rl.shipping.ship import _check_same_case

    target = tmp_path / "m2-4mT"
    shutil.copytree(POLICIES_DIR / "m2-4mT", target, ignore=shutil.ignore_patterns("seeds"))
    spec = load_case("m2-4mT").to_dict()
    _check_same_case(target, "m2-4mT", spec)  # the case itself: a recipe trained since may differ
    spec["training"] = {"recipe": "fast", "steps": 1000}
    _check_same_case(target, "m2-4mT", spec)
    spec["robot"]["magnetization"]["magnitude"] = 90e3
    with pytest.raises(ResultExistsError, match=r"holds the shipped policy of case 'm2-4mT' with another "
                                                r"spec \(they differ at \[robot.magnetization\] magnitude\)"):
        _check_same_case(target, "m2-4mT", spec)


def test_a_checkpoint_copied_away_from_its_run_plays(trained, tmp_path):
    """V31, V32: ``msr policy generate COPY.pt`` (the run's checkpoint copied elsewhere, or a link
    to it) was refused for want of the replay file, which playing never reads."""
    from elastica_magnetic_rl.shipping.policy_files import resolve_policy

    copy = tmp_path / "copy.pt"
    shutil.copyfile(trained / "m1-4mT" / "seed0" / "checkpoint.pt", copy)
    link = tmp_path / "link.pt"
    link.symlink_to(trained / "m1-4mT" / "seed0" / "checkpoint.pt")
    for given in (copy, link):
        assert resolve_policy(given).case.name == "m1-4mT"


def _state(tmp_path, calibration):
    state = LoopState(tmp_path / "loop.json", "m1-4mT", {"robot": {}},
                      {"steps": 10, "calibration": calibration})
    for step in STEPS:
        state.steps[step] = {"status": "done"}
    return state


def test_a_new_calibration_redoes_the_firmware_step_alone(tmp_path):
    """V65: a loop whose calibration changed was refused as another loop (only --force, every step
    again); the calibration acts on the firmware step alone."""
    state = _state(tmp_path, "/a.json")
    settings = {"steps": 10, "calibration": "/b.json"}
    with pytest.raises(LoopError, match=r"changed: settings.calibration, which only step firmware uses: "
                                        r"pass --redo firmware"):
        plan_loop(state, {"robot": {}}, settings, (), (), False)
    plan = plan_loop(state, {"robot": {}}, settings, (), ("firmware",), False)
    assert plan.run == ("firmware",) and "train" in plan.done
    with pytest.raises(LoopError, match="pass --force to start it over"):  # another setting as well
        plan_loop(state, {"robot": {}}, {**settings, "seeds": 3}, (), ("firmware",), False)


def test_a_calibration_that_cannot_make_the_field_limit_is_refused_before_the_loop(tmp_path, capsys):
    """V65: a calibration of 2.4 mA coils passed the loop's start and failed its last step, advising
    ``--allow-clipping``, an option msr loop does not have."""
    from elastica_magnetic.hardware.calibration import default_calibration_path

    data = json.loads(default_calibration_path().read_text())
    data["current_limit_A"] = [0.0024, 0.0024, 0.0024]
    weak = tmp_path / "weak.json"
    weak.write_text(json.dumps(data))
    capsys.readouterr()
    out = tmp_path / "loop"
    assert msr(["loop", "m1-4mT", "--quick", "--calibration", str(weak), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "cannot make the case's field limit 4 mT along x alone" in err and "--allow-clipping" not in err
    assert not (tmp_path / "loop").exists()


def test_design_force_refuses_the_design_of_another_case(tmp_path):
    """D73: ``msr design m2-4mT --force --out DIR`` replaced DIR's design of m1-4mT."""
    from elastica_magnetic_rl.design.folder import DESIGN_KIND, check_folder

    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.result_markers import mark_folder

    folder = tmp_path / "design"
    folder.mkdir()
    mark_folder(folder, kind=DESIGN_KIND, subject="case m1-4mT")
    with pytest.raises(OutputPathError, match=r"holds the design of case m1-4mT, not of case m2-4mT: "
                                              r"--force replaces only a design of the same case"):
        check_folder(folder, False, True, "case m2-4mT")


def test_a_period_the_search_computes_is_judged_once():
    """S74: the final sweep judged 1.0 s twice (as 0.9999999999999999 s and 1.0 s)."""
    assert judged_periods(0.5, 1.0, 0.9999999999999999, 1.0) == [0.5, 1.0]
    assert judged_periods(0.5, 1.0, 1.0001) == [0.5, 1.0, 1.0001]


def test_no_result_goes_inside_another_result_or_a_folder_being_written(tmp_path, capsys):
    """D116, D117: ``msr field simulate --out s0/inner`` wrote into a finished simulate result
    (then ``--out s0 --force`` refused the mixed folder), and ``--out s5/inner`` while another
    process wrote s5 made that command fail; ``msr design --out ds2/sub`` nested a design likewise."""
    from lock_holder import held_elsewhere

    finished, running = tmp_path / "s0", tmp_path / "s5"
    args = ["field", "simulate", "--duration", "0.02", "--no-progress"]
    assert msr([*args, "--out", str(finished)]) == 0
    before = sorted(p.name for p in finished.iterdir())
    capsys.readouterr()
    assert msr([*args, "--out", str(finished / "inner")]) == 2
    assert "lies in" in capsys.readouterr().err and sorted(p.name for p in finished.iterdir()) == before
    running.mkdir()
    with held_elsewhere(running) as pid:
        assert msr([*args, "--out", str(running / "inner")]) == 2
        assert f"which pid {pid}" in capsys.readouterr().err
        assert msr(["design", "m1-4mT", "--quick", "--out", str(running / "sub"), "--no-progress"]) == 2
        assert f"which pid {pid}" in capsys.readouterr().err
    assert list(running.iterdir()) == []
    assert msr([*args, "--out", str(finished), "--force"]) == 0  # still the command's own, whole


def test_figures_go_into_no_other_commands_result(trained, tmp_path, capsys):
    """D126: ``msr policy figures RUNS --out EXPORT`` put a learning curve into an export's result,
    which ``export --force`` then removed without a word."""
    export = tmp_path / "export"
    run = str(trained / "m1-4mT" / "seed0")
    assert msr(["policy", "export", run, "--out", str(export), "--checkpoint", "final", "--no-progress"]) == 0
    before = sorted(p.name for p in export.iterdir())
    capsys.readouterr()
    assert msr(["policy", "figures", str(trained), "--out", str(export), "--no-gif"]) == 2
    assert "no part of it" in capsys.readouterr().err and sorted(p.name for p in export.iterdir()) == before
