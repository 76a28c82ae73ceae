"""Independent pieces of a report computed side by side: an archive report's two families of
tests and its figures (69 over archive/vpid1) are half of its time, and on two cores take
half as long. :func:`run_forked` runs calls in forked processes, inherited through ``fork``
(never pickled: a figure's data or a closure need not be picklable); only their results
travel back. Where ``fork`` or a second core is missing, or a process dies, the calls run
here, one after another: the same results, only slower."""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, TypeVar

import psutil

from ..interrupts import SIGNALS
from ..machine import available_cores

log = logging.getLogger(__name__)
T = TypeVar("T")
#: The most processes one :func:`run_forked` starts (one per core, up to this).
MAX_WORKERS = 2
#: The calls of the :func:`run_forked` running now, which its forked processes inherit.
_CALLS: list[Callable[[], Any]] = []


def _call(index: int) -> Any:
    return _CALLS[index]()


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """The command's interrupting signals held back while processes are forked: one arriving
    in a fork's callbacks (logging's lock release) raised ``KeyboardInterrupt`` there, where
    Python prints "Exception ignored" and drops it, and the report went on to exit 0. Held
    back, it is raised once they are let through again."""
    held = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def _take_signals() -> None:
    """In a forked process: the signals :func:`_signals_held` held back are let through."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)


def run_forked(calls: Sequence[Callable[[], T]], done: Callable[[int], Any] | None = None
               ) -> list[T]:
    """``[call() for call in calls]``, computed in forked processes where that helps
    (``done(n)`` after each of the first ``n`` results, in order). An exception a call raises
    is raised here, as it would be in this process."""
    workers = min(MAX_WORKERS, available_cores(), len(calls))
    if workers > 1 and "fork" in multiprocessing.get_all_start_methods() and not _CALLS:
        _CALLS[:] = calls
        out: list[T] = []
        before = _children()
        pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                   initializer=_take_signals)
        try:
            with _signals_held():  # the pool forks its processes as the calls are given
                results = pool.map(_call, range(len(calls)))
            for result in results:
                out.append(result)
                if done is not None:
                    done(len(out))
            pool.shutdown()
            return out
        except BrokenProcessPool:  # the others may be stuck (a lock held at the fork): ended
            log.debug("a forked process died; computing here", exc_info=True)
            _end(pool, before)
        except BaseException:  # a Ctrl-C or SIGTERM, a call's error: its processes end now
            _end(pool, before)
            raise
        finally:
            _CALLS.clear()
    out = []
    for call in calls:
        out.append(call())
        if done is not None:
            done(len(out))
    return out


def _children() -> set[int]:
    """The process ids of this process's children now."""
    return {c.pid for c in psutil.Process().children()}


def _end(pool: ProcessPoolExecutor, before: set[int]) -> None:
    """Stop ``pool`` without waiting and kill (SIGKILL: they inherited the command's
    handlers, which only note a SIGTERM) every child forked since ``before``, found by the
    system, not multiprocessing: a signal handled on the main thread while the pool forks
    (another thread took the signal) interrupts it between the fork and the process's
    registration, and the tests found such processes left behind for ever, blocked on a
    lock they inherited. Left to the pool's own shutdown, an interrupted report also waited
    for every call under way."""
    pool.shutdown(wait=False, cancel_futures=True)
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline:
        forked = [c for c in psutil.Process().children() if c.pid not in before]
        if not forked:
            break
        for child in forked:
            with contextlib.suppress(psutil.Error):
                child.kill()
        psutil.wait_procs(forked, timeout=0.5)
    multiprocessing.active_children()  # reaps the ones multiprocessing knows
