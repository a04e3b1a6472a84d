"""``msr real stream``, ``msr real firmware`` and ``msr real calibrate``."""

from __future__ import annotations

import argparse
import csv
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from elastica_magnetic.cli.app import command_name
from elastica_magnetic.cli.input_places import REPLACED_FOLDER, out_file
from elastica_magnetic.cli.options import output_path
from elastica_magnetic.clock_columns import other_spelling_hint
from elastica_magnetic.field_csv import (
    MILLITESLA,
    named_twice,
    read_field_csv,
    separator_hint,
)
from elastica_magnetic.io import display_path

from ..io import missing_folder_hint

# the result files the hardware commands write, each known to the others' --force (a calibration
# JSON is never replaced by a board log, nor the other way): importing them registers their kinds
from .calibration import CALIBRATION_FILE
from .stream import BOARD_LOG_FILE

#: The longest ``--timeout`` of ``msr real stream``, s: an hour. A larger value is most likely
#: milliseconds written for seconds (refused, naming the slip); a waveform longer than that is
#: streamed with the default limit (its playback time + 30 s).
MAX_TIMEOUT_S = 3600.0


def register(subparsers: Any) -> None:
    """Add the hardware sub-commands to the ``msr`` parser."""
    p = subparsers.add_parser(
        "stream", help="stream a field CSV (mT) or up to 3 coil currents (A) to the STM32 firmware",
        description="Stream a field CSV, or a coil-current file of up to 3 coils, to the board; prints "
        "what the board reported.")
    p.add_argument("field_csv", metavar="FILE",
                   help="field CSV, mag_x,mag_y,mag_z in mT, 100 rows/s; or a coil-current file, "
                   "t_s,current_0_A[,current_1_A[,current_2_A]] in s and A, one row per 0.01 s, "
                   "played on the board's outputs 0-2 (coil_currents.csv of msr field baseline)")
    p.add_argument("--port", required=True,
                   help="pyserial URL or device: socket://127.0.0.1:4321 (QEMU), /dev/ttyACM0")
    p.add_argument("--calibration",
                   help="calibration JSON: the board plays with it (uploaded first when the board's "
                   "active calibration differs) and the reported codes are compared with it")
    p.add_argument("--no-upload", action="store_true",
                   help="with --calibration: refuse (exit 2) instead of uploading when the board's "
                   "active calibration differs")
    p.add_argument("--allow-clipping", action="store_true",
                   help="stream a waveform (or currents) beyond the calibration's current limit or DAC "
                   "span (the firmware clamps it); by default such a file is refused")
    p.add_argument("--baud", type=_number("baud", 1, integer=True), default=115200)
    p.add_argument("--timeout", type=_number("s", 0.0, MAX_TIMEOUT_S, low_open=True), default=None,
                   help="overall limit in seconds, handshake included, at most 3600 (default: the "
                   "waveform's playback time + 30 s, however long)")
    p.add_argument("--log", type=output_path, help="write every line the board sent to this file")
    p.add_argument("--codes-out", type=output_path,
                   help="write the reported DAC codes as row,code_x,code_y,code_z")
    p.add_argument("--corrupt-row", type=_number("", 0, integer=True), default=None,
                   help="fault injection: corrupt row N after its checksum (board must stop)")
    p.add_argument("--force", action="store_true",
                   help="replace an existing --log or --codes-out file")
    p.add_argument("--no-progress", action="store_true")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=_stream)

    p = subparsers.add_parser(
        "export-firmware", help="write the flash table, calibration header and expected codes",
        description="Write calibration_gen.h, waveform_table.c and expected_dac_codes.csv.")
    p.add_argument("field_csv", help="field CSV, mag_x,mag_y,mag_z in mT")
    p.add_argument("--calibration", required=True, help="calibration JSON")
    p.add_argument("--out", type=output_path, required=True, help="output directory")
    p.add_argument("--allow-clipping", action="store_true",
                   help="write a waveform beyond the coils' current limit or DAC span (the firmware "
                   "clamps it); by default such a waveform is refused")
    p.add_argument("--force", action="store_true",
                   help="replace an earlier export-firmware result in --out (the folder is replaced "
                   "whole; a folder holding other files is refused)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_export)

    p = subparsers.add_parser(
        "calibrate", help="fit the 3x3 actuation matrix from measured (current, field) pairs",
        description="Least-squares fit of field = A @ current; writes a calibration JSON.")
    p.add_argument("measurements", help="CSV with columns current_x_A,current_y_A,current_z_A,"
                   "field_x_mT,field_y_mT,field_z_mT (one row per measurement)")
    p.add_argument("--out", type=output_path, required=True, help="calibration JSON to write")
    p.add_argument("--base", help="calibration JSON providing the amplifier, DAC and limits "
                   "(default: stm32/calibration/default.json)")
    p.add_argument("--name", default="measured", type=_calibration_name,
                   help="calibration name compiled into firmware (1-31 letters, digits, '_', '.', '-')")
    p.add_argument("--upload", metavar="PORT",
                   help="also upload the fitted calibration to the board at this pyserial URL")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_calibrate, **{REPLACED_FOLDER: out_file})  # --out: a file, not a folder


def _calibration_name(text: str) -> str:
    """argparse type of ``--name``: refused at parsing, before the fit, naming the option."""
    from elastica_magnetic.hardware.calibration import CALIBRATION_NAME_RULE, is_calibration_name

    if not is_calibration_name(text):
        raise argparse.ArgumentTypeError(f"{text!r}: a calibration name {CALIBRATION_NAME_RULE} "
                                         "(the board keeps it)")
    return text


def _number(*args: Any, **kwargs: Any) -> Any:
    from elastica_magnetic.cli import number

    return number(*args, **kwargs)


def _print(result: dict[str, Any], as_json: bool) -> None:
    from elastica_magnetic.cli import print_result

    print_result(result, as_json)


def _error(message: str) -> Exception:
    from elastica_magnetic.cli import CommandError

    return CommandError(message)


def _check_port(option: str, port: str) -> None:
    """Refuse a network URL without a usable TCP port, naming the option."""
    from elastica_magnetic.hardware.stream import port_url_problem

    problem = port_url_problem(port)
    if problem is not None:
        raise _error(f"{option} {problem}")


#: Largest difference (LSB) between the board's reported codes and the host's model.
CODE_TOLERANCE_LSB = 1


def _stream(args: argparse.Namespace) -> int:
    from elastica_magnetic.hardware.stream import StreamError

    drive, cal = _stream_inputs(args)
    try:
        result = _stream_logged(args, drive, cal)
    except StreamError as exc:
        raise _error(str(exc)) from None
    summary = result.summary()
    got = result.codes_array()
    if args.codes_out:
        from elastica_magnetic.hardware.export import EXPECTED_CODES_FILE, write_expected_codes
        from elastica_magnetic.result_file import result_file

        with result_file(args.codes_out, force=args.force, option="--codes-out",
                         kind=EXPECTED_CODES_FILE) as codes:
            write_expected_codes(codes.path, got)
    codes_ok = cal is None or _compare_codes(summary, result, got, drive, cal)
    _print(summary, args.json)
    if result.safe is None:  # time-out: stream_field has sent STOP
        raise _error(f"{args.port}: no SAFE report from the board within the time limit "
                     f"({result.rows_applied} of {result.rows_total} rows reported played); STOP sent")
    if not codes_ok:
        print(f"msr {command_name(args)}: error: the board's DAC codes differ from the host's by "
              f"{summary['max_code_error_lsb']} LSB (tolerance {CODE_TOLERANCE_LSB}; -1: rows out "
              "of order or more rows than sent): the board plays with another calibration or "
              "firmware", file=sys.stderr)
        return 1
    expected_end = "checksum" if args.corrupt_row is not None else "end"
    ok = result.safe.reason == expected_end and result.ended_safe
    return 0 if ok else 1


@dataclass(frozen=True)
class _Drive:
    """What ``msr real stream`` plays: a field (``mode`` "field", ``values`` in T, ``(n, 3)``) or the
    board's outputs' coil currents (``mode`` "currents", ``values`` in A, ``(n, 3)``)."""

    mode: str
    values: Any

    def board_values(self) -> Any:
        """The doubles the board parses from the rows sent (mT or A)."""
        from elastica_magnetic.hardware.protocol import wire_rows, wire_rows_mT, wire_values

        text = wire_rows_mT(self.values) if self.mode == "field" else wire_rows(self.values)
        return wire_values(text)

    def expected_codes(self, cal: Any) -> Any:
        """The codes the board writes for every row with ``cal`` (the host's bit-exact twin)."""
        from elastica_magnetic.hardware.calibration import expected_current_codes, expected_dac_codes

        codes_of = expected_dac_codes if self.mode == "field" else expected_current_codes
        return codes_of(cal, self.board_values())

    def streamer(self) -> Any:
        """:func:`~elastica_magnetic.hardware.stream.stream_field` or ``stream_currents``."""
        from elastica_magnetic.hardware.stream import stream_currents, stream_field

        return stream_field if self.mode == "field" else stream_currents


def _stream_inputs(args: argparse.Namespace) -> tuple[_Drive, Any]:
    """Everything ``msr real stream`` checks before it connects: the options, the file (a field
    CSV, as T, or a coil-current file, as A), the calibration (or ``None``) and what the coils can
    follow, the output files. Returns what to play and the calibration."""
    from elastica_magnetic.drive_columns import is_coil_currents
    from elastica_magnetic.hardware.calibration import load_calibration
    from elastica_magnetic.hardware.coil_currents import read_coil_currents
    from elastica_magnetic.hardware.export import EXPECTED_CODES_FILE
    from elastica_magnetic.result_file import check_result_file

    if args.force and not (args.log or args.codes_out):
        raise _error("--force replaces an existing --log or --codes-out file, and neither is "
                     "given: leave it out, or name the file to replace")
    _check_port("--port", args.port)  # before the files are read, and not as pyserial words it
    currents = read_coil_currents(args.field_csv) if is_coil_currents(args.field_csv) else None
    if currents is None:
        _refuse_magnet_path(args.field_csv)
    drive = (_Drive("field", read_field_csv(args.field_csv, plausible=True)) if currents is None
             else _Drive("currents", currents.board_rows()))
    rows = len(drive.values)
    if args.corrupt_row is not None and args.corrupt_row >= rows:  # before connecting
        raise _error(f"--corrupt-row {args.corrupt_row}: the waveform has {rows} rows "
                     f"({'0-' + str(rows - 1) if rows else 'none'}) in {display_path(args.field_csv)}; "
                     "choose one of them")
    cal = load_calibration(args.calibration) if args.calibration else None
    if args.no_upload and cal is None:
        raise _error("--no-upload needs --calibration FILE")
    if cal is not None and currents is None:
        _check_field_limits(args, drive, cal)
    elif cal is not None:
        _check_current_limits(args, currents, cal)
    if args.log and args.codes_out and args.log == args.codes_out:
        raise _error(f"--log and --codes-out name the same file, {args.log}")
    for option, path, kind in (("--log", args.log, BOARD_LOG_FILE),
                               ("--codes-out", args.codes_out, EXPECTED_CODES_FILE)):
        if path:
            check_result_file(path, force=args.force, option=option, kind=kind)
    return drive, cal


def _refuse_magnet_path(path: str) -> None:
    """A magnet arm's path is no drive of the coil board: say so (the field reader would name it
    as no field)."""
    from elastica_magnetic.drive_columns import MAGNET_COLUMN, is_magnet_path

    if is_magnet_path(path):
        raise _error(f"{path}: holds a magnet arm's path ({MAGNET_COLUMN}, ..., m), a catheter's drive by a "
                     "moving magnet: the coil board cannot play it (it plays a field CSV, mag_x, mag_y, "
                     "mag_z in mT, or coil currents, t_s, current_0_A, ... in A); play the path on the "
                     "arm's controller")


def _check_field_limits(args: argparse.Namespace, drive: _Drive, cal: Any) -> None:
    """A field the coils of ``cal`` cannot make is refused (unless --allow-clipping), one they
    follow late warned about."""
    from elastica_magnetic.hardware.calibration import clipping_report, slew_warning

    clipping = clipping_report(cal, drive.board_values())
    if clipping.rows and not args.allow_clipping:
        raise _error(
            f"{args.field_csv}: the coils of calibration {cal.name!r} cannot follow this "
            f"waveform: {clipping.describe()}. Lower the field, or pass --allow-clipping to "
            "play it clipped; nothing was sent")
    warning = slew_warning(clipping, args.field_csv, cal.name)
    if warning:  # played (reached late, not clipped), but the user should know
        print(f"msr {command_name(args)}: warning: {warning}", file=sys.stderr)


def _check_current_limits(args: argparse.Namespace, currents: Any, cal: Any) -> None:
    """Currents beyond the current limit or the DAC span of ``cal`` are refused (unless
    --allow-clipping), currents faster than its slew limit warned about: as for a field."""
    from elastica_magnetic.hardware.coil_currents import clipping_problem, slew_problem

    problem = clipping_problem(cal, currents)
    if problem and not args.allow_clipping:
        raise _error(f"{problem}: the board would clamp it. Lower the currents, or pass --allow-clipping "
                     "to play them clamped; nothing was sent")
    slow = slew_problem(cal, currents)
    if slow:
        print(f"msr {command_name(args)}: warning: {slow}; check the calibration's slew_limit_A_per_s "
              "(A/s), or slow the currents", file=sys.stderr)


def _compare_codes(summary: dict[str, Any], result: Any, got: Any, drive: _Drive, cal: Any) -> bool:
    """Compare the DAC codes the board reported (``got``, one row per played row) with the host's
    for the calibration; adds ``rows_in_order`` and ``max_code_error_lsb`` (``None``: no codes,
    -1: rows out of order or more than sent) to ``summary``. True when within tolerance."""
    expected = drive.expected_codes(cal)
    rows = [d.row for d in result.row_codes]
    in_order = rows == list(range(len(rows)))
    summary["rows_in_order"] = in_order
    if len(got) and in_order and len(got) <= len(expected):
        summary["max_code_error_lsb"] = int(np.max(np.abs(got - expected[: len(got)])))
    else:
        summary["max_code_error_lsb"] = None if not len(got) else -1
    error = summary["max_code_error_lsb"]
    return error is None or 0 <= error <= CODE_TOLERANCE_LSB


def _stream_logged(args: argparse.Namespace, drive: _Drive, cal: Any) -> Any:
    """Stream with ``--log`` written as one result file: the log of a stream that failed is kept
    too (it says what the board did), an interrupted one leaves the earlier log."""
    from elastica_magnetic.hardware.stream import StreamError
    from elastica_magnetic.result_file import result_file

    def run(log_path: Path | None) -> Any:
        return drive.streamer()(args.port, drive.values, baudrate=args.baud, corrupt_row=args.corrupt_row,
                                timeout_s=args.timeout, log_path=log_path,
                                progress=not args.no_progress, calibration=cal,
                                upload=not args.no_upload)

    if not args.log:
        return run(None)
    failure: StreamError | None = None
    with result_file(args.log, force=args.force, option="--log", kind=BOARD_LOG_FILE) as log:
        try:
            result = run(log.path)
        except StreamError as exc:
            if not log.path.exists() or log.path.stat().st_size == 0:
                # nothing was logged (the port did not open, the board never answered): the
                # earlier log is kept (raised inside the block, the empty new one is dropped)
                kept = "is left as it was" if args.log.exists() else "was not written"
                raise StreamError(f"{exc}; --log {display_path(args.log)} {kept} (nothing was "
                                  "logged)") from None
            failure = exc
        if not log.path.exists():  # a stream that logged nothing (an empty waveform)
            log.path.write_text("")
    if failure is not None:
        raise failure
    return result


def _export(args: argparse.Namespace) -> int:
    from elastica_magnetic.hardware.export import export_firmware

    summary = export_firmware(args.field_csv, args.calibration, args.out, args.allow_clipping,
                              force=args.force)
    for warning in summary["warnings"]:  # slew-limited rows: written, but the coils lag
        print(f"msr {command_name(args)}: warning: {warning}", file=sys.stderr)
    _print(summary, args.json)
    return 0


#: Header words of a coil current or of a field: such a column the fit does not read would be
#: lost without a word (a fourth coil's current absorbed into the other coils' entries).
_CURRENT_WORDS = ("current", "i")
_FIELD_WORDS = ("field", "b", "mag")


def _unread_drive_column(header: list[str], columns: list[str]) -> str:
    """What is wrong with the first column of ``header`` that names a current or a field but is
    not one of ``columns`` (the fit reads only those), else ``""``."""
    for name in header:
        if name in columns or not name:
            continue
        first = re.split(r"[\s_\[(/-]+", name.strip().lower())[0]
        if first in _CURRENT_WORDS:
            return (f"column {name!r} is a current the fit does not read: the actuation matrix maps the "
                    f"three currents {', '.join(columns[:3])} (A) to the field; another coil's field would "
                    "be taken for theirs (measure with that coil off), and a setpoint beside a measured "
                    "current is not fitted: drop the column")
        if first in _FIELD_WORDS:
            return (f"column {name!r} is a field the fit does not read (it reads {', '.join(columns[3:])}, "
                    "in mT): give each component once, in mT, and drop the column")
    return ""


def _not_read(header: list[str], columns: list[str]) -> list[str]:
    """The warning naming the columns of ``header`` the fit leaves unread (a note, a temperature)."""
    others = [name for name in header if name and name not in columns]
    return [f"column(s) {', '.join(repr(n) for n in others)} not read"] if others else []


def _read_measurements(path: Path, columns: list[str]) -> tuple[np.ndarray, list[str]]:
    """The measurements file's ``columns`` as ``(n, 6)`` numbers (currents in A, fields in mT) and
    its header; every problem (a missing, doubled or unread current or field column, a bad value)
    refused naming the file, line and column."""
    import pandas as pd

    try:
        table = pd.read_csv(path, skipinitialspace=True, encoding="utf-8-sig")
    except pd.errors.EmptyDataError:
        raise _error(f"{path}: empty file; expected columns {', '.join(columns)}") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise _error(f"{path}: not a readable UTF-8 CSV: {exc}") from None
    table.columns = [str(c).strip() for c in table.columns]  # "field_z_mT " is field_z_mT
    with open(path, encoding="utf-8-sig", newline="") as handle:
        header = [c.strip() for c in next(csv.reader(handle), [])]
    twice = named_twice(header)
    if twice:
        raise _error(f"{path}: header on line 1 {twice}; give each column once")
    missing = [c for c in columns if c not in table.columns]
    if missing:
        spelled = other_spelling_hint(missing, header,
                                      "name the columns exactly, currents in A and fields in mT")
        comment = ("; line 1 is a comment (it starts with #): msr reads no comment lines, delete it"
                   if header and header[0].startswith("#") else "")
        raise _error(f"{path}: missing column(s) {', '.join(missing)}{spelled}; expected "
                     f"{', '.join(columns)} (found {', '.join(header) or 'no header'})"
                     f"{separator_hint(header)}{comment}")
    unread = _unread_drive_column(header, columns)
    if unread:
        raise _error(f"{path}: {unread}")
    data = table[columns].apply(pd.to_numeric, errors="coerce")
    bad = data.isna().any(axis=1) | ~np.isfinite(data.to_numpy()).all(axis=1)
    if bad.any():
        first = int(np.flatnonzero(bad.to_numpy())[0])
        row = data.iloc[first].to_numpy(dtype=np.float64)
        column = columns[int(np.flatnonzero(~np.isfinite(row))[0])]
        cells = ", ".join(str(v) for v in table.iloc[first])
        raise _error(f"{path}: line {first + 2}: column {column}: missing or non-numeric value "
                     f"{str(table[column].iloc[first])!r} (the row: {cells})")
    values = data.to_numpy(dtype=np.float64)
    return values, header


def _calibrate(args: argparse.Namespace) -> int:
    from elastica_magnetic.hardware.calibration import (
        Calibration,
        calibration_from_dict,
        default_calibration_path,
        load_calibration,
        save_calibration,
    )
    from elastica_magnetic.hardware.calibration_fit import fit_actuation_matrix
    from elastica_magnetic.hardware.plausibility import (
        CURRENT_COLUMNS,
        FIELD_COLUMNS,
        check_measurements,
    )
    from elastica_magnetic.result_file import check_result_file, result_file

    if args.upload:
        _check_port("--upload", args.upload)
    path = Path(args.measurements)
    if not path.is_file():
        raise _error(f"{path}: no such measurements file{missing_folder_hint(path)}")
    check_result_file(args.out, force=args.force, kind=CALIBRATION_FILE)
    columns = [*CURRENT_COLUMNS, *FIELD_COLUMNS]
    values, header = _read_measurements(path, columns)
    check_measurements(values[:, :3], values[:, 3:], str(path))
    fit = fit_actuation_matrix(values[:, :3], values[:, 3:] * MILLITESLA, str(path))
    base = load_calibration(args.base) if args.base else load_calibration(default_calibration_path())
    fitted: Calibration = calibration_from_dict(
        {**base.to_json_dict(), "name": args.name,
         "actuation_matrix_T_per_A": fit.matrix_T_per_A.tolist(),
         "description": f"fitted by msr real calibrate from {path.name} ({fit.measurements} measurements)"},
        str(args.out))
    with result_file(args.out, force=args.force, kind=CALIBRATION_FILE) as written:
        save_calibration(written.path, fitted)
    uploaded = _upload(args.upload, fitted, args.out) if args.upload else None
    _print({
        "measurements": fit.measurements,
        "actuation_matrix_mT_per_A": np.round(fit.matrix_T_per_A / MILLITESLA, 6).tolist(),
        "rms_residual_mT": np.round(fit.rms_residual_T / MILLITESLA, 6).tolist(),
        "max_abs_residual_mT": round(fit.max_abs_residual_T / MILLITESLA, 6),
        "std_error_mT_per_A": np.round(fit.std_error_T_per_A / MILLITESLA, 6).tolist(),
        "current_condition_number": round(fit.current_condition, 3),
        "warnings": fit.warnings + _not_read(header, columns),
        "calibration": str(args.out),
        "uploaded": uploaded,
    }, args.json)
    for warning in fit.warnings:
        print(f"msr {command_name(args)}: warning: {warning}", file=sys.stderr)
    return 0


def _upload(port: str, calibration: Any, written: Path) -> dict[str, str]:
    """Upload the calibration just ``written``; a failure says the file is kept and how to send it."""
    from elastica_magnetic.hardware.stream import StreamError, upload_calibration

    try:
        return upload_calibration(port, calibration)
    except StreamError as exc:
        raise _error(f"--upload {exc}; the calibration was written to {display_path(written)} "
                     f"(msr real stream FIELD_CSV --port PORT --calibration {display_path(written)} uploads "
                     "it before playing)") from None
