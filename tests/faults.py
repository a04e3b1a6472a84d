"""Faults injected into real ``msr`` processes (issue 35's fault-injection suite).

:class:`FaultServer` starts one Python process that imports the package once, then forks a fresh
child per command: each command runs in a real process of its own (killed for real by SIGKILL,
its files on disk as a crash leaves them) without paying the imports each time (about 5 s).

A :class:`Fault` says what goes wrong in the child, at the Python level (``open``, ``write``,
``os.rename``/``os.replace`` of the standard library; files written by C++, such as
``torch.jit`` saving to a path, are not seen):

- ``Fault("open", PATTERN, SIGNAL, nth=N)``: SIGNAL to itself when the N-th file whose path
  matches the regular expression PATTERN is opened for writing;
- ``Fault("write", PATTERN, SIGNAL, nth=N, after=B)``: SIGNAL once more than B bytes (or
  characters) were written to the N-th such file: killed in the middle of a file;
- ``Fault("enospc", PATTERN, nth=N, after=B)``: writes to the N-th such file fail with ENOSPC
  past B bytes (a full disk);
- ``Fault("rename", PATTERN, SIGNAL, nth=N)``: SIGNAL right after the N-th rename whose
  destination matches PATTERN (between the two renames of a swap, in the middle of moves).

Used by ``tests/rl/test_command_faults.py`` (importable from every test folder: pytest puts
``tests/`` on ``sys.path`` for its ``conftest.py``).
"""

from __future__ import annotations

import builtins
import errno
import json
import os
import re
import select
import signal
import subprocess
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent


@dataclass(frozen=True)
class Fault:
    action: str  # "open", "write", "enospc" or "rename"
    pattern: str  # regular expression, searched in the path (rename: the destination)
    signal: str = ""  # "SIGKILL", "SIGINT", "SIGTERM" (not for enospc)
    nth: int = 1
    after: int = 0


@dataclass
class Done:
    """What a command run by :meth:`FaultServer.run` did: exit status (``-9``: killed by
    SIGKILL) and its output."""

    returncode: int
    stdout: str
    stderr: str


class _Failing:
    """A file object whose writes fail (``enospc``) or end the process (``write``) past a count."""

    def __init__(self, handle: Any, fault: Fault) -> None:
        self._handle, self._fault, self._count = handle, fault, 0

    def write(self, data: Any) -> int:
        self._count += len(data)
        if self._count > self._fault.after:
            if self._fault.action == "enospc":
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            part = len(data) - (self._count - self._fault.after)
            self._handle.write(data[:part])  # the part that reached the disk
            self._handle.flush()
            os.kill(os.getpid(), getattr(signal, self._fault.signal))
        return self._handle.write(data)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def __enter__(self) -> _Failing:
        return self

    def __exit__(self, *exc: object) -> Any:
        return self._handle.__exit__(*exc)

    def __iter__(self) -> Any:
        return iter(self._handle)


def install(fault: Fault | None) -> None:
    """Patch this process's ``open`` and renames to inject ``fault``."""
    if fault is None:
        return
    matcher = re.compile(fault.pattern)
    seen = {"files": 0, "renames": 0}
    real_open, real_rename, real_replace = builtins.open, os.rename, os.replace

    def fire() -> None:
        os.kill(os.getpid(), getattr(signal, fault.signal))

    def patched_open(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        handle = real_open(file, mode, *args, **kwargs)
        if fault.action == "rename" or not any(c in mode for c in "wax+"):
            return handle
        if not isinstance(file, (str, os.PathLike)) or not matcher.search(os.fspath(file)):
            return handle
        seen["files"] += 1
        if seen["files"] != fault.nth:
            return handle
        if fault.action == "open":
            fire()
            return handle
        return _Failing(handle, fault)

    def after_rename(dst: Any) -> None:
        if fault.action == "rename" and matcher.search(os.fspath(dst)):
            seen["renames"] += 1
            if seen["renames"] == fault.nth:
                fire()

    def patched_rename(src: Any, dst: Any, *args: Any, **kwargs: Any) -> None:
        real_rename(src, dst, *args, **kwargs)
        after_rename(dst)

    def patched_replace(src: Any, dst: Any, *args: Any, **kwargs: Any) -> None:
        real_replace(src, dst, *args, **kwargs)
        after_rename(dst)

    builtins.open, os.rename, os.replace = patched_open, patched_rename, patched_replace


def _child(request: dict[str, Any]) -> None:
    """In the forked child: a fresh command's signal handlers, the fault, ``msr ARGV``."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for other in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(other, signal.SIG_DFL)
    os.chdir(request["cwd"])
    for stream, name in ((1, "stdout"), (2, "stderr")):
        fd = os.open(request[name], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(fd, stream)
        os.close(fd)
    sys.stdout = sys.__stdout__  # the server writes its replies there, and prints on stderr
    sys.argv = ["msr", *request["argv"]]
    status = 1
    try:
        from elastica_magnetic.cli import main

        install(Fault(**request["fault"]) if request["fault"] else None)
        status = main(request["argv"])
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else 1
    except BaseException:  # noqa: BLE001 - report, as an uncaught exception would
        import traceback

        traceback.print_exc()
        status = 1
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(int(status))


def serve() -> None:
    """The server's loop: one JSON request per line on stdin, one status per line on stdout."""
    import elastica_magnetic_rl.cli.commands  # noqa: F401
    import elastica_magnetic_rl.cli.rollout_commands  # noqa: F401
    import torch  # noqa: F401

    import elastica_magnetic.cli  # noqa: F401 - imported once, inherited by every child

    reply = sys.stdout
    sys.stdout = sys.stderr
    reply.write("ready\n")
    reply.flush()
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            _child(request)
        _, status = os.waitpid(pid, 0)
        code = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
        reply.write(f"{code}\n")
        reply.flush()


class FaultServer:
    """The warm parent of the commands' processes (see the module docstring); :meth:`close` it."""

    def __init__(self, workdir: Path) -> None:
        self.workdir = Path(workdir)
        self.workdir.mkdir(parents=True, exist_ok=True)
        env = {**os.environ, "MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1"}
        self.proc = subprocess.Popen(
            [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(HERE)!r}); "
                                   "import faults; faults.serve()"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env,
            start_new_session=True)
        self.runs = 0
        if self.proc.stdout.readline().strip() != "ready":
            self.close()
            raise RuntimeError("the fault server did not start")

    def run(self, argv: list[str], fault: Fault | None = None, cwd: Path | None = None,
            timeout_s: float = 300.0) -> Done:
        """``msr ARGV`` in a fresh child process with ``fault``; waits for its end (at most
        ``timeout_s``: then the server and its child are killed and the test fails)."""
        self.runs += 1
        out = self.workdir / f"run{self.runs}"
        request = {"argv": [str(a) for a in argv], "fault": asdict(fault) if fault else None,
                   "cwd": str(cwd or self.workdir), "stdout": f"{out}.out",
                   "stderr": f"{out}.err"}
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout_s)
        if not ready:
            os.killpg(self.proc.pid, signal.SIGKILL)  # the server and the hanging command
            self.proc.wait()
            raise TimeoutError(f"msr {' '.join(request['argv'])} did not end in {timeout_s:g} s")
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError("the fault server ended")
        return Done(int(line), Path(f"{out}.out").read_text(), Path(f"{out}.err").read_text())

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
