"""msr real robustness and msr real identify refuse, before any work, what cannot be meant (issue 48):
a field CSV no coil plays (uT written as mT: one 4000 mT row), as msr field replay does; ``--seed``
without ``--samples`` (it seeds draws that are not made)."""

from __future__ import annotations

from pathlib import Path

import pytest
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR

from elastica_magnetic.cli import main

FIELDS = POLICIES_DIR / "m1-4mT" / "fields.csv"


@pytest.fixture
def huge_csv(tmp_path):
    """The first 20 rows of a shipped waveform, one of them 4000 mT (uT written as mT)."""
    lines = FIELDS.read_text().splitlines()[:21]
    header, rows = lines[0], lines[1:]
    cells = rows[5].split(",")
    cells[-3:] = ["4000", "0", "0"]
    rows[5] = ",".join(cells)
    path = tmp_path / "huge.csv"
    path.write_text("\n".join([header, *rows]) + "\n")
    return path


def _refused(capsys, argv, out) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert not out.exists(), err
    return err


def test_robustness_refuses_a_field_csv_no_coil_plays(huge_csv, tmp_path, capsys):
    # issue 48 fc_huge: it played the 4 T row, every variant "diverged", result written
    out = tmp_path / "rb"
    common = ["--physics", "training", "--duration", "0.05", "--workers", "1", "--no-corners",
              "--no-progress", "--out", str(out)]
    err = _refused(capsys, ["real", "robustness", str(huge_csv), "--case", "m1-4mT", *common], out)
    assert str(huge_csv) in err and "4000" in err and "T" in err, err
    err = _refused(capsys, ["real", "robustness", "m1-4mT", "--fields", str(huge_csv), *common], out)
    assert str(huge_csv) in err and "4000" in err, err


def test_identify_refuses_a_field_csv_no_coil_plays(huge_csv, tmp_path, capsys):
    out = tmp_path / "id"
    err = _refused(capsys, ["real", "identify", str(huge_csv), str(tmp_path / "trajectory.csv"),
                            "--robot", "m1-4mT", "--fit", "magnetization", "--no-progress",
                            "--out", str(out)], out)
    assert str(huge_csv) in err and "4000" in err, err


def test_robustness_refuses_a_seed_without_samples(tmp_path, capsys):
    # issue 48 o11: --seed 7 without --samples was silently ignored
    out = tmp_path / "rb"
    err = _refused(capsys, ["real", "robustness", str(FIELDS), "--case", "m1-4mT", "--seed", "7",
                            "--duration", "0.05", "--no-progress", "--out", str(out)], out)
    assert "--seed 7" in err and "--samples" in err, err


@pytest.mark.parametrize("robot", ["catheter-coils-reach", "spec"])
def test_round16_s1_identify_refuses_a_catheter_steered_by_a_source(robot, tmp_path, capsys):
    """Round 16 S1: `msr real identify --robot` took a catheter case (a magnet arm, coils) and
    fitted its magnetization to a waveform played as a uniform field, writing an identified spec."""
    from elastica_magnetic_rl.cases.case import load_case

    if robot == "spec":
        robot = str(tmp_path / "cm.toml")
        (tmp_path / "cm.toml").write_text(load_case("catheter-magnet-reach").toml())
    trajectory = tmp_path / "traj.csv"
    trajectory.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "".join(
        f"{k * 0.01},{k * 1e-4},0,{0.02 + k * 1e-4},0\n" for k in range(21)))
    out = tmp_path / "id"
    assert main(["real", "identify", str(POLICIES_DIR / "m1-4mT" / "fields.csv"), str(trajectory),
                 "--robot", robot, "--fit", "magnetization", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"--robot {robot}: [actuation] kind = " in err and "so it does not apply" in err
    assert not out.exists()


def test_round17_identify_plays_a_specs_field_in_space_and_clamp(tmp_path, capsys):
    """Round 17 S: identify fitted a spec with a [field] in space and a [boundary] clamp as a free
    robot under the CSV alone (the nominal robot missed msr field replay's own trajectory by 6.7
    mm). It plays them as replay does now: the nominal robot reproduces replay's motion."""
    from importlib import resources

    import numpy as np
    from elastica_magnetic_rl.sim2real.fit_model import FieldDrive, FitModel
    from elastica_magnetic_rl.sim2real.identify import load_spec, parse_fit
    from elastica_magnetic_rl.sim2real.tracking import read_trajectory

    from elastica_magnetic.field_csv import read_field_csv, write_field_csv
    from elastica_magnetic.field_spec import load_field

    spec_file = Path(str(resources.files("elastica_magnetic") / "data" / "examples" / "catheter.toml"))
    fields_csv = write_field_csv(tmp_path / "f.csv", np.tile([0.0, 1e-3, 0.0], (16, 1)))
    assert main(["field", "replay", str(fields_csv), "--robot", str(spec_file), "--physics", "training",
                 "--out", str(tmp_path / "rp"), "--no-progress"]) == 0
    capsys.readouterr()
    measured = read_trajectory(tmp_path / "rp" / "trajectory.csv")
    spec = load_spec(spec_file)
    fits = parse_fit("magnetization", spec)
    fields = read_field_csv(fields_csv)
    with pytest.raises(ValueError, match=r"the spec has \[field\] and \[boundary\]"):
        FieldDrive(fields).check_spec(spec)
    model = FitModel(spec, fits, FieldDrive(fields, load_field(spec_file)), measured, "training")
    assert np.abs(model.residuals([1.0])).max() < 1e-9
    assert np.abs(measured.displacements()).max() > 1e-4  # the magnet moved it


def test_round17_identify_refuses_tracked_points_closer_than_the_body(tmp_path):
    """Round 17 S: a 20 mm robot's trajectory was fitted on a 50 mm robot's spec without a word
    (points too far apart were refused, too close never)."""
    import numpy as np
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError, check_against_robot, read_trajectory

    t = np.arange(30) * 0.01
    rows = [f"{ti:.2f},{0.001 * ti},0,{0.0197 + 0.001 * ti},0" for ti in t]
    path = tmp_path / "tracked.csv"
    path.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "\n".join(rows) + "\n")
    measured = read_trajectory(path)
    check_against_robot(measured, 0.02, 0.3)  # its own robot
    with pytest.raises(TrajectoryError, match=r"19.7 mm apart, and on the 50 mm robot of the spec they lie"):
        check_against_robot(measured, 0.05, 0.3)


def test_round17_robustness_of_a_reach_case_judges_the_miss_of_the_target():
    """Round 17 S: the robustness of the reach policy m1-4mT-reach (within 1 mm of +10 mm) ranked a
    variant 3.8 mm past its target above the nominal robot (a study of distances ahead): the worst
    robot of a reach case is the one that ends farthest from its target, over or short."""
    from types import SimpleNamespace

    from elastica_magnetic_rl.cases.case import load_case
    from elastica_magnetic_rl.sim2real.report import robustness_table
    from elastica_magnetic_rl.sim2real.robustness import summarize

    case = load_case("m1-4mT-reach")
    variants = [SimpleNamespace(label=label, kind="one", settings={}) for label in
                ("nominal", "magnetization x0.85", "magnetization x1.15")]
    plan = SimpleNamespace(case=case, physics="training", duration=10.0, variations=[], variants=variants,
                           source="m1-4mT-reach", policy=None, waveform="fields.csv", design={})
    distances = [0.0093, 0.0048, 0.0138]
    jobs = [{"variant": k, "mode": "open_loop"} for k in range(3)]
    results = [{"distance_m": d, "diverged": False} for d in distances]
    import elastica_magnetic_rl.sim2real.robustness as robustness

    values = robustness.variant_values
    robustness.variant_values = lambda *args: {}
    try:
        report = summarize(plan, jobs, results, 1.0, 1)
    finally:
        robustness.variant_values = values
    s = report["summary"]["open_loop"]
    assert s["target_m"] == case.task.target == 0.01
    assert s["worst_variant"] == "magnetization x0.85" and s["worst_error_m"] == pytest.approx(0.0052)
    assert s["nominal_error_m"] == pytest.approx(0.0007) and s["worst_of_nominal"] is None
    assert "target +10.0 mm; nominal +9.3 mm (0.70 mm from it), worst +4.8 mm (magnetization x0.85, " \
           "5.20 mm from it)" in robustness_table(report)


def test_file_kind_tells_every_recorded_file_by_its_first_line(tmp_path):
    """identify's order checks read one classification: a tip path, a magnet path, the coils'
    currents, a field CSV, or nothing it knows (a crawler's trajectory, an unreadable file)."""
    from elastica_magnetic_rl.sim2real.recorded_paths import FILE_KINDS, file_kind
    from recorded_files import write_coil_currents

    files = {"tip": "t_s,tip_x_m,tip_y_m,tip_z_m", "magnet-pose": "t_s,magnet_x_m,magnet_y_m,magnet_z_m",
             "field": ",mag_x,mag_y,mag_z", None: "t_s,p0_x_m,p0_y_m"}
    for kind, header in files.items():
        (tmp_path / f"{kind}.csv").write_text(header + "\n0,0,0,0\n")
        assert file_kind(tmp_path / f"{kind}.csv") == kind
    assert file_kind(write_coil_currents(tmp_path / "coils.csv", n_coils=3)) == "coil-currents"
    assert file_kind(tmp_path / "absent.csv") is None
    assert set(FILE_KINDS) == {"tip", "magnet-pose", "coil-currents", "field"}
