"""A steering to one target writes the drive it played (a magnet arm's path, the coils' currents) and
the tip's path, the files ``msr real identify`` reads (``msr policy generate --target``, ``msr field
baseline --target`` of a steered case): replayed, the written drive gives the written tip path."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict
from elastica_magnetic_rl.shipping.tip_reach import Steering, steering_controller, write_targets
from elastica_magnetic_rl.sim2real.coil_path import read_coil_path, simulate_coil_tips
from elastica_magnetic_rl.sim2real.identify import drive_recorder
from elastica_magnetic_rl.sim2real.magnet_path import read_magnet_path, simulate_tips
from elastica_magnetic_rl.sim2real.recorded_paths import file_kind
from elastica_magnetic_rl.sim2real.tracking import read_trajectory
from spec_texts import quick_catheter

TARGET = (0.05, 0.008, -0.006)  # m, inside both shipped cases' target boxes
DURATION_S = 0.3
REPLAYS = {"catheter-magnet-reach": ("magnet_path.csv", "magnet-pose", read_magnet_path, simulate_tips),
           "catheter-coils-reach": ("coil_currents.csv", "coil-currents", read_coil_path, simulate_coil_tips)}


@pytest.mark.parametrize("case_name", sorted(REPLAYS))
def test_the_written_drive_replays_to_the_written_tip_path(tmp_path, case_name):
    name, kind, read, replay = REPLAYS[case_name]
    spec = quick_catheter(case_name, "catheter-quick")
    case = case_from_dict(spec)
    out = tmp_path / "out"
    result = write_targets(case, out, Steering(steering_controller), physics="training", duration=DURATION_S,
                           targets=[TARGET], figures=False, drive=drive_recorder(case))
    assert set(result["files"]) == {"targets.csv", "targets.json", name, "tip_path.csv"}
    assert file_kind(out / name) == kind and file_kind(out / "tip_path.csv") == "tip"
    drive = read(out / name)
    read_trajectory(out / "tip_path.csv")  # a tip path identify takes
    steps = round(DURATION_S / 0.01)
    assert len(drive.times) == steps  # every control step but the episode's last (which resets it)
    replayed = replay(spec, "training", drive)
    written = np.loadtxt(out / "tip_path.csv", delimiter=",", skiprows=1)[:, 1:]
    assert written.shape == (steps, 3) and np.ptp(written, axis=0).max() > 1e-4  # the tip moved
    # the files hold 9 significant digits: the replay agrees to far below a tracker's 0.05 mm
    np.testing.assert_allclose(replayed, written, rtol=0, atol=1e-7)


def test_a_drive_is_recorded_for_one_target_only(tmp_path):
    spec = quick_catheter("catheter-magnet-reach", "catheter-quick")
    case = case_from_dict(spec)
    with pytest.raises(ValueError, match="a drive is recorded for one target; got 2"):
        write_targets(case, tmp_path / "out", Steering(steering_controller), physics="training",
                      duration=0.05, targets=[TARGET, TARGET], figures=False, drive=drive_recorder(case))
    assert not (tmp_path / "out").exists()


def test_a_baseline_to_one_target_writes_the_coils_currents(tmp_path, capsys):
    import json

    from elastica_magnetic.cli import main

    spec = tmp_path / "coils.toml"
    spec.write_text(case_from_dict(quick_catheter("catheter-coils-reach", "coils-quick")).toml())
    args = ["field", "baseline", "--case", str(spec), "--physics", "training", "--duration", "0.05",
            "--no-figures", "--json"]
    assert main([*args, "--target", ",".join(map(str, TARGET)), "--out", str(tmp_path / "one")]) == 0
    files = json.loads(capsys.readouterr().out)["files"]
    assert {"coil_currents.csv", "tip_path.csv"} <= set(files)
    assert file_kind(files["coil_currents.csv"]) == "coil-currents"
