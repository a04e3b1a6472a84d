"""Where the seeds of a sweep run: worker processes on this machine, or Ray tasks.

:func:`run_jobs` runs one function (``elastica_magnetic_rl.sweep.training._train_group``: the training of a
group of seeds side by side) on a list of jobs (:class:`~elastica_magnetic_rl.sweep.jobs.GroupJob`: plain,
picklable data) and gathers its results by seed. Both
backends call the same function with the same job; only the transport differs, so the run directories,
checkpoints and returned summaries are the same whichever backend ran them.

``"process"`` (default)
    ``workers == 1``: in this process, one group after the other. Otherwise a
    :class:`~concurrent.futures.ProcessPoolExecutor` of ``workers`` processes, each seed with its
    own progress bar. The processes are forked from a fork server that imported the heavy
    modules once (:data:`WORKER_PRELOAD`), so a pool starts in a fraction of a second, not in the
    seconds a fresh interpreter takes to import PyTorch and PyElastica.

``"ray"``
    Each group of seeds is a ``ray.remote`` task (``num_cpus`` = the torch threads of a worker, no retries),
    at most ``workers`` in flight at a time. Without an ``address`` a private local Ray instance is started
    with ``workers x threads`` CPUs (no dashboard, usage statistics off unless ``RAY_USAGE_STATS_ENABLED``
    says otherwise, quiet logging) and shut down at the end; with an ``address`` (``auto``, ``HOST:PORT``,
    ``ray://HOST:10001``) the driver connects to that cluster and disconnects at the end (the cluster keeps
    running). When Ray is already initialised in this process, it is used as it is and left running.

    The workers write the run directories themselves, so the output folder must be a path that
    every node sees at the same place: on a single machine it is just the same folder; on a
    cluster use a shared filesystem (NFS, a mounted bucket) mounted at the same path on every
    node, and install this package (same version) on every node. A seed whose finished run
    directory the driver cannot see is reported as failed with that reason.

    Progress: the workers' output goes to Ray's log files (not the terminal), so there is no
    per-seed bar; the driver prints one line per finished seed on stderr instead.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import pickle
import sys
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, replace
from typing import Any

from elastica_magnetic.interrupts import Interrupted

from ..runfiles.rundir import CaseDir, RunDir
from .jobs import GroupJob

__all__ = ["BACKENDS", "Rebalancing", "run_in_processes", "run_jobs"]

#: Backend names accepted by :func:`run_jobs` (and ``msr train --backend``).
BACKENDS = ("process", "ray")

#: Object store of a local Ray instance: only small result dicts travel through it.
LOCAL_OBJECT_STORE_BYTES = 128 * 1024**2


def _error(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


@dataclass(frozen=True)
class Rebalancing:
    """How a pool of worker processes keeps every worker busy once no job is waiting: it asks the
    running jobs to hand back the work they have not done (``request``: called once per running
    job while a worker is idle and the queue is empty), continues a job that handed some back in
    new jobs over the free workers (``split(job, result, free_workers)``: the continuation jobs,
    ``[]`` when the job finished whole), and folds each continuation's result, or the exception
    it raised, into the result of the job it continues (``merge(result, continuation, outcome)``).
    The training of groups of seeds is the user (:mod:`elastica_magnetic_rl.sweep.rebalance`)."""

    request: Callable[[Any], None]
    split: Callable[[Any, Any, int], list[Any]]
    merge: Callable[[Any, Any, Any], Any]


def run_jobs(
    fn: Callable[[GroupJob], dict[str, Any]],
    jobs: list[GroupJob],
    workers: int,
    backend: str = "process",
    address: str | None = None,
    progress: bool = True,
    rebalancing: Rebalancing | None = None,
) -> list[dict[str, Any]]:
    """Run ``fn(job)`` for every job and return the results in the order of ``jobs`` (jobs may
    differ in case and seed: a sweep is one list).

    A job that raises does not stop the others: its result is ``{"seed": s, "error": "Type: msg"}``.
    ``address`` (a Ray cluster) is only for ``backend="ray"``; ``progress`` only affects the Ray
    backend's per-seed lines (the process backend's bars are set in the jobs). ``rebalancing``
    (process backend with several workers only; ignored otherwise): see :class:`Rebalancing`.
    """
    if backend not in BACKENDS:
        raise ValueError(f"unknown backend {backend!r}; choose one of {', '.join(BACKENDS)}")
    if address is not None and backend != "ray":
        raise ValueError("an address is for the ray backend (--backend ray)")
    if backend == "ray":
        return _run_ray(fn, jobs, workers, address, progress)
    return _run_processes(fn, jobs, workers, rebalancing)


def _run_processes(fn, jobs, workers, rebalancing=None) -> list[dict[str, Any]]:
    results: list[dict[str, Any]] = [{} for _ in jobs]
    if workers == 1:
        for k, job in enumerate(jobs):
            try:
                results[k] = fn(job)
            except Exception as exc:  # keep the other seeds going; report the failure
                if _raised_by_an_interrupt(exc):  # e.g. a Ctrl-C inside an import, wrapped by Python
                    raise KeyboardInterrupt from exc
                results[k] = {"seed": job.seed, "error": _error(exc)}
    else:
        results = run_in_processes(fn, jobs, workers, on_error=lambda k, exc: {
            "seed": jobs[k].seed, "error": _error(exc)}, rebalancing=rebalancing)
    return results


def _raised_by_an_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` was raised while handling a Ctrl-C (a ``KeyboardInterrupt`` in its chain of
    causes and contexts): the seed was interrupted, not failed."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


def run_in_processes(
    fn: Callable[[Any], Any],
    jobs: list[Any],
    workers: int,
    on_error: Callable[[int, Exception], Any] | None = None,
    stop_grace_s: float | None = None,
    quiet_interrupt: bool = False,
    rebalancing: Rebalancing | None = None,
) -> list[Any]:
    """``fn(job)`` for every job in ``workers`` processes (:func:`worker_context`), the results in
    the order of ``jobs``. A job that raises gives ``on_error(k, exception)`` as its result, or, without
    ``on_error``, the exception is raised here (the jobs not started are dropped). With
    ``rebalancing`` (:class:`Rebalancing`), a job's result includes those of its continuations.

    Ctrl-C (KeyboardInterrupt) stops the workers within :data:`STOP_GRACE_S` (see
    :func:`_stop_workers`) and is raised again; a plain ``ProcessPoolExecutor`` would wait for
    every queued job, and for ever after a SIGINT to this process alone. ``stop_grace_s``
    (default :data:`STOP_GRACE_S`) is how long the workers get; ``quiet_interrupt``: the workers
    ignore SIGINT (no traceback of theirs on a Ctrl-C from the terminal) and are ended by this
    process (for jobs that lose nothing when ended, such as evaluations).
    """
    for k, job in enumerate(jobs):  # refused here: in the pool's feeder thread it left the pool hanging
        try:
            pickle.dumps(job)
        except (pickle.PicklingError, AttributeError, TypeError) as exc:
            raise TypeError(f"job {k} of {len(jobs)} cannot be sent to a worker process: {exc}") from None
    context = worker_context()
    grace = STOP_GRACE_S if stop_grace_s is None else stop_grace_s
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context,
                               initializer=_init_worker, initargs=(os.getpid(), quiet_interrupt))
    futures: dict[Any, tuple[int, Any]] = {}
    results: list[Any] = [None] * len(jobs)
    asked: set[Any] = set()  # the futures asked to hand work back
    try:
        with _termination_as_interrupt():
            # handed out inside: a Ctrl-C while the workers start and take their jobs still ends them
            # (outside, it left them running their jobs and this process waiting on them at exit)
            for k, job in enumerate(jobs):
                futures[pool.submit(fn, job)] = (k, job)
            running = set(futures)
            while running:
                done, running = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    k, job = futures[future]
                    try:
                        outcome = future.result()
                    except Exception as exc:
                        if on_error is None and (rebalancing is None or job is jobs[k]):
                            raise
                        outcome = exc
                    if job is not jobs[k]:  # a continuation of job k
                        results[k] = rebalancing.merge(results[k], job, outcome)
                    else:
                        results[k] = on_error(k, outcome) if isinstance(outcome, Exception) \
                            else outcome
                    if rebalancing is not None and not isinstance(outcome, Exception):
                        for more in rebalancing.split(job, outcome, workers - len(running)):
                            new = pool.submit(fn, more)
                            futures[new] = (k, more)
                            running.add(new)
                if rebalancing is not None and len(running) < workers:
                    for future in running - asked:  # a worker is idle: hand work over to it
                        rebalancing.request(futures[future][1])
                        asked.add(future)
    except KeyboardInterrupt:
        _stop_workers(pool, futures, grace)
        raise
    except BaseException:
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown(wait=True)
    return results


#: What the fork server of the worker processes imports once, before it forks any worker: PyTorch
#: with the compiler front end its optimizers load at their first step, PyElastica (and through it
#: SciPy), and the training; every job run in a worker needs most of them. A fresh interpreter per
#: worker (``spawn``) imported them anew: seconds per worker, in every pool.
WORKER_PRELOAD = ("torch", "torch._dynamo", "elastica", "elastica_magnetic_rl.sweep.training")


def run_each(fn: Callable[[Any], Any], jobs: list[Any], workers: int, *, progress: bool = True,
             label: str = "run", on_error: Callable[[int, Exception], Any] | None = None) -> list[Any]:
    """``fn(job)`` for every job, the results in the order of ``jobs``: with ``workers`` 1 in this
    process, one after the other under a progress bar (``label``; a job that raises raises here),
    else :func:`run_in_processes` (``on_error`` as there)."""
    if workers > 1:
        return run_in_processes(fn, jobs, workers, on_error=on_error)
    from elastica_magnetic.progress import progress_bar

    results = []
    with progress_bar(len(jobs), label, "run", disable=not progress, leave=False) as bar:
        for job in jobs:
            results.append(fn(job))
            bar.update()
    return results


def worker_context() -> multiprocessing.context.BaseContext:
    """The start method of the worker processes: ``forkserver`` with :data:`WORKER_PRELOAD`
    imported in the server, started (once per process) with SIGINT ignored, so a Ctrl-C while it
    imports prints no traceback and never ends it; each worker sets its own SIGINT handling
    (:func:`_init_worker`). A fork from a server that has run nothing (no threads, no PyTorch
    thread pool yet) is safe, unlike a fork of this process."""
    from multiprocessing import forkserver

    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(WORKER_PRELOAD))
    with _sigint_ignored_while_spawning(True):
        forkserver.ensure_running()
    # Wait here until the server serves (its imports take seconds the first time): a Ctrl-C then
    # stops nothing half made, where one during a pool's start would leave the server to fork a
    # worker for a pool already gone (a traceback of its own). The probe carries no lock.
    probe = context.Process(target=_serving, name="msr-fork-server-probe", daemon=True)
    probe.start()
    probe.join()
    return context


def _serving() -> None:
    """The fork server's probe (:func:`worker_context`): nothing to do."""


#: Seconds the workers get, after a Ctrl-C, to stop by themselves before they are ended.
STOP_GRACE_S = 10.0


@contextlib.contextmanager
def _sigint_ignored_while_spawning(active: bool):
    """SIGINT ignored in this process while a child starts (``active``, main thread only): the
    child keeps the ignored disposition from its first instruction (Python leaves an ignored SIGINT
    ignored), so a Ctrl-C while it imports prints no traceback of its own; restored after."""
    import signal
    import threading

    if not active or threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


#: Seconds between a worker's checks that the process that started it is still alive.
PARENT_POLL_S = 1.0


def _init_worker(parent_pid: int, ignore_sigint: bool) -> None:
    """Worker initializer: with ``ignore_sigint``, Ctrl-C is the parent's to handle (it ends the
    worker), otherwise it raises KeyboardInterrupt here as in any Python program (set explicitly:
    a worker forked from the fork server starts with the server's SIGINT ignored); in every case
    the worker ends itself (SIGTERM, as the parent would) once the process that started the pool
    is gone (killed with SIGKILL, or ended by a signal it could not catch), so an orphaned worker
    never goes on writing a run folder that nobody owns any more. A worker loses at most the steps
    since its last checkpoint, which is written atomically."""
    import signal
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN if ignore_sigint else signal.default_int_handler)

    def watch() -> None:
        _wait_for_exit(parent_pid)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, name="msr-parent-watch", daemon=True).start()


def _wait_for_exit(pid: int) -> None:
    """Return once process ``pid`` has ended. Not through ``os.getppid()``: a worker's parent is
    the fork server, which lives on while any worker does. A pidfd (Linux) is readable once the
    process has ended, zombie or not; elsewhere the process is looked up every
    :data:`PARENT_POLL_S` seconds."""
    import select

    try:
        handle = os.pidfd_open(pid)
    except ProcessLookupError:
        return
    except (AttributeError, OSError):
        while True:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                return
            except PermissionError:
                pass
            time.sleep(PARENT_POLL_S)
    try:
        select.select([handle], [], [])
    finally:
        os.close(handle)


@contextlib.contextmanager
def _termination_as_interrupt():
    """SIGTERM and SIGHUP in this process (main thread only) raise
    :class:`~elastica_magnetic.interrupts.Interrupted` (a :class:`KeyboardInterrupt` carrying the
    signal, so ``msr`` reports it and exits 128 + its number) while the workers run, so
    ``kill PID`` or a closed terminal stops the workers as Ctrl-C does (a shell's background job
    ignores SIGINT, which leaves SIGTERM as the way to stop it); the previous handlers are
    restored after."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise Interrupted(signum)  # not a bare KeyboardInterrupt: that would read as SIGINT

    names = [n for n in ("SIGTERM", "SIGHUP") if hasattr(signal, n)]
    previous = {n: signal.signal(getattr(signal, n), interrupt) for n in names}
    try:
        yield
    finally:
        for n, handler in previous.items():
            signal.signal(getattr(signal, n), handler)


def _stop_workers(pool: ProcessPoolExecutor, futures, grace: float = STOP_GRACE_S) -> None:
    """Ctrl-C in this process: end the workers, never wait on them for good.

    From a terminal the workers get the same SIGINT (it goes to the whole process group) and stop
    at their next step; they get :data:`STOP_GRACE_S` for it. If a job still runs then, as after
    a ``kill -INT`` of this process alone, where waiting on the pool would wait for the whole
    training, every worker is ended (SIGTERM; the multiprocessing resource tracker may then warn
    of the workers' semaphores, which it releases). Ending a worker loses at most the steps
    since its last checkpoint, which is written atomically, so ``--resume`` continues from it.

    The jobs not started yet are cancelled by the pool's own management thread (``shutdown``
    with ``cancel_futures``), not here: one cancelled here but still on its list of pending jobs
    made that thread fail (``InvalidStateError: CANCELLED``, printed as a traceback, its queues'
    semaphores left to the resource tracker's "leaked" warning) when it found a worker ended and
    marked every pending job failed (Python before 3.12). The thread takes the shutdown before
    it looks at the ended workers, so by then only started jobs are on that list.
    """
    # no public handle on the processes or the thread before Python 3.14 (terminate_workers);
    # shutdown(wait=False) lets go of them, so they are taken first
    processes = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    pool.shutdown(wait=False, cancel_futures=True)  # the jobs not started yet: cancelled
    try:
        running = wait(futures, timeout=grace).not_done if grace > 0 else {
            future for future in futures if not future.done()}
    except KeyboardInterrupt:  # a second Ctrl-C: end them now
        running = {future for future in futures if not future.done()}
    if running:
        for process in processes:
            if process.is_alive():
                process.terminate()
            process.join()
    if manager is not None:  # it ends once no job runs (each one done or failed by the ending)
        manager.join()
    pool.shutdown(wait=True, cancel_futures=True)


def _run_ray(fn, jobs, workers, address, progress) -> list[dict[str, Any]]:
    # Before importing ray: a local instance must not report usage statistics (no network).
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    import ray

    threads = max(int(job.threads) for job in jobs) if jobs else 1
    started = False
    if not ray.is_initialized():
        quiet = {"log_to_driver": False, "logging_level": logging.ERROR}
        if address and address.startswith("ray://"):  # Ray Client: the cluster's own settings
            ray.init(address=address)
        elif address:
            ray.init(address=address, **quiet)
        else:
            ray.init(address="local", num_cpus=workers * threads, include_dashboard=False,
                     object_store_memory=LOCAL_OBJECT_STORE_BYTES, **quiet)
        started = True
    results: list[dict[str, Any]] = [{} for _ in jobs]
    finished = 0
    start = time.perf_counter()
    try:
        task = ray.remote(num_cpus=threads, max_retries=0)(fn)
        queue = [(k, replace(job, progress=False)) for k, job in enumerate(jobs)]  # no bars in Ray
        pending: dict[Any, tuple[int, GroupJob]] = {}
        while queue or pending:
            while queue and len(pending) < workers:
                k, job = queue.pop(0)
                pending[task.remote(job)] = (k, job)
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                k, job = pending.pop(ref)
                seed = job.seed
                try:
                    result = ray.get(ref)
                except Exception as exc:  # RayTaskError wraps the worker's exception
                    result = {"seed": seed, "error": _error(getattr(exc, "cause", None) or exc)}
                if "error" not in result and not RunDir(job.run_dir).has_checkpoint():
                    result = {"seed": seed, "error": f"{job.run_dir}: the run directory written by "
                              "the Ray worker is not visible here (put --out on a filesystem shared "
                              "by all nodes, at the same path)"}
                results[k] = result
                finished += 1
                if progress:
                    status = result.get("error") or "; ".join(
                        f"{CaseDir.seed_name(r['seed'])} final mean return {r['final_mean_return']:.4g}, "
                        f"{r['episodes']} episodes, {r['wall_s']:.1f} s"
                        for r in result.get("group", [result]))
                    print(f"[ray] {job.case} {CaseDir.seed_name(seed)} done ({finished}/{len(jobs)}, "
                          f"{time.perf_counter() - start:.0f} s): {status}", file=sys.stderr, flush=True)
    finally:
        if started:
            ray.shutdown()
    return results
