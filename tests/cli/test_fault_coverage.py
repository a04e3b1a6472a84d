"""Every command that writes is in the fault-injection suite (issue 48), checked against the
parser's own list: a new writing command fails :func:`test_every_writing_command_has_a_fault_test`
until a test kills it while it writes. The result-folder writers not covered elsewhere are run here
over an earlier result of theirs, in a real process (``tests/faults.py``), with SIGKILL at the
first file of their temporary folder, then SIGINT, then a full disk: the earlier result survives
byte for byte, nothing is left beside it, a file of the user's beside it is untouched.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest
from faults import Fault

from elastica_magnetic.cli import OUTPUT_TYPES, listed_commands, main
from elastica_magnetic.field_csv import write_field_csv

pytestmark = pytest.mark.skipif(os.name != "posix", reason="fork and signals are POSIX")

#: Writing command -> the fault-injection tests that cover it ("tests/PATH.py::FUNCTION").
FAULT_TESTS: dict[str, tuple[str, ...]] = {
    "field replay": ("cli/test_commands_integrity.py::test_replay_over_another_robots_result_is_refused",),
    "field simulate": ("cli/test_commands_integrity.py::test_simulate_killed_then_the_next_run_recovers",
                 "cli/test_commands_integrity.py::test_a_full_filesystem_keeps_the_old_result"),
    "validate": ("cli/test_fault_coverage.py::test_a_writer_killed_interrupted_or_on_a_full_disk",),
    "policy generate": ("cli/test_fault_coverage.py::test_a_writer_killed_interrupted_or_on_a_full_disk",),
    "field baseline": ("cli/test_fault_coverage.py::test_a_writer_killed_interrupted_or_on_a_full_disk",),
    "policy demo": ("cli/test_fault_coverage.py::test_a_writer_killed_interrupted_or_on_a_full_disk",),
    "real robustness": ("cli/test_fault_coverage.py::test_a_writer_killed_interrupted_or_on_a_full_disk",),
    "real identify": ("cli/test_fault_coverage.py::test_a_writer_killed_interrupted_or_on_a_full_disk",),
    "real stream": ("cli/test_fault_coverage.py::test_stream_log_interrupted_keeps_the_old_log",),
    "policy figures": ("cli/test_writer_faults.py::test_figures_interrupted_leave_the_earlier_figures",),
    "policy seeds": ("cli/test_fault_coverage.py::test_seeds_figures_interrupted_leave_the_earlier_ones",),
    "real firmware": ("cli/test_writer_faults.py::test_killed_while_writing_then_the_next_run_cleans_up",
                        "cli/test_writer_faults.py::test_interrupted_or_full_disk_keeps_the_old_result_whole"),
    "real calibrate": ("cli/test_writer_faults.py::test_killed_while_writing_then_the_next_run_cleans_up",),
    "policy export": ("rl/shipping/test_command_faults.py::"
               "test_export_killed_while_building_and_between_the_renames",
               "rl/shipping/test_export_full_disk.py::test_export_on_a_full_disk_is_a_named_error"),
    "policy export-seeds": ("rl/shipping/test_command_faults.py::"
                     "test_export_seeds_killed_while_building_and_between_the_renames",),
    "policy ship": ("rl/shipping/test_command_faults.py::"
                    "test_ship_killed_mid_swap_is_finished_by_the_next_reader",
                    "rl/shipping/test_export_full_disk.py::test_ship_on_a_full_disk_is_a_named_error"),
    "train": ("rl/sweep/test_training_faults.py::"
              "test_a_full_disk_then_a_kill_mid_checkpoint_keep_the_last_good_one",),
    "refine": ("rl/cli/test_run_writer_faults.py::test_refine_killed_mid_checkpoint_resumes",),
    "policy diagnose": ("rl/reports/test_diagnostics.py::"
                 "test_diagnose_figures_interrupted_leave_the_earlier_ones",),
    "policy notes": ("rl/cli/test_run_writer_faults.py::test_notes_interrupted_leave_the_policy_whole",),
    "design": ("rl/design/test_design_run.py::"
               "test_a_design_killed_mid_checkpoint_resumes_to_the_same_result",),
    # interrupted in-process (Ctrl-C at a step; killed between a step and its record): each step
    # is one of the writers above, through the same mechanisms
    "loop": ("rl/loop/test_msr_loop.py::test_an_interrupted_loop_keeps_its_finished_steps",
             "rl/loop/test_msr_loop.py::test_a_training_killed_before_its_record_is_resumed_not_restarted"),
}

TESTS = Path(__file__).resolve().parents[1]
ROOT = TESTS.parent
PUBLISHED = ROOT / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT"


def _writing_commands() -> set[str]:
    """Commands with an option parsed by the path rule, or that rewrite what they are given."""
    found = {"policy notes"}  # writes into the policy folder it names (a positional argument)
    for name, parser in listed_commands().items():
        if any(a.type in OUTPUT_TYPES for a in parser._actions):
            found.add(name)
    return found


def test_every_writing_command_has_a_fault_test():
    assert set(FAULT_TESTS) == _writing_commands()
    for tests in FAULT_TESTS.values():
        for test in tests:
            path, _, function = test.partition("::")
            assert (TESTS / path).is_file(), test
            assert f"def {function}(" in (TESTS / path).read_text(), test


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _rotating_field(path: Path, seconds: float = 0.3) -> Path:
    t = np.arange(int(round(100 * seconds))) / 100
    write_field_csv(path, 4e-3 * np.stack([np.cos(-4 * np.pi * t), np.sin(-4 * np.pi * t), 0 * t],
                                          axis=1))
    return path


def _identify_inputs(lab: Path) -> list[str]:
    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.fields import TabulatedField
    from elastica_magnetic.openloop import run_open_loop, write_trajectory_csv

    fields = _rotating_field(lab / "fields.csv")
    run = run_open_loop(load_case("m1-4mT").robot_spec("training"),
                        TabulatedField.from_csv(fields), 0.3)
    write_trajectory_csv(run.trajectory, lab / "trajectory.csv")
    return ["real", "identify", str(fields), str(lab / "trajectory.csv"), "--robot", "m1-4mT", "--fit",
            "friction",
            "--max-evaluations", "10", "--no-confirm", "--no-progress"]


#: Cheap invocations of the result-folder writers (an earlier result is made with the same).
WRITERS = {
    "generate": lambda lab: ["policy", "generate", "m1-4mT", "--duration", "0.05", "--physics", "training",
                             "--no-gif", "--no-progress"],
    "baseline": lambda lab: ["field", "baseline", "--case", "m1-4mT", "--period", "0.05", "--duration",
                             "0.05",
                             "--physics", "training", "--no-figures", "--no-progress"],
    "demo": lambda lab: ["policy", "demo", "--duration", "0.05", "--no-progress"],
    "robustness": lambda lab: ["real", "robustness", str(_rotating_field(lab / "w.csv")), "--case",
                               "m1-4mT", "--duration", "0.05", "--vary", "density=0.9:1.1",
                               "--no-corners", "--workers", "1", "--no-progress"],
    "identify": _identify_inputs,
    "validate": lambda lab: ["validate", "spatial-fields", "--quick"],
}


@pytest.mark.parametrize("command", sorted(WRITERS))
def test_a_writer_killed_interrupted_or_on_a_full_disk(fault_server, tmp_path, capsys, command):
    lab = tmp_path / "lab"
    lab.mkdir()
    (lab / "notes.txt").write_text("the user's notes\n")
    argv = [*WRITERS[command](lab), "--out", str(lab / "res")]
    assert main(argv) in (0, 1), capsys.readouterr().err  # the earlier result (1: a failed check)
    capsys.readouterr()
    before = snapshot(lab)
    # the demo replaces its own earlier demo unasked (the README's first command is re-runnable)
    again = argv if command == "demo" else [*argv, "--force"]
    for fault, status in ((Fault("open", r"\.res\.msr-new-", "SIGKILL", nth=1), -signal.SIGKILL),
                          (Fault("open", r"\.res\.msr-new-", "SIGINT", nth=1), 130),
                          (Fault("enospc", r"\.res\.msr-new-", after=50), 2)):
        done = fault_server.run(again, fault)
        assert done.returncode == status, (fault, done.stderr)
        assert "Traceback" not in done.stderr, done.stderr
        assert {k: v for k, v in snapshot(lab).items() if not k.startswith(".")} == before
        if status != -signal.SIGKILL:
            assert sorted(p.name for p in lab.iterdir()) == sorted(
                {k.split("/")[0] for k in before}), "something left beside the result"
    if command != "demo":
        assert main(argv) == 2  # an earlier result is refused without --force
        assert "pass --force" in capsys.readouterr().err
    assert snapshot(lab) == before


def test_stream_log_interrupted_keeps_the_old_log(tmp_path, monkeypatch):
    """Ctrl-C while the board's lines go into the new log (a board that answers: in-process, the
    stream stands in for it; a port that does not open writes no log, tests/hardware/
    test_stream.py): the earlier log stays byte for byte, no temporary is left."""
    import elastica_magnetic.hardware.stream as stream
    from elastica_magnetic.result_file import result_file

    log = tmp_path / "board.log"
    earlier = "MSR-FW 1.0 the earlier stream's log\nPONG\n"  # a board log: --force replaces it
    with result_file(log) as written:  # as msr wrote it
        written.path.write_text(earlier)

    def answered_then_interrupted(port, field, *, log_path=None, **kwargs):
        with open(log_path, "w") as handle:  # what the board said so far
            handle.write("MSR-FW 1.0 a new stream\nPONG\n")
        raise KeyboardInterrupt

    monkeypatch.setattr(stream, "stream_field", answered_then_interrupted)
    argv = ["real", "stream", str(PUBLISHED / "magnetic_field.csv"), "--port", "socket://127.0.0.1:9",
            "--timeout", "2", "--log", str(log), "--force", "--no-progress"]
    assert main(argv) == 130
    assert log.read_text() == earlier
    assert sorted(p.name for p in tmp_path.iterdir()) == [".msr-files.json", "board.log"]


def test_seeds_figures_interrupted_leave_the_earlier_ones(fault_server, tmp_path, capsys):
    figures = tmp_path / "figs"
    figures.mkdir()
    (figures / "notes.txt").write_text("the user's notes\n")
    assert main(["policy", "seeds", "m1-4mT", "--figure", str(figures), "--json"]) == 0
    capsys.readouterr()
    before = snapshot(figures)
    done = fault_server.run(["policy", "seeds", "m1-4mT", "--figure", str(figures), "--force"],
                            Fault("open", r"\.msr-files-", "SIGINT", nth=1))
    assert done.returncode == 130, done.stderr
    assert snapshot(figures) == before
