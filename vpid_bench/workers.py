"""Supervised worker processes: a plugin's fault costs its run, never the sweep.

With ``isolation=process`` (the command's default) every call into plugin code runs in
long-lived worker processes, reused by every job of the sweep, several at once
(:meth:`Workers.outcomes` for runs, :meth:`Workers.call` and :meth:`Workers.calls` for the
rest); the sweep's own process never builds a problem, it hands out tasks and writes every
file. A run that ends or blocks its worker fails alone, a lockstep group that lost its
worker runs again one by one (what each fault costs: docs/sweeps.md, crash isolation).
Records are bit-identical to ``isolation=none`` (tested).

Why :mod:`multiprocessing` and not an executor: on Python 3.11 :mod:`concurrent.futures`
cannot kill one hung worker, loky is only vendored inside joblib, and neither ends the
processes a task leaves behind.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import pickle
import resource
import signal
import sys
import time
import weakref
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from multiprocessing import get_context
from multiprocessing.connection import Connection, wait
from typing import Any

import psutil

from . import interrupts
from .cgroups import Cgroup
from .interrupts import held as _sigint_held  # (tests use the name)
from .job_runs import RunOutcome, now_utc
from .machine import available_cores
from .process_tree import Output
from .runner import RunTimeoutError
from .spec import Job
from .worker_loop import LOST_PIPE_EXIT, RemoteError, portable, serve
from .worker_tree import Tree, marked, new_token, start_tracker

log = logging.getLogger(__name__)

#: Seconds for a worker new to a job to start, import and build the problem.
START_S = 120.0
#: Runs per task of a lockstep job, at most (a lost task costs at most this many re-runs).
LOCKSTEP_CHUNK = 10
#: Memory one worker takes (MB, resident): 227 MB measured after a job of the default
#: problem (docs/sweeps.md), rounded up.
WORKER_MB = 250
#: File descriptors the supervisor holds per worker (its pipe, its multiprocessing sentinel,
#: its pidfd, two output pipes), and how many it keeps free for everything else.
FDS_PER_WORKER, FDS_SPARE = 5, 128
#: Seconds between checks that a worker still runs where no descriptor tells (no pidfd).
POLL_S = 0.5
#: Where a run's worker was, by the last phase it announced, when it ended: said in the record.
_DURING = {None: " while it built the problem",
           "metrics": " in the problem's metrics() (or the residuals of its intervals)"}


class WorkerDiedError(RuntimeError):
    """The worker process running the run ended (``os._exit``, ``abort``, a signal)."""


class WorkerKilledError(RunTimeoutError):
    """The run passed ``run_timeout_s`` without returning (blocked in C or ignoring SIGALRM);
    the supervisor killed its worker process."""


def describe_exit(code: int | None) -> str:
    """How a process ended, for a record: ``exit code 3`` or ``signal SIGSEGV``."""
    if code is None:
        return "no exit code"
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"signal {signal.Signals(-code).name}"
        return f"signal {-code}"
    if code == LOST_PIPE_EXIT:
        return (f"exit code {code}: its pipe to the sweep was closed under it, as by a "
                "plugin that closes file descriptors")
    return f"exit code {code}"


def is_timeout(exc: BaseException) -> bool:
    """Whether ``exc`` (raised here or carried from a worker) says a time limit passed."""
    return isinstance(exc, RunTimeoutError) or getattr(exc, "remote_type", "") in (
        "RunTimeoutError", "WorkerKilledError")


def worker_cap() -> tuple[int, str]:
    """The most workers this machine holds at once, and why: one per :data:`WORKER_MB` of
    the memory available, no more than the open-file limit allows; at least one."""
    available = psutil.virtual_memory().available
    by_memory = max(1, int(available // (WORKER_MB * 2**20)))
    soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    by_files = (max(1, (soft - FDS_SPARE) // FDS_PER_WORKER)
                if soft != resource.RLIM_INFINITY else by_memory)
    if by_files < by_memory:
        return by_files, f"the open-file limit, {soft}, allows {by_files}"
    return by_memory, (f"{available / 2**30:.1f} GB of memory available, about {WORKER_MB} MB "
                       f"per worker, allow {by_memory}")


def can_send(job: Job) -> str | None:
    """Why ``job`` cannot be sent to a worker (it does not pickle: a class made in a function)."""
    try:
        pickle.dumps(job)
    except Exception as exc:  # noqa: BLE001 - any pickling failure means "cannot"
        return f"{type(exc).__name__}: {exc}"
    return None


@dataclasses.dataclass(eq=False)
class _Worker:
    process: Any
    conn: Connection
    output: Output
    #: The process and everything it starts; its ``fd`` (pidfd) is readable once it ended.
    tree: Tree
    jobs: set[str] = dataclasses.field(default_factory=set)

    def ended(self) -> bool:
        """Whether the process has ended (without reaping it)."""
        return self.tree.ended()


@dataclasses.dataclass
class _Task:
    """A task a worker is busy with: when it is killed (``None``: never), its runs left and
    when they started (or a call's index), and the last phase the worker announced
    (``None``: still building the problem)."""
    worker: _Worker
    deadline: float | None
    remaining: list[int] = dataclasses.field(default_factory=list)
    started: str = ""
    phase: str | None = None
    index: int = 0


class Workers:
    """A supervised set of worker processes, reused by every job (see module). ``size``: how
    many run a job's runs at once unless its ``workers`` key says."""

    def __init__(self, size: int) -> None:
        if size < 1:
            raise ValueError("a worker set needs at least one worker")
        #: The most workers at once (:func:`worker_cap`) and why.
        self.cap, self._cap_why = worker_cap()
        self.size = min(size, self.cap)
        self._said: set[int] = set()
        self._ctx = get_context("spawn")
        self._idle: list[_Worker] = []
        self._all: list[_Worker] = []
        self._finalizer = weakref.finalize(self, _end_all, self._all)

    def _start(self) -> _Worker:
        """A new worker, started with the signals held back (a Ctrl-C inside ``start()`` once
        cut the child's start-up pickle: a traceback); the child releases them once it
        ignores SIGINT (:func:`~.worker_loop.serve`)."""
        token = new_token()
        cgroup = Cgroup.create(f"vpid-bench-{token}")  # None where none can be made
        start_tracker()  # not inside the block: it unblocks SIGINT and SIGTERM
        with _sigint_held():
            ours, theirs = self._ctx.Pipe(duplex=True)
            output = Output()
            process = self._ctx.Process(target=serve, args=(theirs, *output.child_ends()),
                                        name="vpid-bench-worker")
            with marked(token):
                process.start()
            theirs.close()
            output.started()
            worker = _Worker(process, ours, output, Tree(process, token, cgroup))
            self._all.append(worker)
        return worker

    def prestart(self, count: int | None = None) -> None:
        """Start ``count`` workers now (at most :attr:`size`): their imports overlap the set-up."""
        while len(self._all) < min(self.size, self.size if count is None else count):
            self._idle.append(self._start())

    def how_many(self, requested: int, tasks: int) -> int:
        """How many workers run a job's ``tasks`` at once when ``requested``: never more than
        its tasks nor :attr:`cap` (fewer by the cap: one line, once per requested value)."""
        count = max(1, min(requested, tasks, self.cap))
        if requested > self.cap and requested not in self._said:  # the job's runs, polishes
            self._said.add(requested)
            print(f"note: workers={requested}: at most {self.cap} worker processes on this "
                  f"machine ({self._cap_why}); a job also never starts more than it has "
                  f"runs to give them", file=sys.stderr, flush=True)
        return count

    def _take(self) -> _Worker:
        while self._idle:
            worker = self._idle.pop()
            if not worker.ended():
                return worker
            self._end(worker)
        return self._start()

    def _end(self, worker: _Worker) -> str:
        """End ``worker`` and its tree, copy what it printed, close its pipes and forget it;
        how it ended, for a record. What could not be ended: one ``warning:`` line."""
        left = worker.tree.end()  # before reaping it (join): see worker_tree
        end = time.monotonic() + 5.0
        while not worker.ended() and time.monotonic() < end:
            time.sleep(0.02)
        if worker.ended():  # reaped (its exit code read) only once it has ended
            worker.process.join()
        worker.tree.close()
        worker.output.close()
        with contextlib.suppress(Exception):
            worker.conn.close()
        if left:
            print(f"warning: {len(left)} process(es) started in worker process "
                  f"{worker.process.pid} could not be ended and are left running (they left "
                  f"its cgroup or session and cleared their environment): pid "
                  f"{', pid '.join(left)}", file=sys.stderr, flush=True)
        for group in (self._all, self._idle):
            if worker in group:
                group.remove(worker)
        return describe_exit(worker.process.exitcode)

    def _release(self, worker: _Worker, left: int, who: str) -> None:
        """Back to the idle workers, or ended with the processes its task left running."""
        if left:
            log.warning("%s left %d process(es) running after its task; ended with its worker "
                        "process", who, left)
            self._end(worker)
        else:
            self._idle.append(worker)

    def close(self) -> None:
        """End every worker and its tree; an interrupt meanwhile is delivered after (or only
        noted when the command is already ending from one)."""
        with _sigint_held(deliver=not interrupts.seen()):
            for worker in list(self._all):
                self._end(worker)
            self._idle.clear()

    def _events(self, busy: Sequence[_Task]) -> list[_Worker]:
        """The workers of the ``busy`` tasks with a message waiting or whose process ended,
        waiting until the first deadline at most (none: for ever), copying what they print."""
        deadlines = [b.deadline for b in busy if b.deadline is not None]
        end = min(deadlines) if deadlines else None
        workers = [b.worker for b in busy]
        unwatched = [w for w in workers if w.tree.fd is None]
        while True:
            handles: dict[Any, Any] = {}
            for w in workers:
                handles[w.conn] = w
                if w.tree.fd is not None:
                    handles[w.tree.fd] = w
                handles.update({fd: (w.output, fd) for fd in w.output.fds})
            left = None if end is None else max(0.0, end - time.monotonic())
            if unwatched:
                left = POLL_S if left is None else min(left, POLL_S)
            hits = [w for w in unwatched if w.ended()]
            for ready in wait(list(handles), timeout=0 if hits else left):
                target = handles[ready]
                if isinstance(target, tuple):
                    target[0].forward(target[1])
                elif target not in hits:
                    hits.append(target)
            if hits or (end is not None and time.monotonic() >= end):
                return hits

    def _receive(self, worker: _Worker) -> tuple[Any, str | None]:
        """The worker's next message, or ``(None, how it ended)`` when its process is gone or
        sent what cannot be read (it is then ended): the one place a worker's death is
        learnt. Its liveness, not its pipe, decides (a forked child may hold the pipe)."""
        try:
            if worker.conn.poll():
                msg = worker.conn.recv()
                if isinstance(msg, tuple) and msg:
                    return msg, None
                raise TypeError(f"a {type(msg).__name__}, not a message")
        except (EOFError, OSError):  # every copy of its end is closed
            # on its way out, or alive with its pipe closed under it: a second to end alone
            end = time.monotonic() + 1.0
            while not worker.ended() and time.monotonic() < end:
                time.sleep(0.02)
            if not worker.ended():
                self._end(worker)
                return None, ("its pipe to the sweep was closed under it, as by a plugin that "
                              "closes file descriptors; it was killed")
        except Exception as exc:  # noqa: BLE001 - a message that does not unpickle
            return None, (f"{self._end(worker)} after a message that could not be read "
                          f"({type(exc).__name__})")
        return None, self._end(worker)

    def call(self, job: Job, fn: Callable[..., Any], *args: Any, what: str,
             limit: float | None) -> Any:
        """``fn(job, problem, *args)`` in a worker (``fn`` module-level; the problem built
        there once and kept), and its value; raises what it raised, or
        :class:`WorkerDiedError` / :class:`WorkerKilledError` naming ``what``.
        :data:`START_S` to build the problem, then ``limit`` seconds (``None``: none)."""
        [(value, error)] = self.calls(job, [(fn, args)], what=what, limit=limit, workers=1)
        if error is not None:
            raise error
        return value

    def calls(self, job: Job, tasks: Sequence[tuple[Callable[..., Any], tuple[Any, ...]]],
              what: str, limit: float | None, workers: int) -> list[tuple[Any, Any]]:
        """Each ``(fn, args)`` of ``tasks`` as :meth:`call` runs it, on up to ``workers`` at
        once: ``(value, None)`` or ``(None, the exception)`` per task, in order. A task that
        ends or hangs its worker costs that task only."""
        results: list[tuple[Any, Any]] = [(None, None)] * len(tasks)
        pending = deque(range(len(tasks)))
        busy: dict[Connection, _Task] = {}
        try:
            while pending or busy:
                while pending and len(busy) < max(1, workers):
                    index = pending.popleft()
                    call = self._send_call(job, index, tasks[index], what, limit)
                    if isinstance(call, BaseException):
                        results[index] = (None, call)
                    else:
                        busy[call.worker.conn] = call
                for call, outcome in self._call_events(busy, what, limit, job.spec.grace_s):
                    del busy[call.worker.conn]
                    results[call.index] = outcome
        except BaseException:
            for call in busy.values():  # interrupted: their state is unknown
                self._end(call.worker)
            raise
        return results

    def _send_call(self, job: Job, index: int,
                   task: tuple[Callable[..., Any], tuple[Any, ...]], what: str,
                   limit: float | None) -> _Task | BaseException:
        worker = self._take()
        try:
            worker.conn.send(("call", job, task))
        except OSError:
            return WorkerDiedError(f"its worker process ended ({self._end(worker)}) before "
                                   f"{what}")
        return _Task(worker, None if limit is None else time.monotonic() + START_S, index=index)

    def _call_events(self, busy: dict[Connection, _Task], what: str, limit: float | None,
                     grace: float) -> Iterator[tuple[_Task, tuple[Any, Any]]]:
        """The calls among ``busy`` that ended, each with its ``(value, error)``, after one
        wait (a call that announces its problem is built gets ``limit`` from then)."""
        for worker in self._events(list(busy.values())):
            call = busy[worker.conn]
            msg, ended = self._receive(worker)
            if ended is not None:
                yield call, (None, WorkerDiedError(
                    f"{what} ended its worker process ({ended})" if call.phase
                    else f"its worker process ended ({ended}) while it built the problem"))
            elif _aside(msg):
                continue
            elif msg[0] == "phase":
                call.phase = "built"
                call.deadline = None if limit is None else time.monotonic() + limit
            elif msg[0] == "end":
                _, error, value, strays = msg
                self._release(worker, strays, what)
                yield call, (value, error)
            else:
                self._end(worker)
                yield call, (None, WorkerDiedError(f"{what}: its worker process sent "
                                                   f"{msg[0]!r}, not an answer; it was ended"))
        now = time.monotonic()
        for call in list(busy.values()):
            if call.deadline is not None and now > call.deadline:
                self._end(call.worker)
                yield call, (None, WorkerKilledError(
                    f"{what} did not return within {limit:.0f} s (run_timeout_s + "
                    f"grace_s={grace:g} s; blocked in C or ignoring SIGALRM): its worker process "
                    "was killed" if call.phase else f"building the problem took more than "
                    f"{START_S:.0f} s: its worker process was killed"))

    def outcomes(self, job: Job, indices: Sequence[int], lockstep: bool, workers: int,
                 threads: int) -> Iterator[RunOutcome]:
        """The outcome of each run in ``indices``, as they end, from up to ``workers`` processes."""
        size = max(1, workers)
        pending: deque[list[int]] = deque(_tasks(list(indices), size) if lockstep
                                          else [[i] for i in indices])
        busy: dict[Connection, _Task] = {}
        try:
            while pending or busy:
                while pending and len(busy) < size:
                    self._hand_out(job, pending.popleft(), threads, busy)
                yield from self._collect(job, busy, pending)
        finally:
            for b in busy.values():  # interrupted: their state is unknown
                self._end(b.worker)

    def _hand_out(self, job: Job, runs: list[int], threads: int,
                  busy: dict[Connection, _Task]) -> None:
        worker = self._take()
        key = _job_key(job)
        fresh = key not in worker.jobs
        worker.jobs.add(key)
        # a worker new to the job first builds its problem (no plugin optimizer code yet)
        limit = _allowance(job, len(runs))
        limit = START_S if fresh and limit is not None else limit
        deadline = None if limit is None else time.monotonic() + limit
        busy[worker.conn] = _Task(worker, deadline, list(runs), now_utc())
        with contextlib.suppress(OSError):  # a worker already gone: the next wait says so
            worker.conn.send(("runs", job, (runs, len(runs) > 1, threads)))

    def _collect(self, job: Job, busy: dict[Connection, _Task],
                 pending: deque[list[int]]) -> Iterator[RunOutcome]:
        for worker in self._events(list(busy.values())):
            b = busy[worker.conn]
            msg, ended = self._receive(worker)
            if ended is not None:
                del busy[worker.conn]
                cause = WorkerDiedError(f"its worker process ended ({ended})"
                                        f"{_DURING.get(b.phase, '')}")
                yield from _lost(job, b, cause, pending)
            elif not _aside(msg):
                yield from self._handle(job, worker.conn, msg, busy, pending)
        now = time.monotonic()
        for conn, b in list(busy.items()):
            if b.deadline is not None and now > b.deadline:
                del busy[conn]
                self._end(b.worker)
                cause = WorkerKilledError(
                    f"the run passed run_timeout_s={job.spec.run_timeout_s} s and did not return "
                    f"within grace_s={job.spec.grace_s:g} s more (blocked in C code or ignoring "
                    "SIGALRM): its worker process was killed")
                yield from _lost(job, b, cause, pending)

    def _handle(self, job: Job, conn: Connection, msg: Any, busy: dict[Connection, _Task],
                pending: deque[list[int]]) -> Iterator[RunOutcome]:
        """A worker's message about its runs: progress, an outcome, or the task's end."""
        b = busy[conn]
        kind = msg[0]
        if kind == "outcome" and msg[1].index not in b.remaining:
            # not one of its runs (never sent by a worker that keeps to the protocol)
            del busy[conn]
            cause = WorkerDiedError(f"its worker process sent the outcome of run "
                                    f"{msg[1].index}, which it was not running; it was ended "
                                    f"({self._end(b.worker)})")
            yield from _lost(job, b, cause, pending)
        elif kind in ("phase", "outcome"):  # progress: the clock restarts for what is left
            if kind == "outcome":
                b.remaining.remove(msg[1].index)
                b.phase = "built"
                yield msg[1]
            else:
                b.phase = msg[1]
            limit = _allowance(job, len(b.remaining))
            b.deadline = None if limit is None else time.monotonic() + limit
        elif kind == "end":
            _, error, _, strays = msg
            del busy[conn]
            # building the problem failed (or the worker ended the task early): every run left
            cause = error if error is not None else WorkerDiedError(
                "its worker process ended the task without the run's outcome")
            for i in b.remaining:
                yield RunOutcome(i, cause, b.started, 0.0)
            self._release(b.worker, strays, f"{job.optimizer_name} on {job.problem_name}")
        else:
            del busy[conn]
            cause = WorkerDiedError(f"its worker process sent {kind!r}, not a run's outcome; "
                                    f"it was ended ({self._end(b.worker)})")
            yield from _lost(job, b, cause, pending)


def _lost(job: Job, b: _Task, cause: BaseException, pending: deque[list[int]]
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
    """A lockstep job's runs cut into tasks of at most :data:`LOCKSTEP_CHUNK` runs, a
    multiple of ``workers`` of them, sizes differing by one at most (30 runs on 2 workers go
    as 8, 7, 7, 8, so the workers finish together)."""
    n = len(indices)
    tasks = min(n, workers * -(-n // (workers * LOCKSTEP_CHUNK)))
    bounds = [round(k * n / tasks) for k in range(tasks + 1)] if tasks else [0]
    return [indices[a:b] for a, b in zip(bounds, bounds[1:]) if b > a]


def _allowance(job: Job, runs: int) -> float | None:
    """Seconds a worker may take for ``runs`` runs (a warm-up counts as one) before it is killed."""
    limit = job.spec.run_timeout_s
    return None if limit is None else limit * max(runs, 1) + job.spec.grace_s


def _job_key(job: Job) -> str:
    """What tells a worker's first task of a job from the next (its problem and optimizer)."""
    return repr((job.problem_name, job.problem_settings(), job.optimizer_name,
                 job.optimizer_settings()))


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


def _end_all(workers: list[_Worker]) -> None:
    """At exit: every worker left and what it started, ended."""
    for worker in list(workers):
        with contextlib.suppress(Exception):
            worker.tree.end()
            worker.process.join(timeout=2)
            worker.tree.close()


def outcomes_isolated(pool: Workers, job: Job, indices: Sequence[int], lockstep: bool
                      ) -> Iterator[RunOutcome]:
    """:meth:`Workers.outcomes` with the job's ``workers`` and ``threads`` keys applied (each
    worker's problem gets an equal share of the cores unless ``threads`` is set)."""
    requested = job.spec.workers or pool.size
    tasks = (len(_tasks(list(indices), min(requested, pool.cap))) if lockstep else len(indices))
    workers = pool.how_many(requested, tasks)
    threads = job.spec.threads or max(1, available_cores() // workers)
    return pool.outcomes(job, indices, lockstep, workers, threads)


__all__ = ["RemoteError", "WorkerDiedError", "WorkerKilledError",
           "Workers", "can_send", "describe_exit", "is_timeout", "outcomes_isolated",
           "portable", "worker_cap"]
