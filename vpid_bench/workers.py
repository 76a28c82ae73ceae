"""Supervised worker processes: a plugin's fault costs its run, never the sweep.

With ``isolation=process`` (the command's default) the optimizer's code of every run (its
constructor, ``ask``, ``tell``, ``close``) and the problem's evaluations run in long-lived
worker processes; the sweep's own process only hands out runs, receives each run's outcome and
writes every record, job status and report. A worker is started once and reused by every job
of the sweep (imports and compiled kernels are paid once per worker), and runs of one job go
to several workers at once (``workers``, default every core), so one machine's cores work on a
study.

What a worker can no longer take down:

* a run that ends its process (``os._exit``, ``os.abort``, a segfault in a C extension): the
  run is recorded as failed with how the process ended; a fresh worker takes the next run;
* a run blocked in C code or ignoring SIGALRM past ``run_timeout_s``: the in-process limit
  (SIGALRM, Python code only) cannot stop it, so the supervisor kills its worker
  :data:`GRACE_S` seconds after the limit and records the run as timed out;
* a plugin's ``os.chdir``, lingering threads, signal handlers and ``KeyboardInterrupt``: they
  live and die with the worker.

Runs that went together (a lockstep group) and lost their worker are run again one by one, so
only the run that caused the fault is charged. Records are bit-identical to ``isolation=none``
(tested): every run draws from its own generator and evaluations do not depend on the batch.

Why :mod:`multiprocessing` and not an executor: on Python 3.11, :mod:`concurrent.futures`
cannot kill one hung worker (only break the whole pool), and loky's reusable executor is
available here only as a copy vendored inside joblib, not as a public package. A worker is a
``spawn``-ed :class:`multiprocessing.Process` with one :func:`multiprocessing.Pipe`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import pickle
import signal
import sys
import threading
import time
import traceback
import weakref
from collections import deque
from collections.abc import Iterator, Sequence
from multiprocessing import get_context
from multiprocessing.connection import Connection, wait
from typing import Any

from . import interrupts
from .errors import PluginError, VpidBenchError
from .job_runs import RunOutcome, now_utc, run_outcomes, warm_up
from .machine import one_blas_thread
from .runner import RunTimeoutError, keep_cwd, time_limit
from .spec import Job

log = logging.getLogger(__name__)

#: Seconds allowed to a worker new to a job for what comes before any optimizer code: its
#: start-up, imports and building the problem (then the runs' own limits apply).
START_S = 120.0
#: Seconds past ``run_timeout_s`` before the supervisor kills a worker that has not answered.
GRACE_S = 10.0
#: Runs per task of a lockstep job, at most (a lost task costs at most this many re-runs).
LOCKSTEP_CHUNK = 10


class WorkerDiedError(RuntimeError):
    """The worker process running the run ended (``os._exit``, ``abort``, a signal)."""


class WorkerKilledError(RunTimeoutError):
    """The run passed ``run_timeout_s`` without returning (blocked in C or ignoring SIGALRM);
    the supervisor killed its worker process."""


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


def describe_exit(code: int | None) -> str:
    """How a process ended, for a record: ``exit code 3`` or ``signal SIGSEGV``."""
    if code is None:
        return "no exit code"
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"signal {signal.Signals(-code).name}"
        return f"signal {-code}"
    return f"exit code {code}"


def can_send(job: Job) -> str | None:
    """Why ``job`` cannot be sent to a worker (its classes or settings do not pickle, e.g. a
    class defined inside a function), or ``None`` when it can."""
    try:
        pickle.dumps(job)
    except Exception as exc:  # noqa: BLE001 - any pickling failure means "cannot"
        return f"{type(exc).__name__}: {exc}"
    return None


# --------------------------------------------------------------------- the worker's side


class _PipeLog(logging.Handler):
    """Sends the worker's log records to the supervisor, which logs them (job log included)."""

    def __init__(self, send: Any) -> None:
        super().__init__(logging.INFO)
        self._send = send

    def emit(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(Exception):
            self._send(("log", record.levelno, record.name, record.getMessage()))


@contextlib.contextmanager
def _sigint_held() -> Iterator[None]:
    """A Ctrl-C inside the block is noted and delivered (to the handler in place before) when
    the block ends. SIGINT is also blocked for this thread, so a process started inside
    inherits it blocked (released by :func:`_serve`). Main thread only (elsewhere a no-op:
    Python runs signal handlers on the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    before = signal.signal(signal.SIGINT, lambda signum, frame: noted.append(signum))
    mask = (signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
            if hasattr(signal, "pthread_sigmask") else None)
    try:
        yield
    finally:
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        signal.signal(signal.SIGINT, before)
        if noted:
            signal.raise_signal(signal.SIGINT)


def _serve(conn: Connection) -> None:
    """The worker's loop: one task at a time until told to stop or the pipe closes."""
    from .build import ProblemCache

    interrupts.plugin_only()  # the user's Ctrl-C is the supervisor's to handle
    if hasattr(signal, "pthread_sigmask"):  # held by the supervisor while it started us
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    lock = threading.Lock()

    def send(msg: Any) -> None:
        with lock:  # a plugin's thread may log while the main thread sends an outcome
            conn.send(msg)

    root = logging.getLogger()
    root.handlers[:] = [_PipeLog(send)]
    root.setLevel(logging.INFO)
    threading.excepthook = _thread_exception(send)
    state = {"problems": ProblemCache(size=4), "warm": set()}
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            break
        if msg is None:
            break
        kind, job, payload = msg
        try:
            if kind == "probe":
                problem = state["problems"].get(job)
                send(("phase", "built"))  # the constructor's own limit starts now
                send(("probed", _probe(job, problem)))
            else:
                _run_task(job, payload, state, send)
        except BaseException as exc:  # noqa: BLE001 - the supervisor records it; keep serving
            send(("task_failed", portable(exc)))
    os._exit(0)  # a plugin's non-daemon thread must not keep the worker alive


def _thread_exception(send: Any) -> Any:
    """The worker's ``threading.excepthook``: one line on the command's stderr for an
    exception in a plugin's own thread (as in the command's own process), no traceback."""
    def hook(args: Any) -> None:
        with contextlib.suppress(Exception):
            send(("say", interrupts.thread_exception_line(args)))
    return hook


def _probe(job: Job, problem: Any) -> RemoteError | None:
    """Build one optimizer (a fault in its constructor stops the job before any run)."""
    from .build import run_rng

    try:
        with time_limit(job.spec.run_timeout_s), keep_cwd():
            job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, 0))
    except KeyboardInterrupt:
        return portable(interrupts.PluginInterruptError("its constructor"))
    except BaseException as exc:  # noqa: BLE001 - carried to the supervisor
        return portable(exc)
    return None


def _run_task(job: Job, payload: tuple[list[int], bool, int], state: dict[str, Any],
              send: Any) -> None:
    indices, lockstep, threads = payload
    problem = state["problems"].get(job)
    problem.set_threads(threads)
    send(("phase", "built"))  # from here on plugin code runs: the runs' limits apply
    warm_key = (id(problem), job.optimizer_cls, job.optimizer_name, lockstep)
    with one_blas_thread():
        if warm_key not in state["warm"]:
            warm_up(job, problem, lockstep)
            state["warm"].add(warm_key)
            send(("phase", "warmed"))
        for outcome in run_outcomes(job, problem, indices, lockstep):
            if outcome.error is not None:
                outcome = dataclasses.replace(outcome, outcome=portable(outcome.error))
            send(("outcome", outcome))
    send(("done", None))


# ----------------------------------------------------------------- the supervisor's side


@dataclasses.dataclass
class _Worker:
    process: Any
    conn: Connection
    jobs: set[str] = dataclasses.field(default_factory=set)


@dataclasses.dataclass
class _Busy:
    worker: _Worker
    remaining: list[int]
    deadline: float | None
    started: str


class Workers:
    """A supervised set of worker processes, reused by every job given to it (see module).
    ``size``: how many run a job's runs at once unless the job's ``workers`` key says."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError("a worker set needs at least one worker")
        self.size = size
        self._ctx = get_context("spawn")
        self._idle: list[_Worker] = []
        self._all: list[_Worker] = []
        self._finalizer = weakref.finalize(self, _kill_all, self._all)

    # --- workers

    def _start(self) -> _Worker:
        """A new worker, started with SIGINT held back: a Ctrl-C in the middle of
        ``start()`` once cut the start-up data the child reads from its pipe, and the child
        printed Python's traceback of the truncated pickle (the Ctrl-C, still pending, is
        raised as soon as the worker is started and tracked). The child inherits the held
        SIGINT and releases it once it ignores SIGINT (:func:`_serve`)."""
        with _sigint_held():
            ours, theirs = self._ctx.Pipe(duplex=True)
            process = self._ctx.Process(target=_serve, args=(theirs,),
                                        name="vpid-bench-worker")
            process.start()
            theirs.close()
            worker = _Worker(process, ours)
            self._all.append(worker)
        return worker

    def prestart(self) -> None:
        """Start every worker now, so their start-up (imports) overlaps the sweep's own set-up
        instead of delaying the first runs."""
        while len(self._all) < self.size:
            self._idle.append(self._start())

    def _take(self) -> _Worker:
        while self._idle:
            worker = self._idle.pop()
            if worker.process.is_alive():
                return worker
            self._discard(worker)
        return self._start()

    def _discard(self, worker: _Worker) -> None:
        with contextlib.suppress(Exception):
            worker.process.kill()
        worker.process.join(timeout=5)
        with contextlib.suppress(Exception):
            worker.conn.close()
        if worker in self._all:
            self._all.remove(worker)

    def close(self) -> None:
        """Stop every worker (politely, then by force)."""
        for worker in list(self._all):
            with contextlib.suppress(Exception):
                worker.conn.send(None)
        for worker in list(self._all):
            worker.process.join(timeout=2)
            self._discard(worker)
        self._idle.clear()

    # --- tasks

    def probe(self, job: Job) -> None:
        """Build one optimizer of ``job`` in a worker; raise what its constructor raised."""
        worker = self._take()
        reply = self._ask(worker, ("probe", job, None), _allowance(job, 1))
        if isinstance(reply, BaseException):
            raise reply
        kind, value = reply
        if kind == "task_failed" or value is not None:
            raise value
        self._idle.append(worker)

    def _ask(self, worker: _Worker, msg: Any, limit: float | None) -> Any:
        """Send one message and wait for the worker's answer: :data:`START_S` to build the
        problem, then ``limit`` seconds (``None``: no limit)."""
        worker.conn.send(msg)
        deadline = None if limit is None else time.monotonic() + START_S
        while True:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not wait([worker.conn], timeout=left):
                self._discard(worker)
                return PluginError(f"the optimizer's constructor did not return within "
                                   f"{limit:.0f} s (run_timeout_s + {GRACE_S:.0f} s; blocked "
                                   "in C or ignoring SIGALRM): its worker process was killed")
            reply, ended = self._receive(worker)
            if ended is not None:
                return PluginError(f"the optimizer's constructor ended its worker process "
                                   f"({ended})")
            if reply[0] == "phase":
                deadline = None if limit is None else time.monotonic() + limit
            elif not _aside(reply):
                return reply

    def outcomes(self, job: Job, indices: Sequence[int], lockstep: bool, workers: int,
                 threads: int) -> Iterator[RunOutcome]:
        """The outcome of each run in ``indices``, in the order they end, from up to
        ``workers`` processes at once."""
        size = max(1, workers)
        pending: deque[list[int]] = deque(_tasks(list(indices), size) if lockstep
                                          else [[i] for i in indices])
        busy: dict[Connection, _Busy] = {}
        try:
            while pending or busy:
                while pending and len(busy) < size:
                    self._hand_out(job, pending.popleft(), threads, busy)
                yield from self._collect(job, busy, pending)
        finally:
            for b in busy.values():  # interrupted: their state is unknown
                self._discard(b.worker)

    def _hand_out(self, job: Job, runs: list[int], threads: int,
                  busy: dict[Connection, _Busy]) -> None:
        worker = self._take()
        key = _job_key(job)
        fresh = key not in worker.jobs
        worker.jobs.add(key)
        worker.conn.send(("runs", job, (runs, len(runs) > 1, threads)))
        # a worker new to the job first builds its problem (no plugin optimizer code yet)
        limit = _allowance(job, len(runs))
        limit = START_S if fresh and limit is not None else limit
        deadline = None if limit is None else time.monotonic() + limit
        busy[worker.conn] = _Busy(worker, list(runs), deadline, now_utc())

    def _receive(self, worker: _Worker) -> tuple[Any, str | None]:
        """The worker's next message, or ``(None, how it ended)`` when its process is gone
        (it is then discarded): the one place both the constructor probe and the runs learn
        that a worker died."""
        try:
            return worker.conn.recv(), None
        except (EOFError, OSError):
            ended = describe_exit(_exit_code(worker))
            self._discard(worker)
            return None, ended

    def _collect(self, job: Job, busy: dict[Connection, _Busy],
                 pending: deque[list[int]]) -> Iterator[RunOutcome]:
        deadlines = [b.deadline for b in busy.values() if b.deadline is not None]
        left = max(0.0, min(deadlines) - time.monotonic()) if deadlines else None
        for conn in wait(list(busy), timeout=left):
            b = busy[conn]
            msg, ended = self._receive(b.worker)
            if ended is not None:
                del busy[conn]
                yield from _lost(job, b, WorkerDiedError(f"its worker process ended ({ended})"),
                                 pending)
                continue
            yield from self._handle(job, conn, msg, busy)
        now = time.monotonic()
        for conn, b in list(busy.items()):
            if b.deadline is not None and now > b.deadline:
                del busy[conn]
                self._discard(b.worker)
                cause = WorkerKilledError(
                    f"the run passed run_timeout_s={job.spec.run_timeout_s} s and did not return "
                    f"within {GRACE_S:.0f} s more (blocked in C code or ignoring SIGALRM): its "
                    "worker process was killed")
                yield from _lost(job, b, cause, pending)

    def _handle(self, job: Job, conn: Connection, msg: Any, busy: dict[Connection, _Busy]
                ) -> Iterator[RunOutcome]:
        b = busy[conn]
        kind, value = msg[0], msg[1]
        if _aside(msg):
            pass
        elif kind in ("phase", "outcome"):  # progress: the clock restarts for what is left
            if kind == "outcome":
                b.remaining.remove(value.index)
                yield value
            limit = _allowance(job, len(b.remaining))
            b.deadline = None if limit is None else time.monotonic() + limit
        elif kind == "task_failed":  # building the problem failed: every run of the task
            del busy[conn]
            self._idle.append(b.worker)
            for i in b.remaining:
                yield RunOutcome(i, value, b.started, 0.0)
        else:  # "done"
            del busy[conn]
            self._idle.append(b.worker)


def _lost(job: Job, b: _Busy, cause: BaseException, pending: deque[list[int]]
          ) -> Iterator[RunOutcome]:
    """A task lost its worker: a single run is charged; a group goes again one by one."""
    if len(b.remaining) > 1:
        log.warning("a worker running runs %s of %s on %s was lost (%s); running them again "
                    "one by one", b.remaining, job.optimizer_name, job.problem_name, cause)
        pending.extendleft([i] for i in reversed(b.remaining))
        return
    for i in b.remaining:
        log.error("run %d of %s on %s failed: %s: %s", i, job.optimizer_name, job.problem_name,
                  type(cause).__name__, cause)
        yield RunOutcome(i, cause, b.started, 0.0)


def _tasks(indices: list[int], workers: int) -> list[list[int]]:
    """A lockstep job's runs cut into tasks of at most :data:`LOCKSTEP_CHUNK` runs, as many
    tasks as a multiple of ``workers`` (so the workers finish together: 30 runs on 2 workers go
    as 8, 7, 7, 8 rather than 10, 10, 10), sizes differing by one at most."""
    n = len(indices)
    tasks = min(n, workers * -(-n // (workers * LOCKSTEP_CHUNK)))
    bounds = [round(k * n / tasks) for k in range(tasks + 1)] if tasks else [0]
    return [indices[a:b] for a, b in zip(bounds, bounds[1:]) if b > a]


def _allowance(job: Job, runs: int) -> float | None:
    """Seconds a worker may take for ``runs`` runs (a warm-up counts as one) before it is
    killed (``None``: no limit)."""
    limit = job.spec.run_timeout_s
    return None if limit is None else limit * max(runs, 1) + GRACE_S


def _job_key(job: Job) -> str:
    """What tells a worker's first task of a job from the next (its problem and optimizer)."""
    return repr((job.problem_name, job.problem_settings(), job.optimizer_name,
                 job.optimizer_settings()))


def _exit_code(worker: _Worker) -> int | None:
    worker.process.join(timeout=5)
    return worker.process.exitcode


def _aside(msg: Any) -> bool:
    """Handle a worker's log record or line for stderr; ``False`` for any other message."""
    if msg[0] == "log":
        _, level, name, text = msg
        logging.getLogger(name).log(level, "%s", text)
    elif msg[0] == "say":
        print(msg[1], file=sys.stderr, flush=True)
    else:
        return False
    return True


def _kill_all(workers: list[_Worker]) -> None:
    for worker in list(workers):
        with contextlib.suppress(Exception):
            worker.process.kill()
            worker.process.join(timeout=2)


def outcomes_isolated(pool: Workers, job: Job, indices: Sequence[int], lockstep: bool
                      ) -> Iterator[RunOutcome]:
    """:meth:`Workers.outcomes` with the job's ``workers`` and ``threads`` keys applied: each
    worker's problem gets an equal share of the cores unless ``threads`` is set."""
    from .machine import available_cores

    workers = job.spec.workers or pool.size
    threads = job.spec.threads or max(1, available_cores() // workers)
    return pool.outcomes(job, indices, lockstep, workers, threads)


__all__ = ["GRACE_S", "RemoteError", "WorkerDiedError", "WorkerKilledError",
           "Workers", "can_send", "describe_exit", "outcomes_isolated", "portable"]
