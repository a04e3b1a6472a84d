"""The real firmware ELF in QEMU, streaming the published waveform through ``msr stream``.

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
