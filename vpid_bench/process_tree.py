"""A worker process and every process its plugins start: one session, output through the
supervisor, and the end of the whole tree.

A plugin may start processes: ``os.fork`` (both copies going on, or a child left sleeping),
``subprocess``, a pool, a daemon. Round four's attack found what that did to the sweep: a
forked child kept the worker's pipe open, so the sweep learned of its worker's death only when
the child ended; an orphan kept the command's standard output open, so ``vpid-bench ... |
tail`` waited for it after the command had exited. So each worker

* starts its own session (:func:`detach`): it and every process it starts form one process
  group; on Linux it is also a *child subreaper*, so a grandchild its parent left (a daemon's
  double fork, even one that started a session of its own) becomes the worker's child rather
  than init's and is still found among its descendants (:func:`strays`);
* closes its copy of the command's multiprocessing resource-tracker pipe (:func:`drop_tracker`);
* writes its standard output and error into pipes that the supervisor reads and copies to its
  own (:class:`Output`): no process a plugin starts holds the command's streams, whatever it
  does.

Ending the whole tree, and never anything else, is :mod:`vpid_bench.worker_tree`'s job (a
cgroup per worker, a mark in the environment, pidfds).
"""

from __future__ import annotations

import codecs
import contextlib
import os
import sys
from multiprocessing.connection import Connection
from typing import Any

#: ``prctl`` option that makes a process the reaper of its orphaned descendants (Linux).
PR_SET_CHILD_SUBREAPER = 36
#: Bytes read from a worker's output pipe at a time.
CHUNK = 65536


def detach() -> None:
    """In a new worker process, before any plugin code: a session of its own and, on Linux,
    the child subreaper of its descendants (see module). Best effort: where either is not
    available, less of the tree is found."""
    with contextlib.suppress(OSError):
        os.setsid()
    if sys.platform.startswith("linux"):
        with contextlib.suppress(Exception):
            import ctypes

            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def drop_tracker() -> None:
    """In a new worker process, before any plugin code: close its copy of the write end of
    the command's multiprocessing resource tracker pipe. The tracker ends when every copy is
    closed, and it holds the command's standard output and error: a daemon a plugin started
    kept the copy it inherited, and ``vpid-bench ... | tail`` waited for it (issue 44, N3).
    Should a plugin need a tracker, the worker starts its own (its child, ended with it)."""
    from multiprocessing import resource_tracker

    tracker = resource_tracker._resource_tracker
    fd = getattr(tracker, "_fd", None)
    if fd is not None:
        with contextlib.suppress(OSError):
            os.close(fd)
        tracker._fd, tracker._pid = None, None


def strays(process: Any) -> list[Any]:
    """The living descendants of ``process`` (a :class:`psutil.Process` or a process id;
    zombies, already ended, left out), as :class:`psutil.Process` objects; empty when it is
    gone."""
    import psutil

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
    """Whether the child process ``pid`` has ended, without reaping it (its number stays its
    own until it is reaped: see :mod:`vpid_bench.worker_tree`)."""
    try:
        return os.waitid(os.P_PID, pid, os.WEXITED | os.WNOHANG | os.WNOWAIT) is not None
    except ChildProcessError:  # already reaped
        return True


class Output:
    """A worker's standard output and error: two pipes it writes (:meth:`child_ends`, handed
    to it at its start) and this process reads (:meth:`forward`), copying the text to its own
    ``sys.stdout`` and ``sys.stderr``. The read ends are non-blocking: a descendant that keeps
    a write end open never blocks the supervisor."""

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
        """Copy what is waiting in pipe ``fd`` to this process's stream of the same name; at
        the end of the pipe, close it."""
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
                if fd not in self._streams or not _ready(fd):
                    break
                self.forward(fd)
            if fd in self._streams:
                del self._streams[fd]
                with contextlib.suppress(OSError):
                    os.close(fd)


def _ready(fd: int) -> bool:
    """Whether pipe ``fd`` has something to read now."""
    import select

    with contextlib.suppress(OSError, ValueError):
        return bool(select.select([fd], [], [], 0)[0])
    return False


def redirect(out: Connection, err: Connection) -> None:
    """In the worker: its standard output and error go into the pipes ``out`` and ``err``
    (:class:`Output`), line-buffered so a plugin's lines arrive as it prints them."""
    for end, fd in ((out, 1), (err, 2)):
        os.dup2(end.fileno(), fd)
        end.close()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.reconfigure(line_buffering=True)


__all__ = ["Output", "detach", "drop_tracker", "exited", "redirect", "strays"]
