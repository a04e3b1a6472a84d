"""Round 7 of held-out tries (issue 48): a folder spelling written as a file, a column in the
wrong unit, sideways motion a model or a fit does not show. Each test fails without its fix."""

from __future__ import annotations

import math

import numpy as np
import pytest

from elastica_magnetic.cli import main as msr
from elastica_magnetic.field_csv import read_field_csv, write_field_csv
from elastica_magnetic.plausibility import ImplausibleValueWarning


def test_a_file_output_spelled_as_a_folder_is_refused(tmp_path, capsys):
    """P10: ``msr real calibrate --out newdir/`` wrote a file named ``newdir``."""
    measurements = tmp_path / "m.csv"
    measurements.write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,field_z_mT\n")
    assert msr(["real", "calibrate", str(measurements), "--out", f"{tmp_path}/newdir/"]) == 2
    assert "ends with a separator, so it names a folder" in capsys.readouterr().err
    assert not (tmp_path / "newdir").exists()


def test_one_column_in_tesla_among_columns_in_millitesla_is_warned(tmp_path):
    """N10: a mag_z column in T (0.003) beside mag_y in mT (3) was played without a word."""
    rows = "".join(f"0,3,{0.003 * math.sin(0.1 * i)}\n" for i in range(40))
    (tmp_path / "mix.csv").write_text("mag_x,mag_y,mag_z\n" + rows)
    with pytest.warns(ImplausibleValueWarning, match="column mag_z reaches only 0.003 mT while "
                                                     "mag_y reaches 3 mT, about 1000 times less"):
        read_field_csv(tmp_path / "mix.csv", plausible=True)
    import warnings

    with warnings.catch_warnings():  # the paper's own waveform: z = 0, nothing to say
        warnings.simplefilter("error")
        write_field_csv(tmp_path / "planar.csv", np.array([[1e-3, 2e-3, 0.0]] * 5))
        read_field_csv(tmp_path / "planar.csv", plausible=True)


def test_a_three_axis_case_on_a_rolling_band_names_the_flat_band_model():
    """N06: train/generate of an xyz case on a band with the default rolling ground: no word
    (the simulate/replay note did not reach the learning commands)."""
    from elastica_magnetic_rl.cases.case import load_case

    spec = load_case("m1-4mT").to_dict()
    spec["actuation"]["axes"] = "xyz"
    with pytest.warns(ImplausibleValueWarning, match=r'\[actuation\] axes: "xyz" moves the robot '
                                                     r'out of the x-y plane.*sideways = "sliding"'):
        load_case(spec)
    spec["robot"]["ground"]["sideways"] = "sliding"
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_case(spec)


def test_the_sideways_columns_of_a_measured_trajectory_are_said_to_be_unused(tmp_path):
    """N17: identify fitted a trajectory whose z columns disagreed with the model, without a word."""
    from elastica_magnetic_rl.sim2real.tracking import read_trajectory

    lines = ["t_s,mid_x_m,mid_y_m,mid_z_m"] + [f"{0.01 * k},{1e-4 * k},0,0" for k in range(60)]
    (tmp_path / "t.csv").write_text("\n".join(lines) + "\n")
    with pytest.warns(ImplausibleValueWarning, match="columns mid_z_m are not used: the fit "
                                                     "compares the side view"):
        read_trajectory(tmp_path / "t.csv")


def test_the_waveform_figure_draws_bz_of_a_three_axis_waveform(tmp_path):
    """N23: the waveform figure of an xyz rollout drew B_x, B_y and the x-y amplitude only."""
    import matplotlib

    matplotlib.use("Agg")
    from elastica_magnetic_rl.reports import figures

    seen: list[str] = []
    original = figures._save

    def record(fig, path):
        seen.extend(line.get_label() for ax in fig.axes for line in ax.patches)
        return original(fig, path)

    t = np.arange(50) * 0.01
    fields = np.stack([np.zeros_like(t), 3e-3 * np.cos(t), 3e-3 * np.sin(t)], axis=1)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(figures, "_save", record)
        figures.plot_field_waveforms(fields, tmp_path / "w.png", 4e-3)
    assert "B_z" in seen and "|B|" in seen


def test_a_policy_whose_case_spec_was_edited_is_refused(tmp_path, capsys):
    """M07g: a shipped policy's case_spec edited (robot length 20 -> 30 mm) ran without a word,
    the 20 mm actor on a 30 mm robot."""
    import json
    import shutil
    from pathlib import Path

    from elastica_magnetic_rl.shipping.policy_files import PolicyFileError, resolve_policy

    shipped = Path(__file__).resolve().parents[2] / "rl" / "policies" / "m1-4mT"
    policy = tmp_path / "m1"
    shutil.copytree(shipped, policy)
    resolve_policy(policy)  # as shipped: its case_spec matches its hash
    meta = json.loads((policy / "policy.json").read_text())
    meta["case_spec"]["robot"]["length"] = 0.03
    (policy / "policy.json").write_text(json.dumps(meta, indent=2))
    with pytest.raises(PolicyFileError, match="its case_spec was edited"):
        resolve_policy(policy)


def test_a_turned_rotating_field_stays_within_the_specs_z_limit(tmp_path, capsys):
    """N24: ``--heading 1.5708`` on a case whose z pair is limited to 2 mT drove z at 4 mT."""
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import dumps

    spec = load_case("m1-4mT").to_dict()
    spec["actuation"].update({"axes": "xyz", "field_limit": [4e-3, 4e-3, 2e-3]})
    spec["robot"]["ground"]["sideways"] = "sliding"
    path = tmp_path / "z2.toml"
    path.write_text(dumps(spec))
    assert msr(["field", "simulate", "--robot", str(path), "--heading", "1.5708", "--duration",
                "0.05", "--out", str(tmp_path / "s")]) == 2
    assert ("reaches 4 mT on z, above z2.toml's [actuation] field_limit of 2 mT on z; give "
            "--amplitude of at most 2 mT") in capsys.readouterr().err.replace(str(tmp_path) + "/", "")
    assert msr(["field", "simulate", "--robot", str(path), "--heading", "1.5708", "--amplitude",
                "0.002", "--duration", "0.05", "--out", str(tmp_path / "s"), "--no-progress"]) == 0
