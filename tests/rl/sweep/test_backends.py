"""The process backend's job runner: results in job order, errors reported or raised; SIGTERM
stops it as Ctrl-C does, and its workers never outlive it."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from elastica_magnetic_rl.sweep.backends import run_in_processes


def test_results_keep_the_job_order_and_a_failing_job_is_reported():
    out = run_in_processes(math.sqrt, [9.0, 4.0, -1.0, 16.0], 2,
                           on_error=lambda k, exc: f"job {k}: {exc}")
    assert out == [3.0, 2.0, "job 2: math domain error", 4.0]


def test_without_an_error_handler_the_jobs_exception_is_raised():
    with pytest.raises(ValueError, match="math domain error"):
        run_in_processes(math.sqrt, [4.0, -1.0, 9.0], 2)


def test_a_job_no_worker_can_receive_is_refused_before_the_pool_starts():
    """A job that does not pickle (a residual policy's yardstick maker was once a lambda) raised in
    the pool's feeder thread and left ``msr policy ship`` waiting for ever on idle workers."""
    start = time.perf_counter()
    with pytest.raises(TypeError, match="job 1 of 3 cannot be sent to a worker process"):
        run_in_processes(abs, [1.0, lambda: 2.0, 3.0], 2)
    assert time.perf_counter() - start < 5.0


# -- signals: the workers never outlive the sweep that started them ---------------------------

SLEEPER = '''
import os, pathlib, time
def sleep_and_record(k):
    pathlib.Path(os.environ["MSR_TEST_PIDS"], str(k)).write_text(str(os.getpid()))
    time.sleep(120)
    return k
'''

DRIVER = '''
import sys
sys.path.insert(0, {folder!r})
from sleeper import sleep_and_record
from elastica_magnetic_rl.sweep.backends import run_in_processes
if __name__ == "__main__":
    try:
        run_in_processes(sleep_and_record, list(range({jobs})), 2, stop_grace_s=1.0)
    except KeyboardInterrupt as exc:
        print("stopped:", type(exc).__name__, exc, getattr(exc, "signum", None), flush=True)
        sys.exit(130)
'''


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def _start_sweep(tmp_path: Path, jobs: int = 2) -> tuple[subprocess.Popen, list[int]]:
    """A driver process running two sleeping workers (``jobs`` jobs: those beyond two wait),
    started as a shell's background job (SIGINT ignored); returns it and its workers' pids once
    two jobs run."""
    (tmp_path / "sleeper.py").write_text(SLEEPER)
    (tmp_path / "driver.py").write_text(DRIVER.format(folder=str(tmp_path), jobs=jobs))
    pids = tmp_path / "pids"
    pids.mkdir()
    env = {**os.environ, "MSR_TEST_PIDS": str(pids)}
    proc = subprocess.Popen([sys.executable, str(tmp_path / "driver.py")], env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    deadline = time.monotonic() + 120
    # each worker creates its file, then writes its pid: wait for both pids, not the files alone
    while len(written := [p.read_text() for p in pids.iterdir()]) < 2 or not all(
            text.strip().isdigit() for text in written):
        assert proc.poll() is None, proc.stdout.read()
        assert time.monotonic() < deadline, "the workers did not start"
        time.sleep(0.2)
    return proc, [int(text) for text in written]


def _wait_gone(pids: list[int], timeout: float) -> list[int]:
    deadline = time.monotonic() + timeout
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.2)
    return [p for p in pids if _alive(p)]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_stops_the_sweep_and_its_workers_as_ctrl_c_does(tmp_path):
    proc, workers = _start_sweep(tmp_path)
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130, out
    assert "stopped: Interrupted SIGTERM 15" in out  # the signal kept (msr exits 143)
    assert _wait_gone(workers, 10) == []


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_end_themselves_when_the_sweep_is_killed(tmp_path):
    proc, workers = _start_sweep(tmp_path)
    proc.kill()
    proc.wait(timeout=30)
    assert _wait_gone(workers, 15) == []  # they poll their parent every second


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_with_jobs_still_queued_prints_no_traceback(tmp_path):
    """Round 14 T1: SIGTERM to ``msr field baseline``'s sweep (more jobs than workers) printed a
    traceback of the pool's management thread (``InvalidStateError: CANCELLED`` in
    ``terminate_broken``: a job not started, cancelled, then failed when the workers were ended)
    and at times the resource tracker's "leaked semaphore objects"."""
    proc, workers = _start_sweep(tmp_path, jobs=6)
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130, out
    assert "stopped: Interrupted SIGTERM 15" in out
    assert "Traceback" not in out and "InvalidStateError" not in out and "leaked" not in out, out
    assert _wait_gone(workers, 10) == []


def _interrupted_inside_an_import(job):
    try:
        raise KeyboardInterrupt
    except KeyboardInterrupt:  # what Python does to a Ctrl-C inside a class body it is building
        raise RuntimeError("Error calling __set_name__ on 'Field' instance 'size'") from None


def test_a_ctrl_c_wrapped_by_python_stops_the_seeds_not_fails_one():
    """Round 51 (seen once): a Ctrl-C during a seed's torch import came back as "training failed:
    RuntimeError: Error calling __set_name__ ..." instead of an interruption."""
    from types import SimpleNamespace

    from elastica_magnetic_rl.sweep.backends import run_jobs

    with pytest.raises(KeyboardInterrupt):
        run_jobs(_interrupted_inside_an_import, [SimpleNamespace(seed=0)], workers=1)
    failing = run_jobs(lambda job: 1 / 0, [SimpleNamespace(seed=0)], workers=1)
    assert failing[0]["error"].startswith("ZeroDivisionError")


def test_a_ctrl_c_while_the_jobs_are_handed_out_ends_the_workers(monkeypatch):
    """Session 29's CI (once in five runs): a Ctrl-C that arrived while the pool took its jobs, before
    the handling that ends the workers, left them running their jobs and ``msr policy export-seeds``
    waiting on them at exit. Here the interrupt comes right after the second job is handed out."""
    from concurrent.futures import ProcessPoolExecutor

    real_submit = ProcessPoolExecutor.submit
    pools: list[ProcessPoolExecutor] = []

    def submit_then_interrupt(pool, fn, *args, **kwargs):
        future = real_submit(pool, fn, *args, **kwargs)
        pools.append(pool)
        if len(pools) == 2:
            raise KeyboardInterrupt
        return future

    monkeypatch.setattr(ProcessPoolExecutor, "submit", submit_then_interrupt)
    start = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        run_in_processes(time.sleep, [120.0, 120.0], 2, stop_grace_s=0.5, quiet_interrupt=True)
    processes = list((pools[0]._processes or {}).values())
    try:
        assert time.monotonic() - start < 30.0
        assert [p for p in processes if p.is_alive()] == [], "workers still run their jobs"
    finally:  # without the handling they sleep on; do not leave them to the pool's exit
        for process in processes:
            process.terminate()

