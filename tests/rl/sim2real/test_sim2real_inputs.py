"""msr real robustness and msr real identify refuse, before any work, what cannot be meant (issue 48):
a field CSV no coil plays (uT written as mT: one 4000 mT row), as msr field replay does; ``--seed``
without ``--samples`` (it seeds draws that are not made)."""

from __future__ import annotations

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
