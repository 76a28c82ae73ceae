"""Telling the user's Ctrl-C from a ``KeyboardInterrupt`` that a plugin raises.

A plugin raising it itself once stopped every resume too. So the command's handler notes the
signal before raising; a ``KeyboardInterrupt`` without that note came from code and fails its
run only. Without the handler (a program calling the library, a launcher's worker) every
``KeyboardInterrupt`` counts as the user's. SIGTERM and SIGHUP end the command as SIGINT does
(:data:`SIGNALS`; issue 44, N2; docs/sweeps.md, crash isolation and the exit status).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
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


def _handler(signum: int, frame: Any) -> None:
    note(signum)
    raise KeyboardInterrupt


def _note(signum: int, frame: Any) -> None:
    note(signum)


def _set_all(handler: Any) -> None:
    for sig in SIGNALS:
        signal.signal(sig, handler)


def defer() -> None:
    """While the command starts (imports): a signal is only noted, and :func:`install` raises
    it after (raised at once, a library's bare ``except:`` around an import swallowed it and
    the command ran its whole sweep)."""
    if threading.current_thread() is threading.main_thread():
        already = signal.getsignal(signal.SIGINT) is _note  # a note taken so far stays
        _set_all(_note)
        _Watch.installed, _Watch.signalled = True, _Watch.signalled and already


def note(signum: int = signal.SIGINT) -> None:
    """Record an interrupting signal (one before :func:`defer`, or in a block holding them)."""
    if not _Watch.signalled:
        _Watch.signum = signum
    _Watch.signalled = True


def raise_if_swallowed() -> None:
    """Raise ``KeyboardInterrupt`` if the command's handler saw a Ctrl-C that never reached
    the command (ctypes drops one raised inside a C callback, e.g. while numba loads code:
    the sweep once ran to its end and exited 0). Called between jobs and at the end."""
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
    """In a worker process: SIGINT ignored (every ``KeyboardInterrupt`` here is a plugin's),
    SIGTERM and SIGHUP handled by doing nothing (a batch system's SIGTERM to every process
    once failed the workers' runs): they are the supervisor's. A process forked from it gets
    their default back (a plugin's pool must still end its children with SIGTERM)."""
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
    """The command's exit status once interrupted: 128 + the signal's number (130 when none
    was noted: a program's own ``KeyboardInterrupt``)."""
    return 128 + (_Watch.signum if _Watch.signalled else int(signal.SIGINT))


def seen() -> bool:
    """Whether the command's handler has seen the user's Ctrl-C: an error raised since is
    treated as the interrupt (it can land in a library's clean-up, e.g. Hydra's)."""
    return _Watch.installed and _Watch.signalled


def from_user() -> bool:
    """Whether a ``KeyboardInterrupt`` being handled now is the user's (or cannot be told)."""
    return not _Watch.installed or _Watch.signalled


@contextlib.contextmanager
def held(deliver: bool = True) -> Iterator[None]:
    """The :data:`SIGNALS` inside the block noted, and delivered when it ends (with
    ``deliver``; else only noted as the command's interrupt); also blocked, so a process
    started inside inherits them blocked, and a swap of two renames is never cut between
    them. Main thread only."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    noted: list[int] = []
    before = {sig: signal.signal(sig, lambda signum, frame: noted.append(signum))
              for sig in SIGNALS}
    mask = (signal.pthread_sigmask(signal.SIG_BLOCK, set(SIGNALS))
            if hasattr(signal, "pthread_sigmask") else None)
    try:
        yield
    finally:
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        for sig, handler in before.items():
            signal.signal(sig, handler)
        if noted and deliver:
            signal.raise_signal(noted[0])
        elif noted:
            note(noted[0])


class PluginInterruptError(RuntimeError):
    """A plugin raised ``KeyboardInterrupt`` without the user pressing Ctrl-C: its run fails."""

    def __init__(self, where: str) -> None:
        super().__init__(f"the plugin raised KeyboardInterrupt in {where} (not the user's "
                         "Ctrl-C): this run fails, the sweep goes on")


def thread_exception_line(args: Any) -> str:
    """The one line for an exception in a plugin's own thread (``threading.excepthook``)."""
    name = args.thread.name if args.thread is not None else "?"
    return f"warning: thread {name} raised {args.exc_type.__name__}: {args.exc_value}"
