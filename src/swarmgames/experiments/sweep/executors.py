"""Where the runs of a sweep execute: in this process, in local processes, or on Ray.

Every executor calls the same :func:`execute` on each :class:`RunTask`, reports each outcome
as it arrives (``on_done(index, outcome)``, in the caller's thread) and returns whether the
sweep was interrupted. A run that fails is an outcome (``status = "failed"`` with its error),
never an exception. Ctrl-C, SIGTERM or SIGHUP, or a run that reports itself interrupted, stops
the sweep: runs not started are not started, running ones stop at the end of their current
stage and keep their completed stages (``status = "interrupted"``; the next sweep resumes
them).

* ``local`` with one job runs in this process (plug-in missions registered at run time work
  only here);
* ``local`` with more jobs uses a :class:`~concurrent.futures.ProcessPoolExecutor` of spawned
  processes (no fork: Numba's threads and a forked process do not mix). A worker that dies
  (killed, out of memory, a crash in compiled code) fails only the run it was running, with
  the cause: the pool is rebuilt and the other runs go on (those the broken pool stopped
  continue from their checkpoints). Workers end with the sweep's process however it ends
  (``PR_SET_PDEATHSIG`` on Linux, and a thread watching the parent's process id elsewhere);
* ``ray`` sends each run to a Ray cluster (``ray.init(address=...)``) or to a local Ray of
  ``jobs`` CPUs; the optional extra ``pip install 'swarmgames[ray]'``. On a cluster, every
  node needs swarmgames and the sweep's folder (a shared file system).
"""

from __future__ import annotations

import atexit
import contextlib
import json
import os
import shutil
import signal
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from swarmgames.allocator import reuse_freed_memory
from swarmgames.config import ScenarioConfig
from swarmgames.errors import BackendUnavailableError, RunFolderError
from swarmgames.lifetime import end_with
from swarmgames.sim.signals import INTERRUPT_SIGNALS, signals_interrupt

__all__ = ["EXECUTORS", "RunTask", "default_jobs", "execute", "import_ray", "run_tasks"]

EXECUTORS = ("local", "ray")

#: ``on_done(index, outcome)``: an outcome is ``{"status", "error", "summary"}``.
OnDone = Callable[[int, dict[str, Any]], None]

#: Set in each worker process of the local pool by :func:`_init_worker`: the sweep's stop
#: event, seen by tasks that start after an interruption.
_STOP: Any = None
#: Set likewise: where a worker says which task it starts and ends (``(index, pid, ended)``).
_STARTED: Any = None


@dataclass(frozen=True)
class RunTask:
    """One run to execute.

    Attributes
    ----------
    folder : str
        Absolute path of its run folder.
    config : ScenarioConfig
    resume : bool
        Continue the interrupted run in ``folder`` (from scratch if it cannot be continued).
    threads : int, optional
        Threads of the compiled kernels (Numba) while it runs: the executors give each run
        its share of the CPUs, so that runs side by side do not each start a thread per core.
        None: as they are.
    figures : bool
        Write the run's figures and animation (else its tables and summary alone).
    """

    folder: str
    config: ScenarioConfig
    resume: bool = False
    threads: int | None = None
    figures: bool = True


def default_jobs() -> int:
    """The CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _outcome(
    status: str, error: str = "", summary: dict | None = None, note: str = ""
) -> dict[str, Any]:
    return {"status": status, "error": error, "summary": dict(summary or {}), "note": note}


def _fresh(task: RunTask):
    from swarmgames.sim import run

    shutil.rmtree(task.folder, ignore_errors=True)
    return run(task.config, out=task.folder, progress=False, figures=task.figures)


def execute(task: RunTask) -> dict[str, Any]:
    """Run (or resume) one run of a sweep into its folder.

    A top-level function of plain arguments, so that spawned processes and Ray workers can
    call it.

    Returns
    -------
    dict
        ``status`` (``"complete"``, ``"failed"`` or ``"interrupted"``), ``error`` (``"Type:
        message"`` of a failed run, else ``""``), ``summary`` (the run's ``summary.json``;
        empty unless complete or interrupted) and ``note`` (why a run to continue was run
        from scratch, else ``""``).
    """
    from swarmgames.sim import NotResumableError, resume
    from swarmgames.sim.journal import read_manifest, verify_run

    if task.threads is not None:
        import numba

        numba.set_num_threads(min(task.threads, numba.config.NUMBA_NUM_THREADS))
    with signals_interrupt():
        if _STOP is not None and _STOP.is_set():
            return _outcome("interrupted")
        note = ""
        if task.resume:  # a run may have ended just before its worker was stopped
            with contextlib.suppress(RunFolderError, OSError, ValueError):
                manifest = read_manifest(task.folder)
                if manifest["status"] == "complete":
                    verify_run(task.folder, manifest)
                    summary = json.loads((Path(task.folder) / "summary.json").read_text())
                    return _outcome("complete", summary=summary)
        try:
            if task.resume:
                try:
                    result = resume(task.folder, progress=False, figures=task.figures)
                except (NotResumableError, RunFolderError) as exc:
                    note = f"run again: {exc}"[:300]
                    result = _fresh(task)  # no usable checkpoint: run it again
            else:
                result = _fresh(task)
        except KeyboardInterrupt:
            return _outcome("interrupted")
        except Exception as exc:
            with contextlib.suppress(OSError):
                Path(task.folder).rmdir()  # a run that failed before its first stage
            return _outcome("failed", f"{type(exc).__name__}: {exc}")
    status = "interrupted" if result.interrupted else "complete"
    return _outcome(status, summary=result.summary, note=note)


def import_ray():
    """The ``ray`` module.

    Raises
    ------
    BackendUnavailableError
        Ray is not installed (the message gives the pip command).
    """
    try:
        import ray
    except ImportError:
        raise BackendUnavailableError(
            "the 'ray' executor needs Ray: pip install 'swarmgames[ray]'"
        ) from None
    return ray


def run_tasks(
    tasks: Sequence[RunTask],
    on_done: OnDone,
    *,
    jobs: int,
    executor: str = "local",
    address: str | None = None,
) -> bool:
    """Execute ``tasks``, calling ``on_done(index, outcome)`` as each ends (module notes).

    Parameters
    ----------
    tasks : sequence of RunTask
    on_done : callable
    jobs : int
        Runs at once (``local``: processes, 1 = this process; ``ray``: the CPUs of a local
        Ray).
    executor : {"local", "ray"}
    address : str, optional
        Address of the Ray cluster to connect to (``ray`` only).

    Returns
    -------
    bool
        Whether the sweep was interrupted; the tasks not reported then did not run.
    """
    if not tasks:
        return False
    if executor == "ray":
        return _on_ray(tasks, on_done, jobs, address)
    if jobs == 1:
        return _in_process(tasks, on_done)
    return _in_processes(tasks, on_done, jobs)


def _in_process(tasks: Sequence[RunTask], on_done: OnDone) -> bool:
    try:
        with signals_interrupt():
            for i, task in enumerate(tasks):
                outcome = execute(task)
                on_done(i, outcome)
                if outcome["status"] == "interrupted":
                    return True
    except KeyboardInterrupt:
        return True
    return False


def _init_worker(stop, pids, started, parent: int) -> None:
    """Start a pool worker: it stops only when the sweep tells it (SIGTERM while it runs a
    task, the stop event before it starts one), not on the terminal's Ctrl-C; it ends with
    the sweep's process (``parent``); and it keeps freed memory for reuse, as the
    ``swarmgames`` command does."""
    global _STOP, _STARTED
    _STOP, _STARTED = stop, started
    end_with(parent)
    atexit.register(_exit_now)  # first registered: runs after every other exit handler
    reuse_freed_memory()
    for sig in (signal.SIGINT, *INTERRUPT_SIGNALS):
        signal.signal(sig, signal.SIG_IGN)
    pids.put(os.getpid())


def _exit_now() -> None:
    """End a pool worker at the start of its interpreter's teardown: its tasks are done and
    their results sent (synchronous queues), and the teardown of Numba's and LLVM's state
    (0.2-0.4 s a worker) is nothing the sweep needs, which waits for its workers to end."""
    with contextlib.suppress(Exception):
        sys.stdout.flush()
        sys.stderr.flush()
    os._exit(0)


def _run_in_worker(index: int, task: RunTask) -> dict[str, Any]:
    """:func:`execute` in a pool worker, telling the sweep which worker starts it and when it
    ends (a worker that dies never says so)."""
    _STARTED.put((index, os.getpid(), False))
    try:
        return execute(task)
    finally:
        _STARTED.put((index, os.getpid(), True))


def _future_outcome(future) -> dict[str, Any]:
    try:
        return future.result()
    except KeyboardInterrupt:  # the stop signal came just outside the run
        return _outcome("interrupted")
    except Exception as exc:
        return _outcome("failed", f"{type(exc).__name__}: {exc}")


def _in_processes(tasks: Sequence[RunTask], on_done: OnDone, jobs: int) -> bool:
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    ctx = multiprocessing.get_context("spawn")
    stop = ctx.Event()
    share = max(1, default_jobs() // jobs)
    todo = {i: replace(t, threads=share) for i, t in enumerate(tasks)}
    while todo:
        pids, started = ctx.SimpleQueue(), ctx.SimpleQueue()
        pool = ProcessPoolExecutor(
            max_workers=min(jobs, len(todo)),
            mp_context=ctx,
            initializer=_init_worker,
            initargs=(stop, pids, started, os.getpid()),
        )
        index = {pool.submit(_run_in_worker, i, t): i for i, t in todo.items()}
        pending = set(index)
        broken = False
        try:
            with signals_interrupt():
                while pending and not broken:
                    done, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for future in done:
                        if isinstance(future.exception(), BrokenProcessPool):
                            broken = True
                            continue
                        outcome = _future_outcome(future)
                        on_done(index[future], outcome)
                        del todo[index[future]]
                        if outcome["status"] == "interrupted":
                            raise KeyboardInterrupt
        except KeyboardInterrupt:
            stop.set()  # before the signals: a task that starts now sees it
            for future in pending:
                future.cancel()
            while not pids.empty():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pids.get(), signal.SIGTERM)
            for future in pending:
                if not future.cancelled():
                    on_done(index[future], _future_outcome(future))
            return True
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        if broken:
            _after_broken_pool(todo, index, started, on_done)
    return False


def _after_broken_pool(todo: dict[int, RunTask], index: dict, started, on_done: OnDone) -> None:
    """A worker died and took the pool down: report what finished, fail the run whose worker
    died (it started and never ended), and leave the others in ``todo`` to continue (from
    their checkpoints; the broken pool stopped them with SIGTERM) in a new pool."""
    workers, ended = {}, set()
    while not started.empty():
        i, pid, end = started.get()
        workers[i] = pid
        if end:
            ended.add(i)
    if not workers:  # the workers die before they run anything: no pool will do better
        for i in list(todo):
            on_done(i, _outcome("failed", "WorkerDied: the sweep's worker processes end at start"))
            del todo[i]
        return
    for future, i in index.items():
        if i not in todo:
            continue
        if future.done() and not future.cancelled() and future.exception() is None:
            on_done(i, future.result())
            del todo[i]
        elif i in workers and i not in ended:
            on_done(
                i,
                _outcome(
                    "failed",
                    f"WorkerDied: the worker process running it (pid {workers[i]}) ended "
                    "abruptly (killed, out of memory, or a crash); its completed stages are "
                    "kept",
                ),
            )
            del todo[i]
        elif i in workers:
            todo[i] = replace(todo[i], resume=True)


def _on_ray(tasks: Sequence[RunTask], on_done: OnDone, jobs: int, address: str | None) -> bool:
    ray = import_ray()
    started = not ray.is_initialized()
    if started:
        try:
            if address is None:
                ray.init(num_cpus=jobs, include_dashboard=False, log_to_driver=False)
            else:
                ray.init(address=address, log_to_driver=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            where = f"the Ray cluster at {address}" if address else "a local Ray"
            raise BackendUnavailableError(f"cannot start {where}: {exc}") from None
    remote = ray.remote(num_cpus=1)(execute)
    # A task holds one of Ray's CPUs: one thread.
    index = {remote.remote(replace(t, threads=1)): i for i, t in enumerate(tasks)}
    pending = list(index)
    try:
        with signals_interrupt():
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                outcome = _ray_outcome(ray, done[0])
                on_done(index[done[0]], outcome)
                if outcome["status"] == "interrupted":
                    raise KeyboardInterrupt
    except KeyboardInterrupt:
        for ref in pending:
            ray.cancel(ref)  # a running task gets KeyboardInterrupt: it stops cleanly
        for ref in pending:
            on_done(index[ref], _ray_outcome(ray, ref))
        return True
    finally:
        if started:
            ray.shutdown()
    return False


def _ray_outcome(ray, ref) -> dict[str, Any]:
    try:
        return ray.get(ref)
    except ray.exceptions.TaskCancelledError:
        return _outcome("interrupted")
    except ray.exceptions.RayError as exc:  # the worker died: the run failed
        return _outcome("failed", f"{type(exc).__name__}: {exc}")
