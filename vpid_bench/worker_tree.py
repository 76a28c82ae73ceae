"""A worker process and every process its plugins start, held so that ending them never
signals anything else (issue 44: N1, a reused process number once got SIGKILL; N3, N4).

Every signal goes through a pidfd this process holds or a psutil handle checked to be the
tree's; a worker has a cgroup where one can be made (:mod:`vpid_bench.cgroups`) and a mark in
its environment (:data:`MARK`). How :meth:`Tree.end` finds and ends the tree, and what is
guaranteed where: docs/sweeps.md, crash isolation.
"""

from __future__ import annotations

import contextlib
import dataclasses
import itertools
import os
import secrets
import signal
import time
from collections.abc import Callable
from typing import Any

import psutil

from .cgroups import Cgroup
from .machine import environ
from .process_tree import exited, readable

#: The environment variable that marks a worker's processes (its value: the worker's token).
MARK = "VPID_BENCH_TREE"
#: ``pidfd_send_signal`` flag: the target's process group (Linux >= 6.9).
PIDFD_SIGNAL_PROCESS_GROUP = 1 << 2
#: Rounds of the stop-then-look-again search at most (each stops every new process found).
ROUNDS = 500
#: Seconds to wait for killed processes to end before naming them as left.
WAIT_S = 5.0

_count = itertools.count()


def new_token() -> str:
    """A token naming one worker's tree (this process's id, a count, a random part)."""
    return f"{os.getpid()}-{next(_count)}-{secrets.token_hex(4)}"


def pidfd(pid: int) -> int | None:
    """A pidfd of process ``pid`` (Linux >= 5.3), or ``None``."""
    try:
        return os.pidfd_open(pid)
    except (AttributeError, OSError):
        return None


def start_tracker() -> None:
    """Start multiprocessing's resource tracker now if it is not running: before a worker is
    marked (the tracker is the command's: it must not carry the mark), and before the signals
    are held for a worker's start (starting it unblocks SIGINT and SIGTERM)."""
    from multiprocessing import resource_tracker

    with contextlib.suppress(Exception):
        resource_tracker.ensure_running()


def marked(token: str) -> contextlib.AbstractContextManager[None]:
    """Inside: this process's environment carries :data:`MARK` = ``token``, so a worker it
    spawns inherits it (call :func:`start_tracker` first)."""
    return environ(MARK, token)


@dataclasses.dataclass
class _Held:
    """One process held: its pidfd (``None`` without pidfds: its psutil handle then)."""

    pid: int
    fd: int | None
    proc: Any
    name: str

    def signal(self, sig: int) -> None:
        if self.fd is not None:
            with contextlib.suppress(OSError):
                signal.pidfd_send_signal(self.fd, sig)
        elif self.proc is not None:
            with contextlib.suppress(psutil.Error):
                self.proc.send_signal(sig)

    def alive(self) -> bool:
        """Whether it still runs (a zombie does not)."""
        if self.fd is not None and readable(self.fd, closed=True):  # readable once it exits
            return False
        try:
            return self.proc.is_running() and self.proc.status() != psutil.STATUS_ZOMBIE
        except psutil.Error:
            return False

    def close(self) -> None:
        if self.fd is not None:
            with contextlib.suppress(OSError):
                os.close(self.fd)
            self.fd = None


def _hold(pid: int, belongs: Callable[[Any], bool]) -> _Held | None:
    """Process ``pid`` held by a pidfd, once checked to be the tree's (``belongs``, asked of
    its :class:`psutil.Process`), so a number handed out again is never held; ``None`` if it
    is gone, a zombie or not the tree's."""
    fd = pidfd(pid)
    try:
        proc = psutil.Process(pid)
        if proc.status() == psutil.STATUS_ZOMBIE or not belongs(proc):
            raise psutil.NoSuchProcess(pid)
        return _Held(pid, fd, proc, proc.name())
    except psutil.Error:
        if fd is not None:
            os.close(fd)
        return None


def _children(pid: int) -> list[int]:
    """The children of process ``pid`` (zombies included), from the kernel's own lists
    (fast enough to see a chain that forks every millisecond), or psutil's."""
    try:
        tids = os.listdir(f"/proc/{pid}/task")
    except OSError:
        tids = []
    found: list[int] = []
    for tid in tids:
        children = f"/proc/{pid}/task/{tid}/children"
        with contextlib.suppress(OSError, ValueError), open(children) as f:
            found += [int(c) for c in f.read().split()]
    if tids or not os.path.isdir("/proc"):
        return found
    with contextlib.suppress(psutil.Error):
        return [c.pid for c in psutil.Process(pid).children()]
    return []


class Tree(_Held):
    """A worker process just started (not yet reaped), its ``token`` (:func:`marked`) and
    ``cgroup`` (``None``: none could be made), held (see module); its ``fd`` (pidfd,
    ``None`` without pidfds) is readable once it ended. :meth:`close` lets go of it."""

    def __init__(self, process: Any, token: str, cgroup: Cgroup | None) -> None:
        self.process, self.pid, self.token, self.name = process, process.pid, token, "worker"
        self.fd = pidfd(self.pid)
        try:
            self.proc: Any = psutil.Process(self.pid)
        except psutil.Error:
            self.proc = None
        self.cgroup = cgroup if cgroup is not None and cgroup.add(self.pid) else None

    def ended(self) -> bool:
        """Whether the worker has ended (without reaping it)."""
        if self.fd is not None:
            try:
                return os.waitid(os.P_PIDFD, self.fd,
                                 os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
            except ChildProcessError:  # already reaped
                return True
        return not self._unreaped() or exited(self.pid)  # unreaped: the number is its own

    def _unreaped(self) -> bool:
        """Whether the worker is not reaped yet (its number is still its own)."""
        if self.fd is not None:
            try:
                os.waitid(os.P_PIDFD, self.fd, os.WEXITED | os.WNOHANG | os.WNOWAIT)
            except ChildProcessError:
                return False
            return True
        return getattr(getattr(self.process, "_popen", None), "returncode", 0) is None

    def _signal_group(self, sig: int) -> None:
        """Signal the worker's process group (it leads one): through its pidfd, or by number
        only while the worker is not reaped."""
        if self.fd is not None:
            try:
                signal.pidfd_send_signal(self.fd, sig, None, PIDFD_SIGNAL_PROCESS_GROUP)
                return
            except ProcessLookupError:  # no process left in the group
                return
            except OSError:  # the flag is unknown to this kernel (< 6.9)
                pass
        if self._unreaped():
            with contextlib.suppress(OSError):
                os.killpg(self.pid, sig)

    def _descendants(self, held: dict[int, _Held], seen: set[int]) -> tuple[list[_Held], bool]:
        """The worker's descendants not held yet, and whether any number not ``seen`` before
        was listed (a process that ended as it was held still shows the tree is forking)."""
        # only numbers still held (a number handed out again is never walked)
        roots = [pid for pid, h in held.items() if h.alive()]
        roots += [self.pid] if self._unreaped() else []
        tree = {self.pid, *held}
        new: list[_Held] = []
        fresh = False
        stack = list(roots)
        while stack:
            for child in _children(stack.pop()):
                fresh = fresh or child not in seen
                seen.add(child)
                if child in tree:
                    continue
                h = _hold(child, lambda p: p.ppid() in tree)
                if h is not None:
                    tree.add(child)
                    new.append(h)
                    stack.append(child)
        return new, fresh

    def _marked(self, held: dict[int, _Held], checked: set[int]) -> list[_Held]:
        """The processes carrying the worker's mark not held yet (wherever they went);
        ``checked``: the numbers already read (only new ones are read)."""
        def marked(proc: Any) -> bool:
            return proc.environ().get(MARK) == self.token

        new: list[_Held] = []
        for pid in psutil.pids():
            if pid in checked or pid in held or pid in (self.pid, os.getpid()):
                continue
            checked.add(pid)
            with contextlib.suppress(psutil.Error):
                if marked(psutil.Process(pid)):
                    h = _hold(pid, marked)
                    if h is not None:
                        new.append(h)
        return new

    def end(self) -> list[str]:
        """Kill the worker and its tree; ``"<pid> (<name>)"`` of each process still running
        afterwards. Nothing but what it holds is signalled."""
        if self.cgroup is not None:
            self.cgroup.kill(WAIT_S)
        self.signal(signal.SIGSTOP)  # it starts no more; its orphans stay its own
        held: dict[int, _Held] = {}  # every process of the tree found and stopped, until two
        checked: set[int] = set()  # rounds running find none new (at most ROUNDS, WAIT_S)
        seen: set[int] = set()
        quiet = 0
        end = time.monotonic() + WAIT_S
        for _ in range(ROUNDS):
            found, fresh = self._descendants(held, seen)
            new = found + self._marked(held, checked)
            for h in new:
                h.signal(signal.SIGSTOP)
                held[h.pid] = h
            quiet = 0 if new or fresh else quiet + 1
            if quiet >= 2 or time.monotonic() > end:
                break
        self.signal(signal.SIGKILL)
        self._signal_group(signal.SIGKILL)
        for h in held.values():
            h.signal(signal.SIGKILL)
        end = time.monotonic() + WAIT_S
        while any(h.alive() for h in held.values()) and time.monotonic() < end:
            time.sleep(0.01)
        left = {h.pid: h.name for h in held.values() if h.alive()}
        for h in held.values():
            h.close()
        if self.cgroup is not None:
            for pid in self.cgroup.pids():  # still there after its kill: said, never signalled
                left.setdefault(pid, f"in cgroup {self.cgroup.path.name}")
            left.pop(self.pid, None)
            self.cgroup.remove()
        return [f"{pid} ({name})" for pid, name in sorted(left.items())]
