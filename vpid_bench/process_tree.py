"""A worker process's own session and subreaping (:func:`detach`), its copy of the
resource-tracker pipe closed (:func:`drop_tracker`), its output through pipes the supervisor
copies (:class:`Output`): an orphan once kept the command's standard output open and
``vpid-bench ... | tail`` waited for it (docs/sweeps.md, crash isolation). Ending the tree
is :mod:`vpid_bench.worker_tree`'s job.
"""

from __future__ import annotations

import codecs
import contextlib
import ctypes
import os
import select
import sys
from multiprocessing.connection import Connection
from typing import Any

import psutil

#: ``prctl`` option that makes a process the reaper of its orphaned descendants (Linux).
PR_SET_CHILD_SUBREAPER = 36
#: Bytes read from a worker's output pipe at a time.
CHUNK = 65536


def detach() -> None:
    """In a new worker, before any plugin code: a session of its own and, on Linux, the
    child subreaper of its descendants (best effort)."""
    with contextlib.suppress(OSError):
        os.setsid()
    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def drop_tracker() -> None:
    """In a new worker, before any plugin code: close its copy of the command's resource
    tracker pipe (the tracker holds the command's output and ends when every copy is closed:
    a daemon holding one made ``vpid-bench ... | tail`` wait, issue 44 N3). A plugin that
    needs a tracker gets the worker's own."""
    from multiprocessing import resource_tracker

    tracker = resource_tracker._resource_tracker
    fd = getattr(tracker, "_fd", None)
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)
        tracker._fd, tracker._pid = None, None


def strays(process: Any) -> list[Any]:
    """The living descendants (no zombies) of ``process`` (a :class:`psutil.Process` or a
    process id), as :class:`psutil.Process` objects."""
    try:
        root = process if isinstance(process, psutil.Process) else psutil.Process(process)
        found = root.children(recursive=True) if root.is_running() else []
    except psutil.Error:
        return []
    alive = []
    for child in found:
        with contextlib.suppress(psutil.Error):
            if child.status() != psutil.STATUS_ZOMBIE:
                alive.append(child)
    return alive


def exited(pid: int) -> bool:
    """Whether the child process ``pid`` has ended, not reaping it (its number stays its own)."""
    try:
        return os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
    except ChildProcessError:  # already reaped
        return True


class Output:
    """A worker's standard output and error: two pipes it writes (:meth:`child_ends`) and
    this process copies to its own (:meth:`forward`). The read ends never block (a
    descendant may keep a write end open)."""

    def __init__(self) -> None:
        self._streams: dict[int, tuple[str, Any]] = {}
        self._child: list[Connection] = []
        for name in ("stdout", "stderr"):
            read, write = os.pipe()
            os.set_blocking(read, False)
            self._streams[read] = (name, codecs.getincrementaldecoder("utf-8")("replace"))
            self._child.append(Connection(write, readable=False))

    def child_ends(self) -> tuple[Connection, Connection]:
        """The write ends, for the worker (they pickle to a spawned process as descriptors)."""
        return self._child[0], self._child[1]

    def started(self) -> None:
        """Close this process's copies of the write ends (the worker has its own)."""
        for end in self._child:
            with contextlib.suppress(OSError):
                end.close()
        self._child = []

    @property
    def fds(self) -> list[int]:
        """The read ends still open (to wait on)."""
        return list(self._streams)

    def forward(self, fd: int) -> None:
        """Copy what is waiting in pipe ``fd`` to this process's stream; at its end, close it."""
        try:
            data = os.read(fd, CHUNK)
        except BlockingIOError:
            return
        except OSError:
            data = b""
        name, decoder = self._streams[fd]
        text = decoder.decode(data, final=not data)
        stream = getattr(sys, name, None)
        if text and stream is not None:
            with contextlib.suppress(Exception):
                stream.write(text)
                stream.flush()
        if not data:
            del self._streams[fd]
            os.close(fd)

    def close(self) -> None:
        """Copy what is left in the pipes (never waiting for more) and close them."""
        self.started()
        for fd in list(self._streams):
            for _ in range(64):  # at most 4 MB more of a worker that is still writing
                if fd not in self._streams or not readable(fd):
                    break
                self.forward(fd)
            if fd in self._streams:
                del self._streams[fd]
                with contextlib.suppress(OSError):
                    os.close(fd)


def readable(fd: int, closed: bool = False) -> bool:
    """Whether ``fd`` (a pipe, a pidfd) is readable now; ``closed`` when it is not open."""
    with contextlib.suppress(OSError, ValueError):
        return bool(select.select([fd], [], [], 0)[0])
    return closed


def redirect(out: Connection, err: Connection) -> None:
    """In the worker: its standard output and error into the pipes ``out`` and ``err``,
    line-buffered so a plugin's lines arrive as it prints them."""
    for end, fd in ((out, 1), (err, 2)):
        os.dup2(end.fileno(), fd)
        end.close()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.reconfigure(line_buffering=True)
