"""One path rule for every writer (issue 48): an output location is made absolute and normalized
once, where the options are parsed, and every check and write uses that one path.

Spelled ``DIR/missing/..`` (a path that resolves to ``DIR``), ``--out`` used to pass the
command's check of ``DIR`` (the spelling did not exist) while the swap renamed ``DIR`` itself
away: every command that writes a result folder deleted the user's files there. Here every
spelling of the same folder (relative, absolute, ``x/missing/..``, ``./x/``, a link to it, ...)
must be treated as that folder: refused, naming it, and nothing in it touched.

The walk over the parser makes sure a new command cannot forget the rule: every option that names
where a command writes is parsed with :func:`elastica_magnetic.cli.output_path`, and every
command with such an option is exercised below or names the test that covers it.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from elastica_magnetic.cli import OUTPUT_TYPES, listed_commands, main
from elastica_magnetic.command_names import spelling
from elastica_magnetic.io import display_path, normalized_path

ROOT = Path(__file__).resolve().parents[2]
PUBLISHED = ROOT / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT"
FIELD_CSV = str(PUBLISHED / "magnetic_field.csv")
SEEDS = str(ROOT / "rl" / "policies" / "m1-4mT" / "seeds" / "paper")
CALIBRATION = str(ROOT / "stm32" / "calibration" / "default.json")

#: Option names that say "this is where the command writes".
OUTPUT_OPTION_NAMES = {"--out", "--dest", "--figure", "--log", "--codes-out", "--set-yardstick"}

#: Every writing command, as argv reaching its output check with the output ``{o}`` (a folder) or
#: ``{f}`` (a file): (argv, what the output is, the option named in the refusal). Cheap: each is
#: refused before any simulation.
WRITERS: dict[str, tuple[list[str], str, str]] = {
    "replay": (["field", "replay", FIELD_CSV, "--duration", "0.01", "--out", "{o}", "--force"], "folder",
               "--out"),
    "simulate": (["field", "simulate", "--duration", "0.01", "--out", "{o}", "--force"], "folder", "--out"),
    "validate": (["validate", "--quick", "--out", "{o}", "--force"], "folder", "--out"),
    "generate": (["policy", "generate", "m1-4mT", "--duration", "0.01", "--out", "{o}", "--force"], "folder",
                 "--out"),
    "baseline": (["field", "baseline", "--case", "m1-4mT", "--period", "0.05", "--duration", "0.05", "--out",
                  "{o}", "--force"], "folder", "--out"),
    "baseline --set-yardstick": (["field", "baseline", "--case", "m1-4mT", "--set-yardstick", "{f}"], "file",
                                 "--set-yardstick"),
    "figures": (["policy", "figures", SEEDS, "--out", "{o}"], "files", "--out"),
    "demo": (["policy", "demo", "--duration", "0.01", "--out", "{o}"], "folder", "--out"),
    "seeds": (["policy", "seeds", "m1-4mT", "--figure", "{o}"], "files", "--figure"),
    "export": (["policy", "export", "m1-4mT", "--out", "{o}", "--force"], "folder", "--out"),
    "export-firmware": (["real", "firmware", FIELD_CSV, "--calibration", CALIBRATION, "--out", "{o}",
                         "--force"], "folder", "--out"),
    "calibrate": (["real", "calibrate", "{measurements}", "--out", "{f}"], "file", "--out"),
    "robustness": (["real", "robustness", "m1-4mT", "--duration", "0.01", "--out", "{o}", "--force"],
                   "folder",
                   "--out"),
    "identify": (["real", "identify", FIELD_CSV, str(PUBLISHED / "trajectory.csv"), "--robot", "m1-4mT",
                  "--fit", "friction", "--out", "{o}", "--force"], "folder", "--out"),
    "loop": (["loop", "m1-4mT", "--out", "{o}", "--force"], "folder", "--out"),
    "design": (["design", "m1-4mT", "--out", "{o}", "--force", "--quick"], "folder", "--out"),
    "stream --log": (["real", "stream", FIELD_CSV, "--port", "socket://127.0.0.1:9", "--log", "{f}"], "file",
                     "--log"),
    "stream --codes-out": (["real", "stream", FIELD_CSV, "--port", "socket://127.0.0.1:9", "--codes-out",
                            "{f}"], "file", "--codes-out"),
}

#: Writing commands that need a training run to reach their output check: covered with one
#: (``tests/rl/cli/test_path_rule_runs.py``).
NEEDS_A_RUN = {"train", "refine", "export-seeds", "ship", "diagnose"}

#: Figures that ``figures`` and ``seeds`` write there (an existing one is refused without --force).
EXISTING_FIGURES = ("learning_curves_paper.png", "seeds_m1-4mT.png")


def _output_options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {option: action for action in parser._actions for option in action.option_strings
            if option in OUTPUT_OPTION_NAMES or action.type in OUTPUT_TYPES}


def test_every_output_option_is_parsed_with_the_path_rule():
    commands = listed_commands()  # as written today: "policy generate" (WRITERS run old spellings)
    writers = {spelling(name.split()[0]) for name in WRITERS} | {spelling(n) for n in NEEDS_A_RUN}
    with_outputs = set()
    for name, parser in commands.items():
        for option, action in _output_options(parser).items():
            with_outputs.add(name)
            assert action.type in OUTPUT_TYPES, f"msr {name} {option} is not parsed with output_path"
            assert not isinstance(action.default, Path), (
                f"msr {name} {option}: a Path default is not parsed (argparse converts only string "
                "defaults); give it as a string")
    assert with_outputs <= writers, f"writing commands not exercised here: {with_outputs - writers}"
    assert writers - {spelling("notes")} <= with_outputs


@pytest.mark.parametrize("spelling, same", [
    ("D", "D"), ("./D/", "D"), ("D/missing/..", "D"), ("D//", "D"), ("D/.", "D"),
    ("x/../D", "D"), ("L", "D"), ("L/", "D"), ("~", None),
])
def test_normalized_path_gives_one_spelling(tmp_path, monkeypatch, spelling, same):
    (tmp_path / "D").mkdir()
    (tmp_path / "L").symlink_to(tmp_path / "D", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    expected = tmp_path.resolve() / same if same else Path.home().resolve()
    assert normalized_path(spelling) == expected
    assert display_path(spelling) == (same or str(expected))


@st.composite
def spellings(draw, root: Path, name: str) -> str:
    """A spelling of ``root/name`` (``name`` a folder, or ``D/mine.txt``) from ``root``: relative or
    absolute, through a link to ``D`` or not, with ``.``, ``..`` over missing folders, repeated and
    trailing separators."""
    folder, _, file = name.partition("/")
    through_link = draw(st.booleans())
    detour = draw(st.sampled_from(["", "./", "missing/../", "missing/deeper/../../", "D/../", ".//"]))
    inner = draw(st.sampled_from(["", "/.", "/missing/..", "//", "/./missing/../."]))
    text = f"{detour}{'L' if through_link else folder}{inner}"
    text += f"/{file}" if file else draw(st.sampled_from(["", "/", "//"]))
    return str(root / text) if draw(st.booleans()) else text


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _run(argv: list[str]) -> tuple[int, str]:
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = main(argv)
        except SystemExit as exc:  # argparse
            status = exc.code
    return status, err.getvalue()


@pytest.mark.parametrize("writer", sorted(WRITERS))
@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_every_spelling_of_a_folder_is_that_folder(writer, data):
    """The user's folder ``D`` (their file ``mine.txt`` and, where the command draws figures, one
    it would redraw), spelled any way: the command refuses it, naming ``D``, and leaves it byte
    for byte (with ``--force`` where the command has it: it never deletes what it did not write)."""
    argv, kind, option = WRITERS[writer]
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp).resolve()
        folder = root / "D"
        folder.mkdir()
        (folder / "mine.txt").write_text("the user's notes\n")
        for figure in EXISTING_FIGURES:
            (folder / figure).write_bytes(b"an earlier figure")
        (root / "L").symlink_to(folder, target_is_directory=True)
        (root / "meas.csv").write_text("current_x_A,current_y_A,current_z_A,field_x_mT,field_y_mT,"
                                       "field_z_mT\n1,0,0,2,0,0\n0,1,0,0,2,0\n0,0,1,0,0,2\n")
        before = _tree(folder)
        spelled = data.draw(spellings(root, "D/mine.txt" if kind == "file" else "D"))
        os.chdir(root)
        try:
            status, err = _run([a.format(o=spelled, f=spelled, measurements="meas.csv")
                                for a in argv])
        finally:
            os.chdir(here)
        assert status == 2, err
        shown = "D/mine.txt" if kind == "file" else "D"
        assert f"{option} {shown}:" in err, err
        assert _tree(folder) == before
        assert sorted(p.name for p in root.iterdir()) == ["D", "L", "meas.csv"]


def test_a_link_loop_or_an_over_long_name_is_refused_before_any_work(tmp_path, capsys):
    """Round 6, P03a/P03b (a link loop as --out: replaced by a calibration file without --force,
    or found only after the work) and P10 (a raw "File name too long")."""
    (tmp_path / "loopA").symlink_to(tmp_path / "loopB")
    (tmp_path / "loopB").symlink_to(tmp_path / "loopA")
    for argv in (["field", "simulate", "--duration", "0.05", "--out"],
                 ["real", "calibrate", str(tmp_path / "m.csv"), "--out"]):
        with pytest.raises(SystemExit):
            main([*argv, str(tmp_path / "loopA")])
        assert "is a symbolic link that leads back to itself (a loop)" in capsys.readouterr().err
    assert (tmp_path / "loopA").is_symlink() and os.readlink(tmp_path / "loopA") == str(tmp_path / "loopB")
    with pytest.raises(SystemExit):
        main(["field", "simulate", "--duration", "0.05", "--out", str(tmp_path / ("a" * 300))])
    assert "is 300 bytes long; the file system allows at most" in capsys.readouterr().err
    # round 10, V6: a 240-byte name fits, msr's own names beside it do not: said before any work
    for argv in (["field", "simulate", "--duration", "0.05", "--out"],
                 ["design", "m1-4mT", "--quick", "--generations", "1", "--out"],
                 ["real", "calibrate", str(tmp_path / "m.csv"), "--out"]):
        with pytest.raises(SystemExit):
            main([*argv, str(tmp_path / ("b" * 240))])
        assert "is 240 bytes long; msr writes beside it under longer names" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["loopA", "loopB"]
    from elastica_magnetic.io import OutputPathError
    from elastica_magnetic.results import check_result_folder

    with pytest.raises(OutputPathError, match="a loop"):  # the library applies the rule too
        check_result_folder(tmp_path / "loopA", kind="demo")
