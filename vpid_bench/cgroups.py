"""A Linux cgroup (version 2) per worker process, where this process may make one (where, and
``VPID_BENCH_CGROUPS=0``: docs/sweeps.md, crash isolation): every process the worker's plugins
start is in it, whatever it does, and ``cgroup.kill`` ends them all at once, forks in flight
included (Linux >= 5.14). Elsewhere :meth:`Cgroup.create` returns ``None`` and
:mod:`vpid_bench.worker_tree` finds processes by their mark.
"""

from __future__ import annotations

import contextlib
import functools
import os
import time
from pathlib import Path

#: The environment variable that turns cgroups off (``0``).
ENV = "VPID_BENCH_CGROUPS"


@functools.lru_cache(maxsize=1)
def _own_folder() -> Path | None:
    """The folder of this process's cgroup v2, or ``None`` (no v2 hierarchy mounted)."""
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
        mounts = Path("/proc/self/mountinfo").read_text().splitlines()
    except OSError:
        return None
    own = next((ln[3:] for ln in lines if ln.startswith("0::")), None)
    for line in mounts:
        fields = line.split(" - ", 1)
        if own is None or len(fields) != 2 or not fields[1].startswith("cgroup2 "):
            continue
        root, mount = fields[0].split()[3:5]  # the mount's root inside the hierarchy
        inside = os.path.relpath(own, root) if own.startswith(root) else None
        if inside is not None and not inside.startswith(".."):
            return Path(mount, inside).resolve()
    return None


class Cgroup:
    """One worker's cgroup: created empty, the worker added once started, killed whole, removed."""

    def __init__(self, path: Path) -> None:
        self.path = path

    @classmethod
    def create(cls, name: str) -> Cgroup | None:
        """A new cgroup ``name`` beside this process's own, or ``None``."""
        base = _own_folder() if os.environ.get(ENV, "1") != "0" else None
        if base is None:
            return None
        path = base / name
        try:
            path.mkdir()
        except OSError:
            return None
        if not (path / "cgroup.kill").exists():  # Linux < 5.14: no atomic kill
            cls(path).remove()
            return None
        return cls(path)

    def add(self, pid: int) -> bool:
        """Move process ``pid`` into the cgroup; ``False`` (the cgroup removed) if refused."""
        try:
            (self.path / "cgroup.procs").write_text(str(pid))
        except OSError:
            self.remove()
            return False
        return True

    def pids(self) -> list[int]:
        """The processes in the cgroup now."""
        with contextlib.suppress(OSError, ValueError):
            return [int(p) for p in (self.path / "cgroup.procs").read_text().split()]
        return []

    def kill(self, wait: float) -> bool:
        """SIGKILL every process in it (``cgroup.kill``); whether it is empty within ``wait`` s."""
        with contextlib.suppress(OSError):
            (self.path / "cgroup.kill").write_text("1")
        end = time.monotonic() + wait
        while self.populated() and time.monotonic() < end:
            time.sleep(0.01)
        return not self.populated()

    def populated(self) -> bool:
        """Whether a living process is still in the cgroup."""
        try:
            events = (self.path / "cgroup.events").read_text()
        except OSError:
            return False
        return "populated 1" in events

    def remove(self) -> None:
        """Remove the cgroup (possible once no process is in it)."""
        with contextlib.suppress(OSError):
            self.path.rmdir()
