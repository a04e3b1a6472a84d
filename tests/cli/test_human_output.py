"""Output for people (issue 50): without ``--json`` no command prints a Python repr (``{'...``,
``[...]``, ``PosixPath(``, ``np.float64(``); nested results are indented, lists joined, numbers
short, paths relative to where the user stands."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from elastica_magnetic.cli import main
from elastica_magnetic.cli.app import human_lines

REPO = Path(__file__).resolve().parents[2]
FIELD_CSV = REPO / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT" / "magnetic_field.csv"
CALIBRATION = REPO / "stm32" / "calibration" / "yao2023.json"
REPR = re.compile(r"\{'|\['|\[\{|\(\{|PosixPath\(|np\.float|array\(|<\w+ object at")


def test_nested_results_are_lines_not_reprs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = {"case": "m1-4mT", "out": tmp_path / "gen", "fields": str(tmp_path / "gen" / "f.csv"),
              "distance_m": 0.012345678901, "diverged": None, "ok": True, "periods_s": [0.5, 1.0],
              "actor_choice": {"checkpoint": "final", "distances_m": {"final": 0.01, "best": None}},
              "runs": [{"period_s": 0.5, "mid_dx_m": 0.002}, {"period_s": 1.0, "mid_dx_m": 0.003}],
              "warnings": []}
    lines = human_lines(result)
    text = "\n".join(lines)
    assert not REPR.search(text), text
    assert lines[:7] == ["case: m1-4mT", "out: gen", "fields: gen/f.csv", "distance_m: 0.0123457",
                         "diverged: none", "ok: yes", "periods_s: 0.5, 1"]
    assert lines[7:12] == ["actor_choice:", "  checkpoint: final", "  distances_m:", "    final: 0.01",
                           "    best: none"]
    assert lines[12:] == ["runs:", "  - period_s: 0.5", "    mid_dx_m: 0.002", "  - period_s: 1",
                          "    mid_dx_m: 0.003", "warnings: none"]


@pytest.mark.parametrize("argv", [
    ["case", "list"],
    ["case", "show", "m1-4mT"],
    ["case", "show", "m1-4mT-goto"],  # its [training.td3] table was printed as a dict
    ["field", "simulate", "--duration", "0.02", "--physics", "training", "--out", "{tmp}/sim"],
    ["field", "replay", str(FIELD_CSV), "--duration", "0.02", "--physics", "training", "--out",
     "{tmp}/replay"],
    ["policy", "generate", "m1-4mT", "--duration", "0.02", "--out", "{tmp}/gen", "--no-progress"],
    ["policy", "export", "m1-4mT", "--out", "{tmp}/export", "--no-progress"],
    ["policy", "seeds", "m1-4mT"],
    ["policy", "notes", "m1-4mT"],
    ["real", "firmware", str(FIELD_CSV), "--calibration", str(CALIBRATION), "--out", "{tmp}/fw"],
    ["real", "robustness", "m1-4mT", "--duration", "0.02", "--no-corners", "--workers", "1", "--out",
     "{tmp}/rob", "--no-progress"],
], ids=lambda argv: " ".join(argv[:3] if argv[1] == "show" else argv[:2]))
def test_no_command_prints_a_repr(argv, tmp_path, capsys):
    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 0
    out = capsys.readouterr().out
    assert out.strip() and not REPR.search(out), out


def _msr_process(*argv: str, stdout) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "elastica_magnetic.cli", *argv], stdout=stdout,
                            stderr=subprocess.PIPE, text=True)


def test_a_reader_that_goes_away_ends_the_command_quietly():
    """Round 4, V11: `msr case list | head -1` printed "error: [Errno 32] Broken pipe"; a Unix
    tool whose reader went away stops quietly (exit status 128 + SIGPIPE)."""
    process = _msr_process("case", "list", stdout=subprocess.PIPE)
    process.stdout.close()  # the reader leaves before the first line
    _, err = process.communicate(timeout=120)
    assert process.returncode == 141 and err == "", err


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs /dev/full")
def test_a_full_standard_output_is_named_as_standard_output():
    """Round 4, V11: "[Errno 28] No space left on device" alone read as if a result could not be
    written."""
    with open("/dev/full", "w") as full:
        process = _msr_process("case", "list", stdout=full)
        _, err = process.communicate(timeout=120)
    assert process.returncode == 2
    assert err.strip() == ("msr case list: error: cannot write to standard output: No space left "
                           "on device (where it is redirected to)"), err


def test_the_case_list_is_a_table_whose_columns_align(capsys):
    """The case names of the catheters (21 characters) pushed their rows' columns past the others'."""
    assert main(["case", "list"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if line.strip()]
    assert len(lines) >= 2
    assert len({line.index(" target ") for line in lines}) == 1, lines
    # the robot column starts at the same place in every row, after the longest name
    longest = max(len(line.split()[0]) for line in lines)
    assert all(line[longest] == " " and line[longest + 1] != " " for line in lines), lines


def test_case_show_gives_the_task_settings_their_units(capsys):
    assert main(["case", "show", "m1-4mT-goto"]) == 0
    task = next(line for line in capsys.readouterr().out.splitlines() if line.strip().startswith("task"))
    assert "distance 0.015 m," in task and "tolerance 0.002 m," in task and "episode_duration 30 s" in task
    assert "angle_low -3.14159 rad" in task


def test_the_yardstick_line_is_a_crawl_cases_alone(capsys, tmp_path):
    """A goto case printed "yardstick 0 mm in 10 s": it is judged on a ring of targets, not on a distance."""
    assert main(["case", "show", "m1-4mT-goto"]) == 0
    assert "  yardstick " not in capsys.readouterr().out
    assert main(["case", "show", "m1-4mT"]) == 0
    assert "  yardstick    20.5 mm in 10 s" in capsys.readouterr().out
    spec = REPO / "rl" / "specs" / "m1-4mT-goto.toml"
    assert main(["case", "check", str(spec), "--no-sag"]) == 0
    assert "  yardstick " not in capsys.readouterr().out


def test_a_round_rod_and_an_arm_are_described_in_words(capsys):
    """A round catheter showed "(band ...)" beside its own mass and stiffness (it has no band), and
    its magnet "pointing [1.0, 0.0, 0.0]" (a Python list)."""
    assert main(["case", "show", "catheter-magnet-reach"]) == 0
    out = capsys.readouterr().out
    assert "(band " not in out and "pointing (1, 0, 0)," in out
    assert main(["case", "show", "m1-4mT"]) == 0
    assert "(band 238.1 mg)" in capsys.readouterr().out  # a band keeps the comparison
