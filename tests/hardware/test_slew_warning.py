"""A waveform the coils follow late (issue 48, a held-out round of tries, cal_slew): with a
calibration whose slew limit makes every row slew-limited, ``msr real firmware`` exited 0 with
"clipping: no row clipped" and ``rows_slew_limited: 11``, no word that the coils will not follow
the waveform. Slew-limited rows stay accepted (the firmware reaches them late, not clipped; a
step from 0 A is slew-limited by design and test_stream plays one with exit status 0), but
``export-firmware`` and ``stream`` now print a warning line on stderr saying how many rows and by
how much the field lags."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from elastica_magnetic.cli import main
from elastica_magnetic.hardware.calibration import clipping_report, load_calibration

YAO2023 = Path(__file__).resolve().parents[2] / "stm32" / "calibration" / "yao2023.json"
#: A ramp of 0.3 mT per 0.01 s row along x (15 A/s with the 2 mT/A coils), from zero.
RAMP_mT = np.array([[0.3 * k, 0.0, 0.0] for k in range(11)])


def slow_calibration(tmp_path: Path) -> Path:
    """yao2023 with a slew limit of 5 A/s on x and y, 2 A/s on z: slow coils (a slew limit below
    1 A/s is refused as a unit mistake: test_plausibility)."""
    data = json.loads(YAO2023.read_text())
    data["slew_limit_A_per_s"] = [5.0, 5.0, 2.0]
    path = tmp_path / "slow.json"
    path.write_text(json.dumps(data))
    return path


def ramp_csv(tmp_path: Path) -> Path:
    path = tmp_path / "ramp.csv"
    path.write_text("mag_x,mag_y,mag_z\n" + "".join(f"{x},{y},{z}\n" for x, y, z in RAMP_mT))
    return path


def test_the_report_says_how_many_rows_and_by_how_much(tmp_path):
    report = clipping_report(load_calibration(slow_calibration(tmp_path)), RAMP_mT)
    assert report.rows == 0 and report.slew_rows == 10 and report.first_slew_row == 1
    assert report.slew_limit_A_per_s == 5.0 and 14.9 < report.max_rate_A_per_s < 15.1
    assert 1.99 < report.max_lag_mT < 2.01  # the 3 mT ramp end, less 10 x 0.05 A x 2 mT/A
    assert re.fullmatch(r"10 row\(s\) slew-limited, first at data row 1: the waveform changes a current "
                        r"\(x coils\) "
                        r"at up to 15\.\d+ A/s for a slew limit of 5 A/s, so the field lags it by "
                        r"up to 2 mT", report.describe_slew())


def test_export_firmware_warns_of_slew_limited_rows(tmp_path, capsys):
    csv_path = ramp_csv(tmp_path)
    argv = ["real", "firmware", str(csv_path), "--calibration", str(slow_calibration(tmp_path)),
            "--out", str(tmp_path / "out"), "--json"]
    assert main(argv) == 0  # written: reached late, not clipped
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert summary["rows_slew_limited"] == 10 and summary["rows_clipped"] == 0
    warning = (f"{csv_path}: the coils of calibration 'yao2023' follow this waveform late: 10 row(s) "
               "slew-limited, first at data row 1:")
    assert summary["warnings"][0].startswith(warning)
    assert captured.err.startswith(f"msr real firmware: warning: {warning}")
    assert "so the field lags it by up to 2 mT; check the calibration's slew_limit_A_per_s (A/s), " \
           "or slow the waveform" in captured.err


def test_export_firmware_says_nothing_of_a_waveform_within_the_slew_limit(tmp_path, capsys):
    argv = ["real", "firmware", str(ramp_csv(tmp_path)), "--calibration", str(YAO2023),
            "--out", str(tmp_path / "out"), "--json"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and json.loads(captured.out)["warnings"] == []


def test_stream_warns_of_slew_limited_rows_before_it_connects(tmp_path, capsys):
    csv_path = ramp_csv(tmp_path)
    assert main(["real", "stream", str(csv_path), "--port", "socket://127.0.0.1:1", "--timeout", "1",
                 "--no-progress", "--calibration", str(slow_calibration(tmp_path))]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith(f"msr real stream: warning: {csv_path}: the coils of calibration 'yao2023' "
                             "follow this waveform late: 10 row(s) slew-limited")
    assert err[-1].startswith("msr real stream: error: socket://127.0.0.1:1: cannot open the port")
