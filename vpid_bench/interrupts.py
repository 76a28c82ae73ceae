"""Telling the user's Ctrl-C from a ``KeyboardInterrupt`` that a plugin raises.

Python turns SIGINT into ``KeyboardInterrupt``, and the run loop lets that stop the whole
sweep (every finished run is kept; ``--resume`` continues). A plugin that raises
``KeyboardInterrupt`` itself (in ``ask``, ``tell``, its constructor or ``close``) once stopped
the sweep the same way, and every resume stopped again. The command installs a SIGINT handler
that notes the signal before raising; a ``KeyboardInterrupt`` seen without that note came from
code, and fails its run only. Where no handler is installed (a program calling the library, a
launcher's worker process) every ``KeyboardInterrupt`` counts as the user's.

SIGTERM (a scheduler's time limit, ``kill``) and SIGHUP (a closed terminal) end the command as
SIGINT does (issue 44, N2): they once ended it with status 143 and nothing printed, its
worker processes and theirs left running. The same handler takes all three (:data:`SIGNALS`):
every completed run is kept, the same ``interrupted:`` line, every process ended; the status is
``128 + the signal's number`` (130, 143, 129: :func:`exit_status`), as a shell reports it.
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from typing import Any

#: The signals that interrupt the command (those this platform has).
SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


class _Watch:
    """Whether the command's handler is installed and whether it has seen SIGINT."""

    installed = False
    signalled = False
    #: The first interrupting signal seen (its number), for the exit status.
    signum = int(signal.SIGINT)


def _seen(signum: int) -> None:
    if not _Watch.signalled:
        _Watch.signum = signum
    _Watch.signalled = True


def _handler(signum: int, frame: Any) -> None:
    _seen(signum)
    raise KeyboardInterrupt


def _note(signum: int, frame: Any) -> None:
    _seen(signum)


def _set_all(handler: Any) -> None:
    for sig in SIGNALS:
        signal.signal(sig, handler)


def defer() -> None:
    """While the command starts (heavy imports, the plugins' own imports): a SIGINT is only
    noted, and :func:`install` raises it once the start-up is over. Raised at once, the
    ``KeyboardInterrupt`` could land inside a library's bare ``except:`` around an import,
    which swallowed it: the command then ran its whole sweep and exited 0."""
    if threading.current_thread() is threading.main_thread():
        already = signal.getsignal(signal.SIGINT) is _note  # a note taken so far stays
        _set_all(_note)
        _Watch.installed, _Watch.signalled = True, _Watch.signalled and already


def note(signum: int = signal.SIGINT) -> None:
    """Record an interrupting signal (:data:`SIGNALS`) that arrived before :func:`defer` (the
    console command's first module notes it while the package imports)."""
    _seen(signum)


def raise_if_swallowed() -> None:
    """Raise ``KeyboardInterrupt`` if the command's handler saw a Ctrl-C that never reached
    the command: a ``KeyboardInterrupt`` raised inside a C callback is dropped by ctypes
    ("Exception ignored on calling ctypes callback function", e.g. while numba loads
    compiled code), and the sweep once ran to its end and exited 0. Called between jobs and
    at the end of the sweep; only where the command's own handler is installed."""
    if _Watch.signalled and signal.getsignal(signal.SIGINT) is _handler:
        raise KeyboardInterrupt


def install() -> None:
    """Install the noting SIGINT handler (main thread of the command's process only); a
    SIGINT noted since :func:`defer` is raised now, as ``KeyboardInterrupt``."""
    if threading.current_thread() is threading.main_thread():
        pending = _Watch.signalled
        _set_all(_handler)
        _Watch.installed, _Watch.signalled = True, pending
        if pending:
            raise KeyboardInterrupt


def plugin_only() -> None:
    """In a worker process (:mod:`vpid_bench.workers`): SIGINT is ignored, the user's Ctrl-C
    is the supervisor's to handle, so every ``KeyboardInterrupt`` seen here is a plugin's.
    SIGTERM and SIGHUP are the supervisor's too (a batch system's SIGTERM to every process of
    a job once ended the workers first, and their runs were recorded as failed by the signal):
    the worker takes them with a handler that does nothing, and a process it forks gets their
    default back at once (a plugin's pool must still end its children with SIGTERM; a process
    it execs gets the default anyway)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        for sig in SIGNALS:
            if sig != signal.SIGINT:
                signal.signal(sig, _ignore)
        os.register_at_fork(after_in_child=_defaults)
    _Watch.installed, _Watch.signalled = True, False


def _ignore(signum: int, frame: Any) -> None:
    """A worker's SIGTERM and SIGHUP handler: nothing (see :func:`plugin_only`)."""


def _defaults() -> None:
    """In a process forked from a worker: SIGTERM and SIGHUP back to their default."""
    for sig in SIGNALS:
        if sig != signal.SIGINT and signal.getsignal(sig) is _ignore:
            with contextlib.suppress(ValueError):  # not the main thread: left as it is
                signal.signal(sig, signal.SIG_DFL)


def exit_status() -> int:
    """The command's exit status once interrupted: 128 + the number of the signal that
    interrupted it (130 for SIGINT, also when no signal was noted: a program's own
    ``KeyboardInterrupt``)."""
    return 128 + (_Watch.signum if _Watch.signalled else int(signal.SIGINT))


def seen() -> bool:
    """Whether the command's handler has seen the user's Ctrl-C. An error raised since may be
    its consequence: the ``KeyboardInterrupt`` can land inside a library's clean-up (an
    omegaconf flag restored in a ``finally`` while Hydra composed a job's config raised
    ``ConfigKeyError`` over it, and the command printed Hydra's traceback and exit 1), so
    the command treats such an error as the interrupt."""
    return _Watch.installed and _Watch.signalled


def from_user() -> bool:
    """Whether a ``KeyboardInterrupt`` being handled now is the user's (or cannot be told)."""
    return not _Watch.installed or _Watch.signalled


class PluginInterruptError(RuntimeError):
    """A plugin raised ``KeyboardInterrupt`` without the user pressing Ctrl-C: its run fails."""

    def __init__(self, where: str) -> None:
        super().__init__(f"the plugin raised KeyboardInterrupt in {where} (not the user's "
                         "Ctrl-C): this run fails, the sweep goes on")


def thread_exception_line(args: Any) -> str:
    """The one line said for an exception in a plugin's own thread (``threading.excepthook``'s
    ``args``), in the command's process and in a worker process alike."""
    name = args.thread.name if args.thread is not None else "?"
    return f"warning: thread {name} raised {args.exc_type.__name__}: {args.exc_value}"
