"""Plugins of round five's attack on process supervision (issue 44, N2-N4), for
``test_round5_processes.py``. Module level, so worker processes import them by name; registered
by the entry point the tests plant (a third party's plugin, as installed). Every process they
start notes itself as :mod:`process_plugins` does (:func:`process_plugins.note`)."""

from __future__ import annotations

import ctypes
import os
import time

from process_plugins import CHILD_S, Base, daemon, fork_noted, linger, note, once

from vpid_bench import hookimpl

#: The environment variable naming the process name (``comm``, at most 15 characters) that
#: every process of :class:`Chain` takes, so a test finds every one of them.
CHAIN_ENV = "VPID_TEST_CHAIN"
#: A chain ends by itself after this many seconds or generations (the machine is shared).
CHAIN_S, CHAIN_GENERATIONS = 20.0, 4000
PR_SET_NAME = 15


class Sleeper(Base):
    """N2: its worker notes itself, leaves a child, then sleeps in ask() until the sweep is
    interrupted (or :data:`CHILD_S` passes)."""

    def ask(self):
        if once("sleeper"):
            note("worker")
            fork_noted("child", linger)
            time.sleep(CHILD_S)
        return super().ask()


class DaemonExit(Base):
    """N3: starts a daemon (fork, ``setsid``, fork again; it lives :data:`CHILD_S` with what it
    inherited), then ends its worker (``os._exit(3)``)."""

    def ask(self):
        daemon("daemon")
        os._exit(3)


def chain() -> None:
    """In a child: fork again and again, each new process in a session of its own, each parent
    ending at once, so that the chain's one living process changes all the time; ends after
    :data:`CHAIN_S` seconds or :data:`CHAIN_GENERATIONS` generations."""
    name = os.environ.get(CHAIN_ENV, "vpidchain").encode()[:15]
    ctypes.CDLL(None).prctl(PR_SET_NAME, ctypes.c_char_p(name), 0, 0, 0)
    end = time.monotonic() + CHAIN_S
    for _ in range(CHAIN_GENERATIONS):
        if time.monotonic() > end:
            break
        if os.fork() != 0:
            os._exit(0)
        os.setsid()
        time.sleep(0.002)
    os._exit(0)


class Chain(Base):
    """N4: starts a process that keeps forking and calling ``setsid`` (:func:`chain`), then
    goes on with its run while its worker lives."""

    def ask(self):
        if once("chain") and os.fork() == 0:
            chain()
        return super().ask()


OPTIMIZERS = (Sleeper, DaemonExit, Chain)


@hookimpl
def vpid_bench_register_optimizers(register):
    for cls in OPTIMIZERS:
        register(cls.__name__.lower(), cls)


__all__ = ["CHAIN_ENV", "Chain", "DaemonExit", "Sleeper", "linger"]
