"""Messages of a thirteenth round of held-out tries (issue 48): numeric options 1000x off name the
milli-unit slip as the spec keys do; a notes file that is not a regular file is named as such."""

from __future__ import annotations

import pytest

from elastica_magnetic.cli import main


def run(argv: list[str]) -> int:
    """``msr argv``'s exit status (a parser's refusal exits through SystemExit)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(exc.code)


@pytest.mark.parametrize(("argv", "hint"), [
    (["field", "simulate", "--amplitude", "4", "--duration", "0.1"],
     "got '4' (mT written where T is expected? 4 mT is 0.004 T)"),
    (["real", "identify", "f.csv", "traj.csv", "--robot", "m1-4mT", "--fit", "magnetization",
      "--noise-m", "0.5"], "got '0.5' (mm written where m is expected? 0.5 mm is 0.0005 m)"),
])
def test_an_option_1000x_its_range_names_the_milli_unit(tmp_path, capsys, argv, hint):
    assert run([*argv, "--out", str(tmp_path / "out")]) == 2
    assert hint in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_an_option_far_out_of_range_gets_no_made_up_hint(tmp_path, capsys):
    assert run(["field", "simulate", "--amplitude", "400", "--duration", "0.1",
                "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "got '400'" in err and "written where" not in err


def test_a_notes_file_that_is_not_a_regular_file_is_named(capsys):
    assert run(["policy", "notes", "m1-4mT", "--file", "/dev/null"]) == 2
    assert ("--file /dev/null: not a regular file, expected a Markdown file (to remove the notes, "
            "give --clear)") in capsys.readouterr().err
