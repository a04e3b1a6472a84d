"""A network URL without a usable TCP port (issue 48, "Tracebacks and vague messages", item 4):
``msr real stream --port socket://127.0.0.1`` said "cannot open the port (Could not open port
socket://127.0.0.1: '<=' not supported between instances of 'int' and 'NoneType')". It is now
named, with an example, before any file is read or the port opened."""

from __future__ import annotations

import numpy as np
import pytest
import serial

from elastica_magnetic.cli import main
from elastica_magnetic.hardware.stream import StreamError, port_url_problem, stream_field

BAD_PORTS = [
    ("socket://127.0.0.1", "socket://127.0.0.1: the URL has no port; e.g. socket://127.0.0.1:4321"),
    ("socket://127.0.0.1:", "socket://127.0.0.1:: the URL has no port; e.g. socket://127.0.0.1:4321"),
    ("socket://[::1]", "socket://[::1]: the URL has no port; e.g. socket://[::1]:4321"),
    ("rfc2217://board", "rfc2217://board: the URL has no port; e.g. rfc2217://board:4321"),
    ("socket://127.0.0.1:abc", "socket://127.0.0.1:abc: the port 'abc' is not a TCP port (a whole "
     "number from 1 to 65535); e.g. socket://127.0.0.1:4321"),
    ("socket://127.0.0.1:99999", "socket://127.0.0.1:99999: the port '99999' is not a TCP port"),
    ("socket://127.0.0.1:0", "socket://127.0.0.1:0: the port '0' is not a TCP port"),
]


@pytest.fixture
def no_port_opened(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the port was opened before its URL was checked")

    monkeypatch.setattr(serial, "serial_for_url", refuse)


@pytest.mark.parametrize("port, message", BAD_PORTS)
def test_stream_names_a_url_without_a_usable_port(port, message, tmp_path, capsys, no_port_opened):
    missing = tmp_path / "not-read.csv"  # checked before the field CSV is read
    assert main(["real", "stream", str(missing), "--port", port, "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"msr real stream: error: --port {message}"), err


def test_calibrate_names_the_upload_port_before_writing(tmp_path, capsys, no_port_opened):
    out = tmp_path / "cal.json"
    assert main(["real", "calibrate", str(tmp_path / "m.csv"), "--out", str(out), "--upload",
                 "socket://127.0.0.1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "msr real calibrate: error: --upload socket://127.0.0.1: the URL has no port; e.g. "
        "socket://127.0.0.1:4321")
    assert not out.exists()


def test_the_library_names_it_too(no_port_opened):
    with pytest.raises(StreamError) as info:
        stream_field("socket://127.0.0.1", np.zeros((3, 3)), progress=False)
    assert str(info.value) == ("socket://127.0.0.1: the URL has no port; e.g. "
                               "socket://127.0.0.1:4321; nothing was sent")


@pytest.mark.parametrize("port", ["socket://127.0.0.1:4321", "socket://localhost:4321/logging=debug",
                                  "rfc2217://[::1]:2217?ign_set_control", "loop://", "/dev/ttyACM0",
                                  "COM3", "spy:///dev/ttyUSB0"])
def test_usable_ports_pass(port):
    assert port_url_problem(port) is None

