"""Firmware build inputs from a field CSV and a calibration file.

``python -m elastica_magnetic.hardware.export FIELD_CSV --calibration FILE --out DIR`` (run by the
firmware's CMake build, and by ``msr real firmware``) writes into DIR:

- ``calibration_gen.h``: the calibration as C constants,
- ``waveform_table.c``: the field rows (mT) as the flash table played by the ``PLAY`` command,
- ``expected_dac_codes.csv``: ``row,code_x,code_y,code_z``, the codes the firmware writes for
  each row, whether played from flash or streamed with ``msr real stream``.

Only numpy and :mod:`elastica_magnetic.field_csv` are imported, so the build stays light.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from elastica_magnetic.cli.options import output_path
from elastica_magnetic.drive_columns import is_coil_currents
from elastica_magnetic.field_csv import FIELD_COLUMNS, read_field_csv
from elastica_magnetic.hardware.calibration import (
    Calibration,
    calibration_header,
    clipping_report,
    expected_dac_codes,
    load_calibration,
    slew_warning,
)
from elastica_magnetic.hardware.protocol import wire_rows_mT, wire_values_mT
from elastica_magnetic.io import atomic_write, atomic_write_text
from elastica_magnetic.plausibility import ImplausibleValueWarning
from elastica_magnetic.result_file import FileKind
from elastica_magnetic.results import check_result_folder, result_folder

#: Flash left for the table after code (1 MB part): 3 doubles = 24 bytes per row.
MAX_TABLE_ROWS = 40000


def waveform_table_source(rows_mT: NDArray[np.float64], source: str) -> str:
    """C source of the flash table (exact double literals, mT)."""
    lines = [
        f"/* Generated from {Path(source).name} by elastica_magnetic.hardware.export. */",
        "/* Field rows in mT, one per 10 ms tick. Do not edit. */",
        '#include "waveform_table.h"',
        "",
        "const double msr_waveform_table[][3] = {",
    ]
    lines += [f"    {{{x!r}, {y!r}, {z!r}}}," for x, y, z in rows_mT.tolist()]
    lines += ["};", f"const uint32_t msr_waveform_rows = {len(rows_mT)}u;", ""]
    return "\n".join(lines)


#: The header of an expected-DAC-codes CSV.
EXPECTED_CODES_HEADER = "row,code_x,code_y,code_z"


def _is_expected_codes(path: Path) -> bool:
    with open(path, encoding="utf-8") as handle:
        return handle.readline().strip() == EXPECTED_CODES_HEADER


#: What ``msr real stream --codes-out FILE --force`` may replace: an earlier codes CSV.
EXPECTED_CODES_FILE = FileKind(f"an expected-DAC-codes CSV ({EXPECTED_CODES_HEADER})",
                               _is_expected_codes, of_no_case=True)


def write_expected_codes(path: Path, codes: NDArray[np.int64]) -> Path:
    """Write ``row,code_x,code_y,code_z`` (atomically)."""
    with atomic_write(path, "w") as handle:
        handle.write(EXPECTED_CODES_HEADER + "\n")
        for i, (x, y, z) in enumerate(codes.tolist()):
            handle.write(f"{i},{x},{y},{z}\n")
    return path


def read_expected_codes(path: str | Path) -> NDArray[np.int64]:
    """Read an ``expected_dac_codes.csv`` back as an ``(n, 3)`` array (rows must count 0, 1, ...)."""
    with open(path) as handle:
        body = handle.read().splitlines()[1:]
    if not any(line.strip() for line in body):
        return np.zeros((0, 3), dtype=np.int64)
    data = np.loadtxt(body, delimiter=",", dtype=np.int64, ndmin=2)
    if data.shape[1] != 4 or not np.array_equal(data[:, 0], np.arange(len(data))):
        raise ValueError(f"{path}: expected columns row,code_x,code_y,code_z with rows 0, 1, ...")
    return data[:, 1:]


#: The files of an export (the result folder holds these and its marker).
EXPORT_FIRMWARE_FILES = ("calibration_gen.h", "waveform_table.c", "expected_dac_codes.csv")


def export_firmware(field_csv: str | Path, calibration: Calibration | str | Path,
                    out_dir: str | Path, allow_clipping: bool = False, *,
                    force: bool = False) -> dict[str, Any]:
    """Write the three build inputs for ``field_csv`` into ``out_dir``; return a summary.

    ``out_dir`` is a result folder (:func:`elastica_magnetic.results.result_folder`): checked
    before anything is read, replaced whole (the header and the table always of the same export)
    or not at all, an earlier export replaced only with ``force``, a folder holding other files
    refused.

    A waveform the coils cannot reach (current limit or DAC span of the calibration,
    see :func:`~elastica_magnetic.hardware.calibration.clipping_report`) is refused with a
    ValueError saying how many rows and by how much, unless ``allow_clipping``; the summary reports
    ``rows_clipped`` either way. Slew-limited rows (reached late, not clipped) are written; the
    summary's ``warnings`` says how many and by how much the field lags (the CLIs print it)."""
    check_result_folder(out_dir, kind="export-firmware", force=force,
                        known_files=EXPORT_FIRMWARE_FILES)
    cal = calibration if isinstance(calibration, Calibration) else load_calibration(calibration)
    if is_coil_currents(field_csv):  # before the field reader names it a drive of no field
        raise ValueError(
            f"{field_csv}: holds coil currents (current_0_A, ..., A), and the flash table (PLAY) is a "
            f"field waveform ({', '.join(FIELD_COLUMNS)} in mT): compile a field CSV, or stream the "
            "currents with 'msr real stream FILE --port PORT --calibration CAL' (up to 3 coils)")
    with warnings.catch_warnings(record=True) as read_warnings:  # the summary's own record
        warnings.simplefilter("always", ImplausibleValueWarning)
        field_T = read_field_csv(field_csv, plausible=True)
    csv_warnings = _reissued(read_warnings)
    if len(field_T) > MAX_TABLE_ROWS:
        raise ValueError(
            f"{field_csv}: {len(field_T)} rows exceed the flash table limit of {MAX_TABLE_ROWS} "
            "(stream longer waveforms with 'msr real stream')"
        )
    rows_mT = wire_values_mT(wire_rows_mT(field_T))
    clipping = clipping_report(cal, rows_mT)
    if clipping.rows and not allow_clipping:
        raise ValueError(
            f"{field_csv}: the coils of calibration {cal.name!r} cannot follow this waveform: "
            f"{clipping.describe()}. Lower the field, or pass --allow-clipping to play it clipped"
        )
    codes = expected_dac_codes(cal, rows_mT)
    with result_folder(out_dir, kind="export-firmware", force=force,
                       known_files=EXPORT_FIRMWARE_FILES) as folder:
        names = [folder.path / name for name in EXPORT_FIRMWARE_FILES]
        atomic_write_text(names[0], calibration_header(cal))
        atomic_write_text(names[1], waveform_table_source(rows_mT, str(field_csv)))
        write_expected_codes(names[2], codes)
    header, table, expected = (folder.final_path(name) for name in names)
    return {
        "rows": len(rows_mT),
        "calibration": cal.name,
        "calibration_header": str(header),
        "waveform_table": str(table),
        "expected_dac_codes": str(expected),
        "rows_clipped": clipping.rows,
        "clipping": clipping.describe(),
        "rows_slew_limited": clipping.slew_rows,
        "slew_limiting": clipping.describe_slew(),
        "warnings": csv_warnings + [w for w in [slew_warning(clipping, field_csv, cal.name)] if w],
        "code_min": int(codes.min()) if len(codes) else None,
        "code_max": int(codes.max()) if len(codes) else None,
    }


def _reissued(caught: list[warnings.WarningMessage]) -> list[str]:
    """The unusual-value warnings among ``caught`` as text (the summary lists and prints them);
    any other warning is issued again as it was."""
    texts = []
    for caught_warning in caught:
        if issubclass(caught_warning.category, ImplausibleValueWarning):
            if str(caught_warning.message) not in texts:
                texts.append(str(caught_warning.message))
        else:
            warnings.warn_explicit(caught_warning.message, caught_warning.category,
                                   caught_warning.filename, caught_warning.lineno)
    return texts


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m elastica_magnetic.hardware.export",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("field_csv")
    parser.add_argument("--calibration", required=True)
    parser.add_argument("--out", type=output_path, required=True)
    parser.add_argument("--quiet", action="store_true")
    parser.add_argument("--allow-clipping", action="store_true",
                        help="write a waveform the coils cannot follow (clamped, as the firmware does)")
    parser.add_argument("--force", action="store_true",
                        help="replace an earlier export in --out (a build folder: CMake passes it)")
    args = parser.parse_args(argv)
    try:
        summary = export_firmware(args.field_csv, args.calibration, args.out, args.allow_clipping,
                                  force=args.force)
    except (ValueError, OSError) as exc:
        print(f"export: error: {exc}", file=sys.stderr)
        return 2
    for warning in summary["warnings"]:
        print(f"export: warning: {warning}", file=sys.stderr)
    if not args.quiet:
        for key, value in summary.items():
            print(f"{key}: {value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
