"""Round 22 of held-out tries (issue 48), the findings of the commands: each test fails without its
fix (docs/errors.md, "A twenty-second round of tries"). D2 and V2 (a lengthened loop) are in
tests/rl/loop/test_msr_loop.py."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.variations import VariationError, parse_variation, resolve_variations
from elastica_magnetic_rl.shipping.policy_files import POLICIES_DIR
from elastica_magnetic_rl.shipping.seed_report import case_seeds
from smoke import NOT_RESIDUAL

from elastica_magnetic.cli import main as msr
from elastica_magnetic.io import atomic_write_json

REGULARIZED = [*NOT_RESIDUAL, "--set", "yardstick_regularization=0.4", "--set", "yardstick_warmup=50",
               "--set", "batch_size=32", "--set", "learning_starts=100", "--set", "eval_every=0", "--threads",
               "1"]


def _snapshot(folder):
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _strict(text: str):
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_a_regularized_run_beyond_its_buffer_is_refused_before_any_work(tmp_path, capsys):
    """D1: ``yardstick_regularization`` with a ``buffer_size`` below the run's steps was refused
    inside the worker, after the run folder was made; on ``--resume --steps N`` after
    ``summary.json`` and the seed's record were rewritten (a NaN failure entry), advising a larger
    buffer, which a resume cannot take. Now refused before any work, a resume told its limit.
    S3: the summary of a run with no finished episode held ``NaN`` (not JSON): now ``null``."""
    fresh = tmp_path / "fresh"
    assert msr(["train", "--case", "m1-4mT-goto", "--seeds", "1", "--steps", "300", "--set",
                "buffer_size=260", *REGULARIZED, "--out", str(fresh)]) == 2
    assert "--set buffer_size=260 holds fewer than --steps 300" in capsys.readouterr().err
    assert not fresh.exists()
    run = tmp_path / "run"
    assert msr(["train", "--case", "m1-4mT-goto", "--seeds", "1", "--steps", "300", "--set",
                "buffer_size=300", *REGULARIZED, "--out", str(run)]) == 0, capsys.readouterr().err
    summary = _strict((run / "m1-4mT-goto" / "summary.json").read_text())
    assert summary["seeds"][0]["episodes"] == 0 and summary["seeds"][0]["final_mean_return"] is None
    before = _snapshot(run)
    capsys.readouterr()
    assert msr(["train", "--case", "m1-4mT-goto", "--seeds", "1", "--steps", "400", "--resume",
                "--threads", "1", "--out", str(run)]) == 2
    err = capsys.readouterr().err
    assert "the run's buffer_size 300 (a resumed run keeps it)" in err, err
    assert "give --steps of at most 300, or train a new run" in err, err
    assert _snapshot(run) == before


def test_a_spec_s_regularization_beyond_its_buffer_is_refused_where_it_is_read(tmp_path):
    """D1: ``msr case check`` passed a spec whose ``[training.td3]`` regularization could not hold
    its warm-up through ``[training] steps``."""
    from elastica_magnetic.specfile import SpecError

    text = load_case("m1-4mT-reach").toml() + ("\n[training.td3]\nbuffer_size = 50000\n"
                                              "yardstick_regularization = 0.4\nyardstick_warmup = 4000\n")
    (tmp_path / "gr.toml").write_text(text)
    with pytest.raises(SpecError, match=r"buffer_size: .*holds fewer than the \[training\] steps = 100000"):
        load_case(tmp_path / "gr.toml")


def test_a_range_that_varies_nothing_is_refused():
    """S1: ``--vary magnetization=1:1`` studied the nominal robot alone and exited 0."""
    spec = load_case("m1-4mT").to_dict()
    with pytest.raises(VariationError, match=r"--vary magnetization=1:1 varies nothing"):
        resolve_variations([parse_variation("magnetization=1:1")], spec)
    density = spec["robot"]["density"]
    with pytest.raises(VariationError, match=r"varies nothing"):
        resolve_variations([parse_variation(f"robot.density=abs:{density}:{density}")], spec)
    with pytest.raises(VariationError, match=r"--fit robot.density=1:1 fits nothing"):
        resolve_variations([parse_variation("robot.density=1:1")], spec, "--fit")
    # a fixed factor away from nominal still is one variant
    assert resolve_variations([parse_variation("magnetization=1.1:1.1")], spec)


def _policy_copy(tmp_path, case: str):
    """A shipped policy's own files (no seeds), copied as a user does."""
    folder = tmp_path / "pols" / case
    folder.mkdir(parents=True)
    for name in ("policy.json", "actor.pt"):
        shutil.copy(POLICIES_DIR / case / name, folder / name)
    return folder


def test_seeds_of_another_case_are_refused_in_a_policy_s_seeds_folder(trained, tmp_path, capsys):
    """S2: ``msr policy export-seeds runs/m1-4mT --out POLICY(m2-4mT)/seeds/ten`` wrote the campaign
    there, and ``msr policy seeds m2-4mT`` then counted it as one of m2-4mT's recipes."""
    policy = _policy_copy(tmp_path, "m2-4mT")
    case_dir = tmp_path / "runs" / "m1-4mT"
    shutil.copytree(trained / "m1-4mT", case_dir)
    capsys.readouterr()
    assert msr(["policy", "export-seeds", str(case_dir), "--out", str(policy / "seeds" / "ten"),
                "--duration", "0.05", "--workers", "1", "--no-progress"]) != 0
    err = capsys.readouterr().err
    assert "of case 'm2-4mT', and this result is of case 'm1-4mT'" in err, err
    assert "accurate physics" not in err  # refused before any evaluation
    assert not (policy / "seeds").exists()


def test_a_campaign_of_another_duration_is_left_out_of_the_seed_table(tmp_path):
    """V3: one campaign exported with ``--duration`` other than 10 s made ``msr policy seeds`` fail
    for the whole case, calling msr's own ``seeds.json`` malformed."""
    root = tmp_path / "pols"
    shutil.copytree(POLICIES_DIR / "m1-4mT" / "seeds", root / "m1-4mT" / "seeds")
    short = root / "m1-4mT" / "seeds" / "mine"
    short.mkdir()
    (short / "seeds.json").write_text(json.dumps([{"seed": 0, "steps": 300, "distance_m": 0.0001,
                                                    "duration_s": 0.1, "actor": "seed0"}]))
    left_out: list[str] = []
    groups = case_seeds(load_case("m1-4mT"), root, left_out)
    assert "mine" not in [g.folder for g in groups] and "paper" in [g.folder for g in groups]
    assert len(left_out) == 1 and "measured over 0.1 s, not the 10 s this table compares" in left_out[0]


def test_a_misspelt_optional_key_is_answered_with_the_key(tmp_path):
    """V1: ``[robot.interaction] cut_off`` listed the table's keys without ``cutoff`` (read only
    when given) and suggested nothing."""
    from elastica_magnetic.specfile import SpecError

    text = load_case("m1-4mT").toml() + "\n[robot.interaction]\ncut_off = 0.001\n"
    (tmp_path / "m1.toml").write_text(text)
    with pytest.raises(SpecError, match=r"cut_off: unknown key; did you mean cutoff\? \(this table takes: "
                                        r"band_source, cutoff, self_contact_damping"):
        load_case(tmp_path / "m1.toml")
    data = load_case("m1-4mT").to_dict()
    data["robot"]["poison_ratio"] = 0.45
    with pytest.raises(SpecError, match=r"poison_ratio: unknown key; did you mean poisson_ratio\?"):
        load_case(data)


def _coil_csv(path, names, rows):
    path.write_text(",".join(["t_s", *names]) + "\n"
                    + "".join(",".join([f"{0.01 * i:.2f}", *row]) + "\n" for i, row in enumerate(rows)))
    return path


def test_coil_paths_numbered_from_one_or_never_driven_are_named(tmp_path):
    """V4: a coil path numbered from 1 was read as a field CSV (asked for mag_x, mag_y, mag_z).
    V5: a coil path of zero currents went through a fit whose warnings advised more evaluations."""
    from elastica_magnetic_rl.sim2real.coil_path import CoilDrive, read_coil_path
    from elastica_magnetic_rl.sim2real.tracking import TrajectoryError

    from elastica_magnetic.drive_columns import is_coil_currents

    shifted = _coil_csv(tmp_path / "one.csv", [f"current_{k + 1}_A" for k in range(8)],
                        [[f"{math.sin(0.3 * i * (k + 1)):.4f}" for k in range(8)] for i in range(5)])
    assert is_coil_currents(shifted)
    with pytest.raises(TrajectoryError, match="a coil path numbers its coils from 0"):
        read_coil_path(shifted)
    spec = load_case("catheter-coils-reach").to_dict()
    names = [f"current_{k}_A" for k in range(8)] + ["insertion_m"]
    zero = read_coil_path(_coil_csv(tmp_path / "zero.csv", names, [["0.0"] * 9] * 5))
    with pytest.raises(TrajectoryError, match="every current is 0 A: the coils never made a field"):
        CoilDrive(zero).check_spec(spec)
    driven = read_coil_path(_coil_csv(tmp_path / "driven.csv", names, [["0.5"] * 8 + ["0.0"]] * 5))
    CoilDrive(driven).check_spec(spec)


def test_json_results_are_strict():
    """S3: a value not measured (NaN) or infinite is written as null, numpy's floats included."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        path = atomic_write_json(Path(folder) / "r.json", {"a": float("nan"), "b": [np.float32("inf"), 1.5],
                                                           "c": (np.nan, "x")})
        assert _strict(path.read_text()) == {"a": None, "b": [None, 1.5], "c": [None, "x"]}
