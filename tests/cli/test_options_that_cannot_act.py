"""Round 5 of tries: options whose value could not act were taken without a word; each is now
refused before any work, naming the option and why (the standard: an option honored or refused)."""

from __future__ import annotations

from pathlib import Path

import pytest

from elastica_magnetic.cli import main

POLICY = Path(__file__).resolve().parents[2] / "rl" / "policies" / "m1-4mT"


def _track(tmp_path: Path) -> Path:
    path = tmp_path / "track.csv"
    rows = [f"{k / 30:.4f},{0.001 * k:.6f},0,{0.02 + 0.001 * k:.6f},0" for k in range(12)]
    path.write_text("t_s,x_0_m,y_0_m,x_1_m,y_1_m\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("name", ["ship --duration", "identify --seed", "robustness --open-loop-only"])
def test_an_option_that_cannot_act_is_refused_before_any_work(tmp_path, capsys, name):
    out = tmp_path / "out"
    argv, message = {
        "ship --duration": (["policy", "ship", str(POLICY), "--name", "x", "--out", str(out),
                             "--no-measure", "--duration", "5"],
                            "--duration 5: the length of the evaluation run, and --no-measure "
                            "skips it"),
        "identify --seed": (["real", "identify", str(POLICY / "fields.csv"), str(_track(tmp_path)),
                             "--robot", "m1-4mT", "--fit", "magnetization", "--starts", "1",
                             "--seed", "5", "--out", str(out)],
                            "--seed 5: seeds the perturbed starts, and --starts 1 fits from the "
                            "nominal values only"),
        "robustness --open-loop-only": (["real", "robustness", str(POLICY / "fields.csv"), "--case",
                                         "m1-4mT", "--open-loop-only", "--no-corners",
                                         "--duration", "0.1", "--no-progress", "--out", str(out)],
                                        "is a field CSV, played open loop only"),
    }[name]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_stop_tolerance_written_as_a_percentage_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit) as refused:
        main(["train", "--case", "m1-4mT", "--stop-when", "plateau", "--stop-tolerance", "2",
              "--out", str(tmp_path / "runs")])
    assert refused.value.code == 2
    assert "it looks like a percentage (2 % is 0.02)" in capsys.readouterr().err
