"""Plugins of round five's attack on process supervision (issue 44, N2-N4), for
``test_round5_processes.py``. Module level, so worker processes import them by name; registered
by the entry point the tests plant (a third party's plugin, as installed). Every process they
start notes itself as :mod:`process_plugins` does (:func:`process_plugins.note`)."""

from __future__ import annotations

import os
import time

from process_plugins import CHILD_S, Base, daemon, fork_noted, linger, note, once

from vpid_bench import hookimpl

#: The environment variable naming the file each new process of :class:`Chain` writes its
#: generation into (no listing of processes catches a chain whose one living process changes
#: every few milliseconds: the file's change shows it still runs).
CHAIN_ENV = "VPID_TEST_CHAIN"
#: A chain ends by itself after this many seconds or generations (the machine is shared).
CHAIN_S, CHAIN_GENERATIONS = 15.0, 3000


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
    beat = os.open(os.environ[CHAIN_ENV], os.O_WRONLY | os.O_CREAT, 0o600)
    end = time.monotonic() + CHAIN_S
    for generation in range(CHAIN_GENERATIONS):
        if time.monotonic() > end:
            break
        if os.fork() != 0:
            os._exit(0)
        os.setsid()
        os.pwrite(beat, f"{generation:08d}".encode(), 0)
        time.sleep(0.001)
    os._exit(0)


class Chain(Base):
    """N4: at the end of its first timed run (its ``close()``), starts a process that keeps
    forking and calling ``setsid`` (:func:`chain`) while its worker lives on."""

    def close(self):
        timed = self.rng.bit_generator.seed_seq.spawn_key != (2**31,)  # not the warm-up
        if timed and once("chain") and os.fork() == 0:
            chain()


def fork_dispositions(job, problem) -> tuple[bool, bool]:
    """A call for a worker (:meth:`vpid_bench.workers.Workers.call`): whether SIGTERM and
    SIGHUP have their default action in this worker, and in a child it forks (which ends
    before the call returns)."""
    import signal

    def default() -> bool:
        return all(signal.getsignal(s) == signal.SIG_DFL for s in (signal.SIGTERM,
                                                                   signal.SIGHUP))

    pid = os.fork()
    if pid == 0:
        os._exit(0 if default() else 1)
    _, status = os.waitpid(pid, 0)
    return default(), os.waitstatus_to_exitcode(status) == 0


OPTIMIZERS = (Sleeper, DaemonExit, Chain)


@hookimpl
def vpid_bench_register_optimizers(register):
    for cls in OPTIMIZERS:
        register(cls.__name__.lower(), cls)


__all__ = ["CHAIN_ENV", "Chain", "DaemonExit", "Sleeper", "linger"]
