"""``msr real stream`` against boards that misbehave: real ``msr`` processes, real TCP sockets on 127.0.0.1.

Whatever the board does, the command must end with a non-zero status and a message naming the
port, without a Python traceback, and must leave the coils at zero current: it never starts a
stream the board did not accept, and when it gives up on a stream the board accepted it sends
STOP (the firmware's immediate path to mid-scale) instead of leaving queued rows to play out.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
MIDSCALE = (32768, 32768, 32768)
ROWS = 400  # more than the board's 256-row credit, so a stalled board blocks the host
PLAYED_BEFORE_STALL = 5


class Board:
    """A TCP server speaking just enough of the firmware's protocol to fail in one way.

    ``mode``: ``silent`` accepts the connection and never writes; ``refuse`` answers PING but
    refuses STREAM with a SAFE report (as the firmware does with an invalid calibration);
    ``badcredit`` accepts the stream with a garbled credit line (``CREDIT abc``);
    ``stall`` accepts the stream, plays a few rows and then sends nothing more while still
    reading; ``hangup`` plays a few rows and closes the connection. ``outputs`` follows what the
    firmware would drive: the codes of the last row played, mid-scale after STOP or a fault.
    """

    def __init__(self, mode: str) -> None:
        self.mode = mode
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.received: list[str] = []
        self.outputs = MIDSCALE
        self.closed = threading.Event()
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    @property
    def url(self) -> str:
        return f"socket://127.0.0.1:{self.port}"

    def commands(self) -> list[str]:
        return [line for line in self.received if line and not line[0].isdigit()]

    def rows(self) -> list[str]:
        return [line for line in self.received if line and line[0].isdigit()]

    def _serve(self) -> None:
        conn, _ = self.server.accept()
        with conn:
            conn.settimeout(30.0)
            pending = b""
            played = 0
            streaming = False
            while True:
                try:
                    data = conn.recv(4096)
                except (TimeoutError, OSError):
                    break
                if not data:
                    break
                pending += data
                *lines, pending = pending.split(b"\n")
                for raw in lines:
                    line = raw.decode("ascii", "replace").strip()
                    self.received.append(line)
                    if line == "STOP":
                        self.outputs = MIDSCALE  # the firmware's host-stop path
                        streaming = False
                    if self.mode == "silent" or not line:
                        continue
                    reply = ""
                    if line == "PING":
                        reply = "PONG\n"
                    elif line == "STREAM" and self.mode == "refuse":
                        reply = ("DAC safe 32768 32768 32768\n"
                                 "SAFE calibration row=0 applied=0 detail=singular\n")
                    elif line == "STREAM" and self.mode == "badcredit":
                        reply = "OK STREAM queue=256 prefill=64\nCREDIT abc\n"
                    elif line == "STREAM":
                        streaming = True
                        reply = "OK STREAM queue=256 prefill=64\nCREDIT 256\n"
                    elif line[0].isdigit() and streaming and played < PLAYED_BEFORE_STALL:
                        self.outputs = (40000, 30000, 32768)
                        reply = f"DAC {played} 40000 30000 32768\n"
                        played += 1
                    if reply:
                        conn.sendall(reply.encode("ascii"))
                    if self.mode == "hangup" and played == PLAYED_BEFORE_STALL:
                        self.outputs = MIDSCALE  # the firmware underruns once the link is gone
                        self.closed.set()
                        return
        self.closed.set()

    def close(self) -> None:
        self.server.close()


@pytest.fixture
def field_csv(tmp_path: Path) -> Path:
    t = np.arange(ROWS) / 100.0
    path = tmp_path / "field.csv"
    rows = "\n".join(f"{np.cos(t_):.4f},{np.sin(t_):.4f},0.1" for t_ in t)
    path.write_text("mag_x,mag_y,mag_z\n" + rows + "\n")
    return path


def run_stream(board: Board, field_csv: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    cmd = [sys.executable, "-m", "elastica_magnetic.cli", "real", "stream", str(field_csv),
           "--port", board.url, "--no-progress", *extra]
    try:
        return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=120, cwd=REPO)
    finally:
        board.thread.join(timeout=10)
        board.close()


def assert_clean_failure(proc: subprocess.CompletedProcess[str], board: Board) -> None:
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0, out
    assert "Traceback" not in out, out
    assert f"127.0.0.1:{board.port}" in proc.stderr, proc.stderr


def test_board_that_never_answers(field_csv: Path) -> None:
    # waits the handshake time-out (10 s): no PONG, so nothing past PING is sent but the
    # fail-safe STOP that ends every failed session (zero current whatever the board was doing)
    board = Board("silent")
    proc = run_stream(board, field_csv)
    assert_clean_failure(proc, board)
    assert set(board.commands()) == {"PING", "STOP"} and board.commands()[-1] == "STOP"
    assert board.rows() == []
    assert board.outputs == MIDSCALE


def test_board_that_refuses_the_stream(field_csv: Path) -> None:
    board = Board("refuse")
    proc = run_stream(board, field_csv)
    assert_clean_failure(proc, board)
    assert "SAFE calibration" in proc.stderr  # the board's reason reaches the user
    assert board.rows() == [], "rows sent to a board that refused the stream"
    assert board.outputs == MIDSCALE


def test_board_that_stalls_mid_stream_gets_stop(field_csv: Path) -> None:
    board = Board("stall")
    proc = run_stream(board, field_csv, "--timeout", "2")
    assert_clean_failure(proc, board)
    assert len(board.rows()) == 256  # the credit, and not a row beyond it
    assert board.commands()[-1] == "STOP", board.commands()
    assert board.outputs == MIDSCALE


def test_board_that_hangs_up_mid_stream(field_csv: Path) -> None:
    board = Board("hangup")
    proc = run_stream(board, field_csv, "--timeout", "10")
    assert_clean_failure(proc, board)
    assert board.closed.is_set()


def test_board_that_sends_a_malformed_credit(field_csv: Path) -> None:
    board = Board("badcredit")
    proc = run_stream(board, field_csv, "--timeout", "10")
    assert_clean_failure(proc, board)
    assert "malformed credit line 'CREDIT abc'" in proc.stderr, proc.stderr
    assert board.rows() == []  # no credit, no row
    assert board.commands()[-1] == "STOP" and board.outputs == MIDSCALE
