"""Inside a worker process (:mod:`vpid_bench.workers` is the supervisor's side): one task
at a time from the supervisor's pipe, answered on it.

A task is ``("runs", job, (indices, lockstep, threads))``, each run's outcome sent as it
ends, or ``("call", job, (fn, args))``: ``fn(job, problem, *args)`` with the job's problem
(built once per worker and kept). Either ends with ``("end", error, value, strays)``,
``strays`` counting the processes the task left running (the supervisor then ends this
worker with them). On the way: ``("phase", name)`` (the supervisor's clock restarts),
``("outcome", RunOutcome)``, and a plugin's log records and lines for the terminal.

A forked child's copy of the pipe is closed at the fork; a plugin that closes the pipe ends
the worker at once with :data:`LOST_PIPE_EXIT` (docs/sweeps.md, crash isolation).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

from . import interrupts
from .build import ProblemCache, run_rng
from .errors import VpidBenchError
from .job_runs import run_outcomes, warm_up
from .machine import one_blas_thread
from .process_tree import detach, drop_tracker, redirect, strays
from .runner import RunTimeoutError, keep_cwd, time_limit
from .spec import Job

#: A worker's exit code when it can no longer write to its pipe (a plugin closed it).
LOST_PIPE_EXIT = 86


class RemoteError(Exception):
    """An exception raised in a worker, carried as its type name, message and traceback (the
    original may not pickle, or not unpickle in this process)."""

    def __init__(self, type_name: str, message: str, traceback_text: str,
                 plain: bool = False) -> None:
        super().__init__(message)
        self.remote_type, self.remote_traceback = type_name, traceback_text
        #: Our own errors and ``ValueError``s are shown without their type (as in-process).
        self.plain = plain

    def __reduce__(self) -> tuple[Any, ...]:
        return (RemoteError, (self.remote_type, str(self), self.remote_traceback, self.plain))


def portable(exc: BaseException) -> RemoteError:
    """``exc`` as a :class:`RemoteError` (what a record needs of it, always picklable)."""
    if isinstance(exc, RemoteError):
        return exc
    return RemoteError(type(exc).__name__, str(exc), "".join(traceback.format_exception(exc)),
                       isinstance(exc, (VpidBenchError, ValueError)))


class _PipeLog(logging.Handler):
    """Sends the worker's log records to the supervisor, which logs them (job log included)."""

    def __init__(self, send: Callable[[Any], None]) -> None:
        super().__init__(logging.INFO)
        self._send = send

    def emit(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(Exception):
            self._send(("log", record.levelno, record.name, record.getMessage()))


def _sender(conn: Connection) -> Callable[[Any], None]:
    """``send(message)`` to the supervisor, from any thread of this worker only (not from a
    process forked from it); with the pipe gone (closed, or its descriptor reused) the worker
    ends with :data:`LOST_PIPE_EXIT`."""
    me = os.getpid()
    lock = threading.Lock()
    fd = conn.fileno()
    identity = _identity(fd)

    def send(msg: Any) -> None:
        if os.getpid() != me:
            return
        with lock:  # a plugin's thread may log while the main thread sends an outcome
            try:
                if _identity(fd) != identity:
                    raise OSError("the pipe's descriptor was closed or reused")
                conn.send(msg)
            except (OSError, ValueError):  # closed under us: nobody to tell; end quietly
                os._exit(LOST_PIPE_EXIT)

    def close_in_child() -> None:
        with contextlib.suppress(Exception):
            conn.close()

    os.register_at_fork(after_in_child=close_in_child)
    return send


def _identity(fd: int) -> tuple[int, int] | None:
    """Which file descriptor ``fd`` names (device, inode), ``None`` when it is closed."""
    try:
        st = os.fstat(fd)
    except OSError:
        return None
    return st.st_dev, st.st_ino


def serve(conn: Connection, out: Connection, err: Connection) -> None:
    """The worker's loop (the target of its process): one task at a time until told to stop
    or the pipe closes. ``out`` and ``err`` become its standard output and error."""
    detach()
    drop_tracker()
    redirect(out, err)
    interrupts.plugin_only()  # the user's Ctrl-C is the supervisor's to handle
    if hasattr(signal, "pthread_sigmask"):  # held by the supervisor while it started us
        signal.pthread_sigmask(signal.SIG_UNBLOCK, set(interrupts.SIGNALS))
    send = _sender(conn)
    root = logging.getLogger()
    root.handlers[:] = [_PipeLog(send)]
    root.setLevel(logging.INFO)
    threading.excepthook = _say(send, interrupts.thread_exception_line)
    sys.unraisablehook = _say(send, lambda a: (  # a destructor, an at-fork hook a limit cut
        f"warning: an exception was ignored in {a.object!r}: {a.exc_type.__name__}: "
        f"{a.exc_value}"))
    state = {"problems": ProblemCache(size=4), "warm": set()}
    me = os.getpid()
    while os.getpid() == me:  # a forked copy that got back here ends below
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            break
        if msg is None:
            break
        kind, job, payload = msg
        value, error = None, None
        try:
            if kind == "call":
                fn, args = payload
                with keep_cwd():
                    problem = state["problems"].get(job)
                    send(("phase", "built"))  # the call's own limit starts now
                    value = fn(job, problem, *args)
            else:
                _run_task(job, payload, state, send)
        except BaseException as exc:  # noqa: BLE001 - the supervisor records it; keep serving
            error = portable(exc)
        left = len(strays(os.getpid()))  # the task's last message: what it left running
        try:
            send(("end", error, value, left))
        except Exception as exc:  # noqa: BLE001 - a value that does not pickle
            send(("end", portable(exc), None, left))
    os._exit(0)  # a plugin's non-daemon thread must not keep the worker alive


def _say(send: Callable[[Any], None], line: Callable[[Any], str]) -> Any:
    """A hook (``threading.excepthook``, ``sys.unraisablehook``) that says ``line(args)`` on
    the command's stderr, one line, no traceback."""
    def hook(args: Any) -> None:
        with contextlib.suppress(Exception):
            send(("say", line(args)))
    return hook


def _run_task(job: Job, payload: tuple[list[int], bool, int], state: dict[str, Any],
              send: Callable[[Any], None]) -> None:
    indices, lockstep, threads = payload
    with keep_cwd():
        problem = state["problems"].get(job)
        problem.set_threads(threads)
    send(("phase", "built"))  # from here on plugin code runs: the runs' limits apply
    warm_key = (id(problem), job.optimizer_cls, job.optimizer_name, lockstep)
    with one_blas_thread():
        if warm_key not in state["warm"]:
            warm_up(job, problem, lockstep)
            state["warm"].add(warm_key)
            send(("phase", "warmed"))
        for outcome in run_outcomes(job, problem, indices, lockstep,
                                    announce=lambda phase: send(("phase", phase))):
            if outcome.error is not None:  # as a RemoteError: always picklable
                outcome = dataclasses.replace(outcome, outcome=portable(outcome.error))
            send(("outcome", outcome))


def probe(job: Job, problem: Any) -> None:
    """Build run 0's optimizer of ``job`` under the run's time limit; raise what its
    constructor raised (a fault there stops the job before any run)."""
    limit = job.spec.run_timeout_s
    try:
        with time_limit(limit), keep_cwd():
            job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, 0))
    except KeyboardInterrupt:
        if interrupts.from_user():
            raise
        raise interrupts.PluginInterruptError("its constructor") from None
    except RunTimeoutError as exc:
        raise RunTimeoutError(f"the optimizer's constructor took longer than "
                              f"run_timeout_s={limit:g} s") from exc
