"""The coils' recorded currents: read, replayed as the environment played them, and the coils' gain
identified from a noisy tip path (``msr real identify`` on a coil-currents case)."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.cases.variations import default_variations
from elastica_magnetic_rl.sim2real.coil_path import (
    CoilDrive,
    CoilPath,
    read_coil_path,
    record_coil_steering,
    simulate_coil_tips,
    write_coil_path,
)
from elastica_magnetic_rl.sim2real.identify import load_spec
from elastica_magnetic_rl.sim2real.tracking import TrajectoryError
from spec_texts import quick_catheter

from elastica_magnetic.cli import main
from elastica_magnetic.specfile import SpecError

TARGET = (0.05, 0.008, -0.006)  # m, inside the shipped case's target box
TRUE_GAIN = 1.06  # the "real" coils make 6 % more field per ampere than the spec's windings
NOISE_M = 5e-5  # the tracker's noise per coordinate: 0.05 mm


@pytest.fixture(scope="module")
def quick_spec() -> dict:
    return quick_catheter("catheter-coils-reach", "coils-quick")


@pytest.fixture(scope="module")
def steered(quick_spec):
    """The yardstick steering the quick catheter toward TARGET for 0.6 s: its currents and tips."""
    return record_coil_steering(case_from_dict(quick_spec), TARGET, physics="training", duration=0.6)


def _scaled(spec: dict, gain: float) -> dict:
    out = copy.deepcopy(spec)
    for coil in out["actuation"]["coils"]:
        coil["turns"] *= gain
    return out


def test_replayed_currents_are_the_environment_s_motion(steered, quick_spec):
    """The recorded currents (and the stage) replayed on the batched rod give the tips the
    environment gave while the yardstick steered, to rounding; a 5 % gain shows above the noise."""
    path, tips = steered
    assert path.currents.shape[1] == 8 and np.ptp(path.currents, axis=0).max() > 0.5  # A: they moved
    assert path.insertion is not None and np.ptp(path.insertion) > 1e-4
    replayed = simulate_coil_tips(quick_spec, "training", path)
    np.testing.assert_allclose(replayed, tips, rtol=0, atol=1e-12)
    assert np.abs(simulate_coil_tips(_scaled(quick_spec, 1.05), "training", path) - tips).max() > NOISE_M


def excitation() -> CoilPath:
    """What a lab plays to identify its coils: every coil a sine of 2 A (a quarter of the limit) at
    its own frequency for 0.6 s, ramped in over 0.1 s, the stage still. (The steering yardstick's
    own path is a poor one: it holds the tip along a field strong enough to align it, where a 6 %
    stronger field moves the tip 0.05 mm RMS, the tracker's noise; here 0.21 mm.)"""
    t = np.arange(61) * 0.01
    currents = np.stack([2.0 * np.sin(2 * np.pi * (1.0 + 0.4 * k) * t + k) * np.minimum(t / 0.1, 1.0)
                         for k in range(8)], axis=1)
    return CoilPath("excitation", t, currents, np.zeros_like(t))


def _measured_files(tmp_path, quick_spec):
    """The coil path, and the tip path of coils TRUE_GAIN x the spec's with NOISE_M noise (50 frames
    per second), as a lab would record them."""
    path = excitation()
    tips = simulate_coil_tips(_scaled(quick_spec, TRUE_GAIN), "training", path)[::2]
    noisy = tips + np.random.default_rng(11).normal(0.0, NOISE_M, tips.shape)
    lines = ["t_s,tip_x_m,tip_y_m,tip_z_m"] + [f"{t:.2f},{x:.9g},{y:.9g},{z:.9g}"
                                               for t, (x, y, z) in zip(path.times[::2], noisy, strict=True)]
    (tmp_path / "tip.csv").write_text("\n".join(lines) + "\n")
    spec_file = tmp_path / "coils.toml"
    spec_file.write_text(case_from_dict(quick_spec).toml(with_name=True))
    return write_coil_path(tmp_path / "coils.csv", path), tmp_path / "tip.csv", spec_file


@pytest.mark.slow
def test_identify_recovers_the_coils_gain(tmp_path, quick_spec):
    """From a 0.05 mm-noisy tip path of coils 6 % stronger than the spec's, ``msr real identify
    --fit coils`` recovers their gain within 3 %, its interval holding the truth."""
    coils, tip, spec_file = _measured_files(tmp_path, quick_spec)
    assert main(["real", "identify", str(coils), str(tip), "--robot", str(spec_file), "--fit", "coils",
                 "--out", str(tmp_path / "id"), "--starts", "1", "--max-evaluations", "40",
                 "--noise-m", str(NOISE_M), "--no-confirm", "--no-progress", "--json"]) == 0
    report = json.loads((tmp_path / "id" / "identify.json").read_text())
    fitted = report["fitted"]["coils"]
    assert fitted["keys"] == [f"actuation.coils.{k}.turns" for k in range(8)]
    assert abs(fitted["factor"] / TRUE_GAIN - 1.0) < 0.03, fitted["factor"]
    assert fitted["identifiable"] and fitted["interval"][0] <= TRUE_GAIN <= fitted["interval"][1]
    assert report["coil_path"] == str(coils)
    assert "turns = 5" in (tmp_path / "id" / "identified.toml").read_text()
    assert report["optimizer"]["starts_agree"] is None  # one start: nothing compared (round 29 S1)


def test_identify_records_the_path_s_warnings_in_its_result(tmp_path, quick_spec, capsys):
    """Round 29 S2: the warnings on the coil path (faster than the case's max_slew) were printed but
    left out of identify.json's warnings, the record a user keeps of the fit; and with one start it
    said "the starts agree" (S1)."""
    slow = copy.deepcopy(quick_spec)
    slow["actuation"]["max_slew"] = 10.0  # A/s: the excitation's sines change faster
    coils, tip, spec_file = _measured_files(tmp_path, slow)
    assert main(["real", "identify", str(coils), str(tip), "--robot", str(spec_file), "--fit", "coils",
                 "--out", str(tmp_path / "id"), "--starts", "1", "--max-evaluations", "10",
                 "--no-confirm", "--no-progress"]) == 0
    out, err = capsys.readouterr()
    said = [line for line in err.splitlines() if "faster than the case's max_slew" in line]
    assert len(said) == 1, err
    kept = json.loads((tmp_path / "id" / "identify.json").read_text())["warnings"]
    assert any("faster than the case's max_slew (10 A/s)" in w for w in kept), kept
    assert "one start: their agreement not tested" in out and "the starts agree" not in out, out


def _write(path, header, rows):
    path.write_text(header + "\n" + "".join(",".join(f"{v:g}" for v in row) + "\n" for row in rows))
    return path


def test_a_coil_path_that_cannot_be_the_spec_s_is_refused_by_line(tmp_path, quick_spec):
    header = "t_s," + ",".join(f"current_{k}_A" for k in range(8)) + ",insertion_m"
    rows = [(0.01 * k, *([0.5] * 8), 0.0) for k in range(4)]
    good = CoilDrive(read_coil_path(_write(tmp_path / "good.csv", header, rows)))
    good.check_spec(quick_spec)
    with pytest.raises(TrajectoryError, match=r"line 3, column current_2_A: 2500 A; .* milliamperes"):
        read_coil_path(_write(tmp_path / "ma.csv", header, [rows[0], (0.01, 0.5, 0.5, 2500, *[0.5] * 5, 0)]))
    with pytest.raises(TrajectoryError, match="current columns current_0_A, current_2_A"):
        read_coil_path(_write(tmp_path / "gap.csv", "t_s,current_0_A,current_2_A", [(0, 1, 1), (0.01, 1, 1)]))
    with pytest.raises(TrajectoryError, match=r"line 3: t_s 0.02 s, expected 0.01 s"):
        read_coil_path(_write(tmp_path / "grid.csv", header, [rows[0], (0.02, *rows[1][1:])]))
    three = CoilDrive(read_coil_path(_write(tmp_path / "three.csv", "t_s,current_0_A,current_1_A,current_2_A",
                                            [(0, 1, 1, 1), (0.01, 1, 1, 1)])))
    with pytest.raises(TrajectoryError, match="3 current column.s., and the spec has 8 coils"):
        three.check_spec(quick_spec)
    with pytest.raises(TrajectoryError, match="a coil path drives a case steered by coil currents"):
        good.check_spec(load_case("catheter-magnet-reach").to_dict())
    with pytest.warns(UserWarning, match="beyond the case's current_limit"):
        hot = _write(tmp_path / "hot.csv", header, [rows[0], (0.01, 9.5, *[0.5] * 7, 0.0)])
        CoilDrive(read_coil_path(hot)).check_spec(quick_spec)
    # round 27 S3: a current changing faster than max_slew (1000 A/s) was accepted without a word
    with pytest.warns(UserWarning, match=r"fast.csv: line 3: current_0_A changes at 1500 A/s, faster than "
                                         r"the case's max_slew \(1000 A/s\)"):
        swing = [(0.0, -7.5, *[0.5] * 7, 0.0), (0.01, 7.5, *[0.5] * 7, 0.0)]
        fast = _write(tmp_path / "fast.csv", header, swing)
        CoilDrive(read_coil_path(fast)).check_spec(quick_spec)
    with pytest.raises(SpecError, match="a coil path drives a case steered by coil currents"):
        load_spec("catheter-magnet-reach", steered_by="coil-currents")
    with pytest.raises(SpecError, match="the coils' recorded currents"):
        load_spec("catheter-coils-reach")


def test_a_hand_written_path_bends_the_tip_toward_the_field_and_the_default_set_varies_the_gain():
    """Coils 0 and 4 (opposite corners across the tip) driven alone turn the tip; the default
    robustness set of a coil case varies the coils' gain, of a magnet case not."""
    spec = copy.deepcopy(load_case("catheter-coils-reach").to_dict())
    del spec["actuation"]["insertion"], spec["actuation"]["insertion_speed"]
    spec["robot"]["n_elements"] = 6
    spec["physics"]["training"]["dt"] = 4e-5
    times = np.arange(31) * 0.01
    currents = np.zeros((times.size, 8))
    currents[:, 0] = np.minimum(times / 0.1, 1.0) * 6.0
    path = CoilPath("hand", times, currents)
    CoilDrive(path).check_spec(spec)
    tips = simulate_coil_tips(spec, "training", path)
    assert np.linalg.norm(tips[-1] - tips[0]) > 1e-4 and np.isfinite(tips).all()
    names = [v.name for v in default_variations(load_case("catheter-coils-reach").to_dict())]
    assert "coils" in names and "coils" not in [v.name for v in default_variations(
        load_case("catheter-magnet-reach").to_dict())]
