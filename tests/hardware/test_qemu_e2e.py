"""The real firmware ELF in QEMU, streaming the published waveform through ``msr real stream``.

Needs qemu-system-arm and stm32/build/arm/msr_firmware.elf, which ``bash stm32/ci.sh`` (run by
scripts/test.sh before pytest) installs and builds; missing ones FAIL this test, never skip it.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from .conftest import PUBLISHED_CSV, REPO

E2E_SCRIPT = REPO / "stm32" / "tests" / "qemu_e2e.py"


def _load_e2e():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("qemu_e2e", E2E_SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_published_waveform_through_qemu(tmp_path: Path) -> None:
    e2e = _load_e2e()
    assert PUBLISHED_CSV.is_file(), f"published waveform missing: {PUBLISHED_CSV}"
    try:
        result = e2e.run_e2e(PUBLISHED_CSV, workdir=tmp_path)
    except e2e.E2EError as exc:
        pytest.fail(f"QEMU end-to-end test could not run: {exc}")
    summary = {k: v for k, v in result.items() if k != "log"}
    assert result["board"].startswith("MSR-FW") and "calibration=default" in result["board"], summary
    assert result["rows_sent"] == result["rows_total"] == 1000, summary
    assert result["rows_applied"] == 1000, summary
    assert result["max_code_error_lsb"] is not None and result["max_code_error_lsb"] <= 1, summary
    assert result["ended_safe"] and result["end_reason"] == "end", summary
    assert result["corrupt_reason"] == "checksum", summary
    assert result["corrupt_safe_row"] == result["corrupt_row"] == 500, summary
    assert result["corrupt_ended_safe"], summary
    assert result["corrupt_max_code_error_lsb"] in (0, 1), summary
    assert result["passed"], summary


@pytest.mark.slow
def test_flash_table_playback_in_qemu() -> None:
    e2e = _load_e2e()
    try:
        result = e2e.run_table_playback()
    except e2e.E2EError as exc:
        pytest.fail(f"QEMU flash-table test could not run: {exc}")
    assert result["rows_total"] == 200, result  # stm32/waveforms/default.csv
    assert result["rows_applied"] == 200 and result["rows_in_order"], result
    assert result["max_code_error_lsb"] is not None and result["max_code_error_lsb"] <= 1, result
    assert result["ended_safe"] and result["end_reason"] == "end", result


YAO2023 = REPO / "stm32" / "calibration" / "yao2023.json"
#: The paper's four cases (magnetization 1 and 2, 4 and 10 mT).
PAPER_CASES = ("m1-4mT", "m1-10mT", "m2-4mT", "m2-10mT")
#: Rows of the calibration session's waveform (0.01 s each): its two streams run in real time.
CALIBRATION_ROWS = 300


@pytest.mark.slow
def test_calibration_upload_refusal_and_reset_in_qemu(tmp_path: Path) -> None:
    """One QEMU session: the compiled calibration as fallback, a bad upload refused (tick-rate),
    yao2023 uploaded and a 10 mT waveform the compiled one cannot make played bit-exactly, a
    second bad upload refused (ill-conditioned) with yao2023 kept, RESET, yao2023 active from
    the slot and played again without upload."""
    e2e = _load_e2e()
    # the first 3 s of the shipped 10 mT waveform (it reaches 10 mT within its first second): the board
    # streams in real time, twice here, and the whole 10 s is played by the tests above and below
    lines = (REPO / "rl" / "policies" / "m1-10mT" / "fields.csv").read_text().splitlines(keepends=True)
    csv = tmp_path / "m1-10mT-first-3s.csv"
    csv.write_text("".join(lines[:1 + CALIBRATION_ROWS]))
    try:
        result = e2e.run_calibration_checks(csv, YAO2023, workdir=tmp_path)
    except e2e.E2EError as exc:
        pytest.fail(f"QEMU calibration test could not run: {exc}")
    assert result["compiled_refuses_csv"], result
    assert "reason=tick-rate" in result["boot"]["answer"], result["boot"]
    assert result["boot"]["status_source"] == "compiled" and result["boot"]["status_name"] == "default"
    up = result["upload_stream"]
    assert up["calibration_uploaded"].startswith("OK CAL-COMMIT name=yao2023"), up
    assert up["max_code_error_lsb"] == 0 and up["exit_status"] == 0, up
    assert up["rows_applied"] == CALIBRATION_ROWS, up
    bad = result["bad_after_upload"]
    assert "reason=ill-conditioned" in bad["answer"], bad
    assert bad["status_hash"] == result["hash"] and bad["status_source"] == "flash", bad
    assert f"calibration=yao2023 hash={result['hash']} source=flash" in result["reset"]["banner"]
    after = result["after_reset_stream"]
    assert after["calibration_uploaded"] is None and after["max_code_error_lsb"] == 0, after
    assert after["rows_applied"] == CALIBRATION_ROWS and after["safe_reason"] == "end", after
    assert result["passed"], result


@pytest.mark.slow
def test_paper_waveforms_stream_with_yao2023(tmp_path: Path) -> None:
    """The four paper waveforms, each through its own QEMU board at once: a board streams in real
    time and waits most of it, so four side by side take the wall time of one."""
    from concurrent.futures import ThreadPoolExecutor

    e2e = _load_e2e()

    def stream(case: str) -> dict:
        csv = REPO / "rl" / "policies" / case / "fields.csv"
        try:
            return e2e.run_e2e(csv, calibration=YAO2023, corrupt_row=None, workdir=tmp_path / case)
        except e2e.E2EError as exc:
            pytest.fail(f"{case}: QEMU end-to-end test could not run: {exc}")

    with ThreadPoolExecutor(len(PAPER_CASES)) as pool:
        results = dict(zip(PAPER_CASES, pool.map(stream, PAPER_CASES), strict=True))
    for case, result in results.items():
        summary = {"case": case, **{k: v for k, v in result.items() if k != "log"}}
        assert result["rows_applied"] == result["rows_total"] == 1000, summary
        assert result["max_code_error_lsb"] == 0, summary
        assert result["ended_safe"] and result["end_reason"] == "end" and result["passed"], summary


@pytest.mark.slow
def test_a_three_axis_waveform_through_qemu(tmp_path: Path) -> None:
    """The third coil pair (issue 51): a 4 mT field rotating in the y-z plane (a sideways roll),
    with an x offset, streamed to the firmware with the compiled calibration: every row's three
    DAC codes exactly as the host model computes them (0 LSB), the z channel driven."""
    import numpy as np

    from elastica_magnetic.field_csv import write_field_csv
    from elastica_magnetic.hardware.export import read_expected_codes

    e2e = _load_e2e()
    t = np.arange(300) / 100.0
    amplitude = 4e-3 * np.minimum(t / 0.3, 1.0)  # from zero, within the slew limit
    phase = 2 * np.pi * t / 1.5
    field = np.stack([np.full_like(t, 1e-3), amplitude * np.cos(phase), amplitude * np.sin(phase)],
                     axis=1)
    csv = write_field_csv(tmp_path / "roll.csv", field)
    try:
        result = e2e.run_e2e(csv, workdir=tmp_path, corrupt_row=None)
    except e2e.E2EError as exc:
        pytest.fail(f"QEMU end-to-end test could not run: {exc}")
    summary = {k: v for k, v in result.items() if k != "log"}
    assert result["rows_sent"] == result["rows_applied"] == result["rows_total"] == 300, summary
    assert result["max_code_error_lsb"] == 0, summary
    assert result["ended_safe"] and result["end_reason"] == "end", summary
    codes = read_expected_codes(tmp_path / "export" / "expected_dac_codes.csv")
    assert codes[:, 2].max() - codes[:, 2].min() > 1000, "the z channel must be driven"


@pytest.mark.slow
def test_coil_currents_through_qemu(tmp_path: Path) -> None:
    """Issue 53: a 3-coil current file (the format of ``msr field baseline``'s coil_currents.csv, in
    A) streamed with ``STREAM CURRENTS`` to the firmware with the compiled calibration: every row's
    three DAC codes exactly as the host model computes them (0 LSB); then, in the same boot, a field
    waveform with plain ``STREAM`` as before (0 LSB)."""
    import numpy as np

    e2e = _load_e2e()
    t = np.arange(250) / 100.0
    ramp = np.minimum(t / 0.5, 1.0)  # from 0 A within the 50 A/s slew limit
    currents = np.stack([1.5 * ramp * np.sin(2 * np.pi * t), -0.8 * ramp,
                         2.0 * ramp * np.cos(np.pi * t)], axis=1)
    csv = tmp_path / "coil_currents.csv"
    csv.write_text("t_s,current_0_A,current_1_A,current_2_A,insertion_m\n" + "".join(
        f"{k / 100:.2f},{a!r},{b!r},{c!r},0\n" for k, (a, b, c) in enumerate(currents.tolist())))
    try:
        result = e2e.run_currents(csv, workdir=tmp_path)
    except e2e.E2EError as exc:
        pytest.fail(f"QEMU coil-current test could not run: {exc}")
    summary = {k: v for k, v in result.items() if not k.endswith("log")}
    assert result["mode"] == "currents" and result["rows_total"] == 250, summary
    assert result["rows_sent"] == result["rows_applied"] == 250, summary
    assert result["max_code_error_lsb"] == 0, summary
    assert result["ended_safe"] and result["safe_reason"] == "end", summary
    assert "OK STREAM queue=256 prefill=64 mode=currents" in Path(result["log"]).read_text()
    assert result["field_mode"] == "field" and result["field_rows_applied"] == 300, summary
    assert result["field_max_code_error_lsb"] == 0 and result["field_safe_reason"] == "end", summary
    assert result["passed"], summary
