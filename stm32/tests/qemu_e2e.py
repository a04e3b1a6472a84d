#!/usr/bin/env python3
"""End-to-end run of the real firmware ELF in QEMU (netduinoplus2) with ``msr real stream``.

    python stm32/tests/qemu_e2e.py --csv FILE [--json] [--corrupt-row N]

1. ``export_firmware`` computes the expected DAC codes of FILE for the calibration the ELF was
   built with (``stm32/calibration/default.json`` unless ``--calibration``).
2. QEMU boots the ELF with USART1 on a TCP socket (``server=on,wait=on,nodelay=on``) and
   ``-icount shift=auto`` (so TIM2 ticks at the right rate).
3. ``msr real stream FILE --port socket://...`` streams the whole waveform; every ``DAC`` line the
   firmware reported is compared with the expected codes (within 1 LSB), and the outputs must end
   at mid-scale with reason ``end``.
4. In the same boot, a second stream corrupts row N mid-stream: the firmware must stop there,
   go to mid-scale and report ``checksum``.

``--calibration FILE`` plays with FILE: ``msr real stream --calibration`` uploads it to the board when
the board's active calibration (the compiled-in one after boot) differs. ``--upload-checks`` runs,
in one QEMU session, the calibration life cycle instead: fallback to the compiled calibration, a
bad upload refused with its reason, FILE uploaded and FILE's waveform played bit-exactly, another
bad upload refused with FILE kept, then ``RESET`` (a real system reset: QEMU's netduinoplus2 does
not model the flash controller, so under emulation the firmware keeps its two calibration slots in
SRAM that a system reset leaves alone) and FILE active again, played with ``--no-upload``.

``--currents`` streams FILE as a coil-current file (``t_s, current_0_A, ...`` in A, up to three
coils: ``STREAM CURRENTS``) and checks every DAC code against the host's
``expected_current_codes``; in the same boot a short field waveform then plays with plain ``STREAM``
(the board is back to field rows).

The JSON result holds at least rows_sent, rows_applied, max_code_error_lsb and ended_safe. Every
step has a hard time-out and QEMU is killed in a ``finally``.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

DEFAULT_ELF = REPO / "stm32" / "build" / "arm" / "msr_firmware.elf"
DEFAULT_CALIBRATION = REPO / "stm32" / "calibration" / "default.json"
# The published waveform ships with the package (elastica_magnetic/data/yao2023).
PUBLISHED_CSV = REPO / "elastica_magnetic" / "data" / "yao2023" / "magnetization1_4mT" / "magnetic_field.csv"
QEMU = "qemu-system-arm"
#: One LSB of tolerance between the host model and the firmware.
TOLERANCE_LSB = 1
CONNECT_TIMEOUT_S = 10.0
#: Time limit of one stream: playback time (100 rows/s) times this factor plus the margin.
#: QEMU's -icount shift=auto clock ran at 50-100 % of real time on a loaded 2-core machine.
STREAM_SLOWDOWN = 3.0
STREAM_MARGIN_S = 20.0


class E2EError(RuntimeError):
    """The emulator or the ELF is missing, or a step did not finish."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def check_prerequisites(elf: Path) -> str:
    qemu = shutil.which(QEMU)
    if qemu is None:
        raise E2EError(f"{QEMU} not found: install Debian's qemu-system-arm (bash stm32/ci.sh does)")
    if not elf.is_file():
        raise E2EError(f"firmware ELF {elf} not found: build it with bash stm32/ci.sh")
    return qemu


def start_qemu(qemu: str, elf: Path, port: int) -> subprocess.Popen[bytes]:
    cmd = [qemu, "-M", "netduinoplus2", "-nographic", "-monitor", "none",
           "-icount", "shift=auto", "-kernel", str(elf),
           "-chardev", f"socket,id=s0,host=127.0.0.1,port={port},server=on,wait=on,nodelay=on",
           "-serial", "chardev:s0"]
    proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT)
    # QEMU announces "waiting for connection" once it listens; connecting to probe would make
    # the guest boot and its banner would be lost, so read that announcement instead.
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    seen = b""
    assert proc.stdout is not None
    while time.monotonic() < deadline:
        ready, _, _ = select.select([proc.stdout], [], [], 0.1)
        if ready:
            chunk = os.read(proc.stdout.fileno(), 4096)
            if not chunk:
                break
            seen += chunk
            if b"waiting for connection" in seen:
                return proc
        elif proc.poll() is not None:
            break
    proc.kill()
    raise E2EError(f"QEMU did not listen on port {port} within {CONNECT_TIMEOUT_S} s "
                   f"(status {proc.poll()}): {seen.decode(errors='replace')[-2000:]}")


def run_stream(csv: Path, port: int, calibration: Path, workdir: Path, tag: str, rows: int,
               corrupt_row: int | None = None, extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """Run ``msr real stream`` as a subprocess; returns its JSON summary plus the files it wrote."""
    log = workdir / f"{tag}.log"
    codes = workdir / f"{tag}_codes.csv"
    limit = rows / 100.0 * STREAM_SLOWDOWN + STREAM_MARGIN_S
    cmd = [sys.executable, "-m", "elastica_magnetic.cli", "real", "stream", str(csv),
           "--port", f"socket://127.0.0.1:{port}", "--calibration", str(calibration),
           "--json", "--no-progress", "--log", str(log), "--codes-out", str(codes),
           "--timeout", str(limit)]
    if corrupt_row is not None:
        cmd += ["--corrupt-row", str(corrupt_row)]
    cmd += list(extra)
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=limit + 15, env=env,
                              cwd=REPO)
    except subprocess.TimeoutExpired as exc:
        raise E2EError(f"msr real stream ({tag}) did not finish in {limit + 15:.0f} s") from exc
    try:
        summary = json.loads(done.stdout)
    except json.JSONDecodeError as exc:
        raise E2EError(f"msr real stream ({tag}) printed no JSON (status {done.returncode}):\n"
                       f"{done.stdout[-2000:]}\n{done.stderr[-2000:]}") from exc
    summary["exit_status"] = done.returncode
    summary["log"] = str(log)
    summary["codes"] = str(codes)
    return summary


def run_e2e(csv: Path, elf: Path = DEFAULT_ELF, calibration: Path = DEFAULT_CALIBRATION,
            corrupt_row: int | None = -1, workdir: Path | None = None) -> dict[str, Any]:
    """The whole end-to-end check; ``corrupt_row=-1`` picks the middle row, None skips it."""
    import numpy as np

    from elastica_magnetic.hardware.export import export_firmware, read_expected_codes

    qemu = check_prerequisites(elf)
    work = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix="msr_e2e_"))
    export = export_firmware(csv, calibration, work / "export")
    expected = read_expected_codes(export["expected_dac_codes"])
    rows = len(expected)
    if corrupt_row == -1:
        corrupt_row = rows // 2
    port = free_port()
    proc = start_qemu(qemu, elf, port)
    try:
        full = run_stream(csv, port, calibration, work, "full", rows)
        got = read_expected_codes(full["codes"])
        n = min(len(got), rows)
        max_err = int(np.max(np.abs(got[:n] - expected[:n]))) if n else None
        result: dict[str, Any] = {
            "csv": str(csv),
            "board": full.get("board"),
            "rows_total": rows,
            "rows_sent": full.get("rows_sent"),
            "rows_applied": full.get("rows_applied"),
            "max_code_error_lsb": max_err,
            "codes_within_tolerance": max_err is not None and max_err <= TOLERANCE_LSB and n == rows,
            "ended_safe": bool(full.get("ended_safe")),
            "end_reason": full.get("safe_reason"),
            "rows_per_s": full.get("rows_per_s"),
            "duration_s": full.get("duration_s"),
            "log": full.get("log"),
        }
        if corrupt_row is not None:
            bad = run_stream(csv, port, calibration, work, "corrupt", rows, corrupt_row)
            result.update({
                "corrupt_row": corrupt_row,
                "corrupt_reason": bad.get("safe_reason"),
                "corrupt_safe_row": bad.get("safe_row"),
                "corrupt_safe_line": bad.get("safe_line"),
                "corrupt_rows_applied": bad.get("rows_applied"),
                "corrupt_ended_safe": bool(bad.get("ended_safe")),
                "corrupt_max_code_error_lsb": bad.get("max_code_error_lsb"),
            })
    finally:
        proc.kill()
        try:
            proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            pass
    ok = result["codes_within_tolerance"] and result["ended_safe"] and result["end_reason"] == "end"
    if corrupt_row is not None:
        ok = ok and result["corrupt_reason"] == "checksum" and result["corrupt_ended_safe"] \
            and result["corrupt_safe_row"] == corrupt_row
    result["passed"] = bool(ok)
    return result


def _board_session(port: int) -> Any:
    """Open the QEMU serial socket and PING until PONG; returns (port, reader, banner)."""
    import serial

    from elastica_magnetic.hardware import stream

    url = f"socket://127.0.0.1:{port}"
    link = serial.serial_for_url(url, timeout=stream.READ_TIMEOUT_S)
    reader = stream._LineReader(link, stream._BoardLog(None))
    banner = stream._sync(link, reader, url, stream.SYNC_TIMEOUT_S)
    return link, reader, banner, url


def _bad_calibration(base: Any, **changes: Any) -> Any:
    """A Calibration built without the host's checks, to see the board refuse it."""
    import dataclasses

    return dataclasses.replace(base, **changes)


def _try_upload(port: int, calibration: Any) -> dict[str, Any]:
    from elastica_magnetic.hardware import stream

    link, reader, banner, url = _board_session(port)
    try:
        try:
            answer = stream.upload_calibration_lines(link, reader, url, calibration)
        except stream.CalibrationRefused as exc:
            answer = str(exc)
        status = stream.query_status(link, reader, url)
    finally:
        link.close()
    return {"answer": answer, "status": status.text, "status_hash": status.hash,
            "status_source": status.source, "status_name": status.calibration}


def _reset(port: int, timeout_s: float = 20.0) -> dict[str, Any]:
    """Send RESET; return the banner the firmware prints when it boots again and its STATUS."""
    from elastica_magnetic.hardware import stream

    link, reader, _, url = _board_session(port)
    try:
        link.write(b"RESET\n")
        banner = reader.wait_for(lambda x: x.startswith("MSR-FW"), timeout_s, "RESET", url)
        reader.wait_for(lambda x: x == "READY", timeout_s, "RESET", url)
        status = stream.query_status(link, reader, url)
    finally:
        link.close()
    return {"banner": banner, "status": status.text, "status_hash": status.hash,
            "status_source": status.source}


def run_calibration_checks(csv: Path, calibration: Path, elf: Path = DEFAULT_ELF,
                           workdir: Path | None = None) -> dict[str, Any]:
    """The calibration life cycle in one QEMU session (see the module docstring).

    ``csv`` must be a waveform the ELF's compiled calibration cannot make and ``calibration``
    can: the result says whether the compiled one refused it (``compiled_refuses_csv``)."""
    from elastica_magnetic.hardware.calibration import load_calibration
    from elastica_magnetic.hardware.export import export_firmware, read_expected_codes
    from elastica_magnetic.hardware.protocol import calibration_hash

    qemu = check_prerequisites(elf)
    work = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix="msr_cal_e2e_"))
    cal = load_calibration(calibration)
    try:
        export_firmware(csv, DEFAULT_CALIBRATION, work / "compiled")
        compiled_refuses = False
    except ValueError:
        compiled_refuses = True
    expected = read_expected_codes(export_firmware(csv, cal, work / "export")["expected_dac_codes"])
    rows = len(expected)
    port = free_port()
    proc = start_qemu(qemu, elf, port)
    result: dict[str, Any] = {"csv": str(csv), "calibration": cal.name,
                              "hash": calibration_hash(cal), "compiled_refuses_csv": compiled_refuses}
    try:
        bad_tick = _bad_calibration(cal, name="bad-tick", tick_hz=1000.0)
        result["boot"] = _try_upload(port, bad_tick)
        upload = run_stream(csv, port, calibration, work, "upload", rows)
        result["upload_stream"] = {k: upload.get(k) for k in (
            "calibration_before", "calibration_uploaded", "rows_applied", "max_code_error_lsb",
            "safe_reason", "ended_safe", "exit_status")}
        m = [list(r) for r in cal.actuation_matrix_T_per_A]
        m[0][1], m[1][0] = m[0][0] * 0.99, m[1][1] * 0.99  # x and y coils nearly parallel
        result["bad_after_upload"] = _try_upload(
            port, _bad_calibration(cal, name="bad-cond", actuation_matrix_T_per_A=m))
        result["reset"] = _reset(port)
        after = run_stream(csv, port, calibration, work, "after_reset", rows, extra=("--no-upload",))
        result["after_reset_stream"] = {k: after.get(k) for k in (
            "calibration_before", "calibration_uploaded", "rows_applied", "max_code_error_lsb",
            "safe_reason", "ended_safe", "exit_status")}
    finally:
        proc.kill()
        try:
            proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            pass
    h = result["hash"]
    s1, s2 = result["upload_stream"], result["after_reset_stream"]
    result["passed"] = bool(
        compiled_refuses
        and "reason=tick-rate" in result["boot"]["answer"]
        and result["boot"]["status_source"] == "compiled"
        and s1["calibration_uploaded"] and s1["max_code_error_lsb"] == 0
        and s1["rows_applied"] == rows and s1["safe_reason"] == "end" and s1["exit_status"] == 0
        and "reason=ill-conditioned" in result["bad_after_upload"]["answer"]
        and result["bad_after_upload"]["status_hash"] == h
        and f"hash={h}" in result["reset"]["banner"] and "source=flash" in result["reset"]["banner"]
        and s2["calibration_uploaded"] is None and s2["max_code_error_lsb"] == 0
        and s2["rows_applied"] == rows and s2["exit_status"] == 0)
    return result


def _codes_error(got_csv: str, expected: Any) -> int | None:
    """The largest difference (LSB) between the codes ``msr real stream --codes-out`` wrote and
    ``expected``; None without codes, -1 when the counts differ."""
    import numpy as np

    from elastica_magnetic.hardware.export import read_expected_codes

    got = read_expected_codes(Path(got_csv))
    if not len(got):
        return None
    if len(got) != len(expected):
        return -1
    return int(np.max(np.abs(got - expected)))


def run_currents(csv: Path, elf: Path = DEFAULT_ELF, calibration: Path = DEFAULT_CALIBRATION,
                 workdir: Path | None = None) -> dict[str, Any]:
    """Stream the coil-current file ``csv`` (``STREAM CURRENTS``) and then, in the same boot, a
    300-row field waveform (plain ``STREAM``); every code of both against the host's model."""
    import numpy as np

    from elastica_magnetic.field_csv import write_field_csv
    from elastica_magnetic.hardware.calibration import (
        expected_current_codes,
        expected_dac_codes,
        load_calibration,
    )
    from elastica_magnetic.hardware.coil_currents import read_coil_currents
    from elastica_magnetic.hardware.protocol import wire_rows, wire_rows_mT, wire_values

    qemu = check_prerequisites(elf)
    work = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix="msr_currents_e2e_"))
    cal = load_calibration(calibration)
    expected = expected_current_codes(cal, wire_values(wire_rows(read_coil_currents(csv).board_rows())))
    t = np.arange(300) / 100.0
    field_T = 1e-3 * np.stack([np.sin(2 * np.pi * t), np.minimum(t, 1.0), np.zeros_like(t)], axis=1)
    field_csv = write_field_csv(work / "field_after.csv", field_T)
    field_expected = expected_dac_codes(cal, wire_values(wire_rows_mT(field_T)))
    port = free_port()
    proc = start_qemu(qemu, elf, port)
    try:
        currents = run_stream(csv, port, calibration, work, "currents", len(expected))
        field = run_stream(field_csv, port, calibration, work, "field_after", len(field_expected))
    finally:
        proc.kill()
        try:
            proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            pass
    result: dict[str, Any] = {"csv": str(csv), "rows_total": len(expected)}
    for tag, summary, codes in (("", currents, expected), ("field_", field, field_expected)):
        result.update({f"{tag}{k}": summary.get(k) for k in (
            "mode", "rows_sent", "rows_applied", "ended_safe", "safe_reason", "exit_status", "log")})
        result[f"{tag}max_code_error_lsb"] = _codes_error(summary["codes"], codes)
    result["passed"] = bool(all(
        result[f"{tag}max_code_error_lsb"] == 0 and result[f"{tag}ended_safe"]
        and result[f"{tag}safe_reason"] == "end" and result[f"{tag}exit_status"] == 0
        for tag in ("", "field_")) and result["mode"] == "currents" and result["field_mode"] == "field")
    return result


def run_table_playback(elf: Path = DEFAULT_ELF, expected_csv: Path | None = None,
                       timeout_s: float = 60.0) -> dict[str, Any]:
    """Boot the ELF, send ``PLAY`` and compare the flash table's DAC codes with the build's
    ``gen/expected_dac_codes.csv`` (written next to the ELF by the CMake build)."""
    import numpy as np
    import serial

    from elastica_magnetic.hardware.export import read_expected_codes
    from elastica_magnetic.hardware.protocol import parse_dac, parse_safe

    qemu = check_prerequisites(elf)
    expected_csv = expected_csv or elf.parent / "gen" / "expected_dac_codes.csv"
    if not expected_csv.is_file():
        raise E2EError(f"{expected_csv} not found: build the ELF with bash stm32/ci.sh")
    expected = read_expected_codes(expected_csv)
    port = free_port()
    proc = start_qemu(qemu, elf, port)
    lines: list[str] = []
    try:
        link = serial.serial_for_url(f"socket://127.0.0.1:{port}", timeout=0.05)
        try:
            start = time.monotonic()
            pending = b""
            sent_play = False
            last_ping = -1.0
            safe = None
            while safe is None and time.monotonic() - start < timeout_s:
                now = time.monotonic() - start
                if not sent_play and now - last_ping > 0.5:
                    link.write(b"\nPING\n")
                    last_ping = now
                pending += link.read(4096)
                *done, pending = pending.split(b"\n")
                for raw in done:
                    line = raw.decode("ascii", "replace").strip()
                    lines.append(line)
                    if line == "PONG" and not sent_play:
                        link.write(b"PLAY\n")
                        sent_play = True
                    elif line.startswith("SAFE ") and sent_play:
                        safe = parse_safe(line)
        finally:
            link.close()
    finally:
        proc.kill()
        try:
            proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            pass
    reports = [d for d in (parse_dac(x) for x in lines) if d is not None]
    rows = [d for d in reports if d.row is not None]
    got = np.array([d.codes for d in rows], dtype=np.int64).reshape(-1, 3)
    n = min(len(got), len(expected))
    max_err = int(np.max(np.abs(got[:n] - expected[:n]))) if n else None
    return {
        "rows_total": len(expected),
        "rows_applied": len(rows),
        "rows_in_order": [d.row for d in rows] == list(range(len(rows))),
        "max_code_error_lsb": max_err,
        "ended_safe": bool(reports) and reports[-1].row is None
        and reports[-1].codes == (32768, 32768, 32768),
        "end_reason": safe.reason if safe else None,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", type=Path, default=PUBLISHED_CSV, help="field CSV (mT)")
    parser.add_argument("--elf", type=Path, default=DEFAULT_ELF)
    parser.add_argument("--calibration", type=Path, default=DEFAULT_CALIBRATION,
                        help="the calibration to play with (uploaded first when the board's "
                        "active one differs)")
    parser.add_argument("--upload-checks", action="store_true",
                        help="instead: the calibration life cycle (fallback, refusals, upload, "
                        "reset) with --calibration and --csv")
    parser.add_argument("--corrupt-row", type=int, default=-1,
                        help="row to corrupt in the second stream (-1: middle)")
    parser.add_argument("--no-corrupt", action="store_true", help="skip the corrupted stream")
    parser.add_argument("--play", action="store_true",
                        help="instead: play the flash table compiled into the ELF and check it")
    parser.add_argument("--currents", action="store_true",
                        help="instead: --csv is a coil-current file (A, up to 3 coils): stream it with "
                        "STREAM CURRENTS, then a field waveform, each checked bit-exactly")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    try:
        if args.upload_checks:
            result = run_calibration_checks(args.csv, args.calibration, args.elf)
        elif args.currents:
            result = run_currents(args.csv, args.elf, args.calibration)
        elif args.play:
            result = run_table_playback(args.elf)
            result["passed"] = bool(
                result["rows_applied"] == result["rows_total"] and result["rows_in_order"]
                and result["max_code_error_lsb"] is not None
                and result["max_code_error_lsb"] <= TOLERANCE_LSB
                and result["ended_safe"] and result["end_reason"] == "end")
        else:
            result = run_e2e(args.csv, args.elf, args.calibration,
                             None if args.no_corrupt else args.corrupt_row)
    except E2EError as exc:
        print(f"qemu_e2e: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for key, value in result.items():
            print(f"{key}: {value}")
    return 0 if result["passed"] else 1


if __name__ == "__main__":
    sys.exit(main())
