"""Round 32 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A thirty-second round of tries"). V1-V3 (coil-current files) are tested in
tests/hardware/test_stream_currents.py."""

from __future__ import annotations

import json
import shutil

import pytest
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main as msr


def _tree(folder):
    return sorted((p.relative_to(folder).as_posix(), p.stat().st_size if p.is_file() else -1,
                   p.stat().st_mtime_ns) for p in folder.rglob("*"))


def test_ship_puts_no_policy_into_a_training_s_output_folder(tmp_path, trained, capsys, monkeypatch):
    """D1: ``msr policy ship --out . --name runs``, where runs/ is a training's --out (it holds the
    case folder runs/m1-4mT), wrote the policy's files there: the training's folder became "a shipped
    policy", refusing the user's next training into it. Now refused, nothing written."""
    runs = tmp_path / "runs"
    shutil.copytree(trained, runs)
    before = _tree(runs)
    monkeypatch.chdir(tmp_path)
    assert msr(["policy", "ship", "runs/m1-4mT/seed0", "--no-measure", "--out", ".", "--name", "runs",
                "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "holds the case folder m1-4mT/ of a training" in err and "choose another --out/--name" in err, err
    assert _tree(runs) == before


def test_a_result_inside_a_committed_campaign_s_seed_names_the_campaign(tmp_path, trained, capsys):
    """V4: ``msr refine --out POLICY/seeds/fast/seed0/ref`` and ``msr policy ship --out
    POLICY/seeds/fast/seed0`` were told the seed is "a shipped policy" and to go beside it, inside the
    campaign, refused too. Both now name the campaign, a result of ``msr policy export-seeds``."""
    policy = tmp_path / "pm"
    shutil.copytree(POLICIES_DIR / "m1-4mT", policy)
    before = _tree(policy)
    run = str(trained / "m1-4mT" / "seed0")
    seed = policy / "seeds" / "fast" / "seed0"
    for argv in (["refine", run, "--checkpoint", "final", "--steps", "3", "--out", str(seed / "ref")],
                 ["policy", "ship", run, "--no-measure", "--out", str(seed), "--name", "x"]):
        assert msr([*argv, "--no-progress"]) == 2, argv
        err = capsys.readouterr().err
        assert "which holds a result of `msr policy export-seeds`" in err and "beside it" not in err, err
    assert _tree(policy) == before


def test_a_loop_s_calibration_measured_again_into_the_same_file_is_a_change():
    """S1: a loop's ``--calibration`` file whose contents changed (the same path) kept the firmware
    built from the old calibration, "8 of 8 steps done". The loop records the calibration's contents:
    a new one is a changed setting of the firmware step."""
    import tempfile
    from pathlib import Path

    from elastica_magnetic_rl.loop.settings import LoopSettings
    from elastica_magnetic_rl.loop.state import STEPS, LoopError, LoopState, plan_loop

    with tempfile.TemporaryDirectory() as folder:
        calibration = Path(folder) / "cal.json"
        calibration.write_text(json.dumps({"name": "lab", "gain": 0.003}))
        first = LoopSettings(calibration=calibration).recorded()
        calibration.write_text(json.dumps({"name": "lab", "gain": 0.0025}))
        second = LoopSettings(calibration=calibration).recorded()
    assert first["calibration"] == second["calibration"]
    done = {s: {"status": "done", "summary": {}} for s in STEPS}
    state = LoopState(Path("out/loop.json"), "c", {}, first, done)
    with pytest.raises(LoopError, match=r"changed: settings.calibration_sha256, which only step firmware "
                                        r"uses: pass --redo firmware"):
        plan_loop(state, {}, second, (), (), False)
    assert plan_loop(state, {}, second, (), ("firmware",), False).run == ("firmware",)


def test_a_non_finite_current_is_named_in_amperes(tmp_path):
    """V3: a NaN current in a coil path was named "(SI units: s, m)"; the column's unit is A."""
    import pandas as pd
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, numeric_columns

    table = pd.DataFrame({"t_s": ["0", "0.01"], "current_2_A": ["0.5", "nan"]})
    with pytest.raises(TrajectoryError, match=r"line 3, column current_2_A: 'nan' is not a finite "
                                              r"number \(A\)"):
        numeric_columns(tmp_path / "c.csv", table, ["t_s", "current_2_A"])


def test_a_rod_too_coarse_for_the_interaction_is_told_so(tmp_path):
    """V5: a rod of 4 elements with ``[robot.interaction]`` was advised ``cutoff = 0.02`` (four elements,
    the rod's whole length), which was refused with the same advice and a millimetre guess that did
    not apply. Now told the rod is too coarse, and what would do."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import SpecError

    base = load_case("m1-4mT").toml().replace('name = "m1-4mT"', 'name = "c4"').replace("n_elements = 64",
                                                                                        "n_elements = 4")
    spec = tmp_path / "c4.toml"
    for table in ("self_contact_stiffness = 40.0", "cutoff = 0.02"):
        spec.write_text(base + f"\n[robot.interaction]\n{table}\n")
        with pytest.raises(SpecError, match=r"too coarse for the interaction: .* give n_elements of at "
                                            r"least 8, or remove \[robot.interaction\]") as refused:
            load_case(spec)
        assert "give cutoff" not in str(refused.value) and "millimetres" not in str(refused.value)


def test_an_input_inside_the_folder_force_replaces_is_refused(tmp_path, capsys):
    """D2: ``msr field replay F --reference OUT/trajectory.csv --out OUT --force`` deleted the reference
    it compared with, with the old result. An input inside the folder a command replaces whole is
    refused before any work, the folder untouched."""
    field = tmp_path / "f.csv"
    field.write_text("mag_x,mag_y,mag_z\n" + "".join(f"{4 * (k % 2)},0,0\n" for k in range(31)))
    out = tmp_path / "meas"
    assert msr(["field", "replay", str(field), "--physics", "training", "--out", str(out),
                "--no-progress"]) == 0
    before = _tree(out)
    capsys.readouterr()
    assert msr(["field", "replay", str(field), "--physics", "training", "--reference",
                str(out / "trajectory.csv"), "--out", str(out), "--force", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "--reference" in err and "lies in --out" in err and "replaces whole" in err, err
    assert _tree(out) == before


def test_a_tracker_naming_one_point_twice_is_refused(tmp_path):
    """S3: a tracker CSV with x_0.5_m and x_0.50_m (two tracks of one place, 5 mm apart) was fitted with
    one of them dropped without a word; now refused naming both columns."""
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, read_trajectory

    path = tmp_path / "tk.csv"
    path.write_text("t_s,x_0.5_m,y_0.5_m,x_0.50_m,y_0.50_m\n"
                    + "".join(f"{k / 30:.4f},{0.001 * k},0,{0.001 * k + 0.005},0\n" for k in range(10)))
    with pytest.raises(TrajectoryError, match=r"columns x_0.5_m and x_0.50_m both name the point at "
                                              r"s = 0.5"):
        read_trajectory(path)


def test_an_immutable_folder_is_not_blamed_on_its_permissions(tmp_path, monkeypatch):
    """V6: a folder made immutable (chattr +i) was said to refuse "the folder's permissions", which
    chmod cannot change; the system's reason is given."""
    import errno
    import tempfile

    import elastica_magnetic.io as io_module

    def immutable(*args, **kwargs):
        raise PermissionError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(io_module.os, "access", lambda *a, **k: False)
    monkeypatch.setattr(tempfile, "TemporaryFile", immutable)
    reason = io_module.unwritable_reason(tmp_path)
    assert reason.startswith("Operation not permitted (the folder is immutable"), reason
    assert "permissions do" not in reason


def test_a_fit_ended_on_the_search_s_bound_is_said_so_and_not_judged():
    """S4: a fit that ended at x0.20006 of the search's bound x0.2 said ``at_bound: false`` (an exact
    comparison of log factors) and "NOT IDENTIFIABLE: flat cost", though the cost rose on its other
    side: the search's wall, not the data, had ended it. Now at the bound, and not judged."""
    import numpy as np
    from elastica_magnetic_rl.sim2real.fit_report import fitted_values
    from elastica_magnetic_rl.sim2real.identify import FIT_BOUNDS, load_spec, parse_fit

    spec = load_spec("m1-4mT")
    fits = parse_fit("robot.magnetization.magnitude", spec)
    bounds = (np.log(FIT_BOUNDS[0]), np.log(FIT_BOUNDS[1]))
    judged = [{"interval": None, "interval_from": "jacobian", "identifiable": False,
               "reason": "flat cost: changing it alone by 10 % changes the residuals by less than the noise"}]
    profile = [{"value": 0, "log_step": -0.095, "cost_rise_over_s2": -0.015},
               {"value": 0, "log_step": 0.095, "cost_rise_over_s2": 5.39}]  # rises away from the wall
    fitted = fitted_values(spec, fits, np.array([np.log(0.20006)]), np.array([0.3]), bounds, judged, profile)
    entry = fitted["robot.magnetization.magnitude"]
    assert entry["at_bound"] is True and entry["identifiable"] is None and entry["interval"] is None
    assert entry["reason"].startswith("not judged: the fit ended on the search's bound (x0.2")
    inside = fitted_values(spec, fits, np.array([np.log(0.25)]), np.array([0.3]), bounds, judged, profile)
    assert inside["robot.magnetization.magnitude"]["at_bound"] is False
    flat = fitted_values(spec, fits, np.array([np.log(0.20006)]), np.array([0.3]), bounds, judged,
                         [{**p, "cost_rise_over_s2": 0.1} for p in profile])  # a flat value at the wall
    assert flat["robot.magnetization.magnitude"]["identifiable"] is False  # its flat-cost verdict stands


def test_a_crawler_given_an_arm_s_path_is_told_to_give_its_field(tmp_path, capsys):
    """V7: ``msr real identify ARM.csv TRAJ.csv --robot m1.toml`` (a crawler) was told to give a tip path,
    then refused for the crawler; the drive is checked against the robot first."""
    arm = tmp_path / "arm.csv"
    arm.write_text("t_s,magnet_x_m,magnet_y_m,magnet_z_m,direction_x,direction_y,direction_z\n"
                   + "".join(f"{k / 100:g},0.05,0.1,0,0,-1,0\n" for k in range(40)))
    traj = tmp_path / "traj.csv"
    traj.write_text("t_s,x_0.5_m,y_0.5_m\n" + "".join(f"{k / 30:.4f},{1e-4 * k},0\n" for k in range(10)))
    assert msr(["real", "identify", str(arm), str(traj), "--robot", "m1-4mT", "--fit",
                "robot.magnetization.magnitude", "--out", str(tmp_path / "id"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "give the field CSV played (mag_x, mag_y, mag_z in mT)" in err and "tip's path" not in err, err
