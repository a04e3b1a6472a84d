"""One rule for every writer (issue 48): an input named on the command line that lies in the folder
the command replaces is refused before any work, whichever argument names it. The rule reads the
parsers, so a new option is covered without a list to update; the commands that replace only their
own files declare it, and the set of them is pinned here."""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

import pytest

from elastica_magnetic.cli import main as msr
from elastica_magnetic.cli.app import build_parser
from elastica_magnetic.cli.input_places import (
    INPUTS_ALWAYS,
    REPLACED_FOLDER,
    command_parser,
    input_arguments,
    no_folder_replaced_whole,
)

REPO = Path(__file__).resolve().parents[2]


def _commands(parser: argparse.ArgumentParser, words: tuple[str, ...] = ()):
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield " ".join(words), parser
        return
    for name, sub in subs[0].choices.items():
        yield from _commands(sub, (*words, name))


def _writers() -> dict[str, argparse.ArgumentParser]:
    return {name: p for name, p in _commands(build_parser())
            if any("--out" in a.option_strings for a in p._actions)}


def test_the_commands_that_replace_only_their_own_files_are_the_ones_declared():
    """Every writer with ``--force`` is checked against ``--out``, but these, whose ``--force``
    replaces their own files and leaves the others (each guards its files itself): adding one to
    this set is a decision, not an accident."""
    opted_out = {name for name, p in _writers().items()
                 if p.get_default(REPLACED_FOLDER) is no_folder_replaced_whole}
    assert opted_out == {"policy figures", "figures", "policy export-seeds", "export-seeds",
                         "policy ship", "ship"}
    always = {name for name, p in _writers().items() if p.get_default(INPUTS_ALWAYS)}
    assert always == {"loop"}
    forced = {name for name, p in _writers().items()
              if any("--force" in a.option_strings for a in p._actions)}
    assert len(forced) >= 20  # every writer but the demo and training, which take no --force


def test_every_argument_that_names_a_path_is_an_input(tmp_path):
    """The arguments of ``msr real robustness``: its positional and --fields are; --out, flags
    and numbers are not."""
    parser = command_parser(build_parser(), "real robustness")
    args = parser.parse_args(["P", "--fields", "a.csv", "--out", "o", "--samples", "3", "--force"])
    found = input_arguments(parser, args)
    labels = [label for label, _ in found]
    # --physics: a choice; --checkpoint: a run's checkpoint file or a word (auto, final, best)
    assert found == [("POLICY_OR_FIELD_CSV", "P"), ("--fields", Path("a.csv")), ("--checkpoint", "auto")]
    assert "--out" not in labels and "--samples" not in labels and "--force" not in labels


def _copy_spec(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    spec = folder / "my.toml"
    shutil.copy(REPO / "rl" / "specs" / "m1-4mT.toml", spec)
    return spec


@pytest.mark.parametrize("argv", [
    # options no per-command list named before: a baseline's --case, a generate's --checkpoint
    ["field", "baseline", "--case", "{spec}", "--period", "0.5", "--duration", "1"],
    ["policy", "generate", "m1-4mT", "--checkpoint", "{spec}", "--duration", "0.1"],
    ["policy", "export", "m1-4mT", "--checkpoint", "{spec}"],
    ["real", "calibrate", str(REPO / "stm32" / "calibration" / "default.json"), "--base", "{spec}"],
])
def test_an_input_inside_what_force_replaces_is_refused(tmp_path, capsys, argv):
    out = tmp_path / "o"
    spec = _copy_spec(out)
    if argv[:2] == ["real", "calibrate"]:  # its --out is a file: the same file as an input
        out = spec
    before = sorted(p.name for p in spec.parent.iterdir())
    args = [a.replace("{spec}", str(spec)) for a in argv] + ["--out", str(out), "--force"]
    assert msr(args) == 2
    err = capsys.readouterr().err
    assert f"{spec}: lies in --out {out}, which this command replaces whole" in err, err
    assert sorted(p.name for p in spec.parent.iterdir()) == before


def test_without_force_nothing_is_replaced_and_nothing_is_refused_for_it(tmp_path, capsys):
    """Without ``--force`` an existing folder is refused by its writer (it holds files that the
    command does not write), not by this rule; with --force, by this rule, naming the input."""
    out = tmp_path / "o"
    spec = _copy_spec(out)
    base = ["field", "baseline", "--case", str(spec), "--period", "0.5", "--duration", "1", "--out", str(out)]
    assert msr(base) == 2
    assert "lies in --out" not in capsys.readouterr().err
    assert msr([*base, "--force"]) == 2
    assert f"--case {spec}: lies in --out" in capsys.readouterr().err
