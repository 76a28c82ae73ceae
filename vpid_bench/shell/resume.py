"""Sweeps that survive: finding an earlier sweep, one command per folder, the jobs' statuses.

* :func:`find_previous` implements ``vpid-bench --resume``: the newest earlier sweep (or single
  run) whose command-line overrides match the current ones, ignoring ``hydra.*`` (launcher
  choice, ...) and the keys that change no result (``progress``, ``report``, ``resume``,
  ``threads``).
* :class:`FolderLock` keeps two commands out of one output folder: the second is refused in
  one line instead of running everything twice.
* :func:`collect_job_statuses` reads the ``job.json`` each job wrote, tagged with this
  command's invocation id (environment variable ``VPID_BENCH_INVOCATION``, inherited by
  launcher workers), so statuses left by an earlier command are not mistaken for this one's.
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import ConfigError
from ..records import JOB_STATUS_FILE, read_job_status
from ..spec import OPERATIONAL_KEYS
from .callbacks import INVOCATION_ENV

LOCK_FILE = ".vpid-bench.lock"


def new_invocation() -> str:
    """A fresh invocation id, exported so that launcher workers inherit it."""
    token = uuid.uuid4().hex
    os.environ[INVOCATION_ENV] = token
    return token


def normalise_overrides(overrides: Sequence[str]) -> list[str]:
    """Overrides that determine results, sorted: ``hydra.*`` and operational keys dropped."""
    out = []
    for text in overrides:
        key = text.lstrip("+~").split("=", 1)[0]
        if key == "hydra" or key.startswith(("hydra.", "hydra/")) or key in OPERATIONAL_KEYS:
            continue
        out.append(text)
    return sorted(out)


def _saved_task_overrides(folder: Path, multirun: bool) -> list[str] | None:
    """The task overrides Hydra saved for an earlier sweep / run in ``folder``."""
    from omegaconf import OmegaConf

    try:
        if multirun:
            cfg = OmegaConf.load(folder / "multirun.yaml")
            return [str(o) for o in cfg.hydra.overrides.task]
        return [str(o) for o in OmegaConf.load(folder / ".hydra" / "overrides.yaml")]
    except Exception:  # a folder that is not a finished sweep/run: not a candidate
        return None


def find_previous(root: Path, overrides: Sequence[str], multirun: bool) -> Path | None:
    """The newest folder under ``root`` whose saved overrides match ``overrides``."""
    if not root.is_dir():
        return None
    wanted = normalise_overrides(overrides)
    candidates = sorted(
        (p for p in root.iterdir() if p.is_dir() and not p.is_symlink()),
        key=lambda p: p.stat().st_mtime, reverse=True,
    )
    for folder in candidates:
        saved = _saved_task_overrides(folder, multirun)
        if saved is not None and normalise_overrides(saved) == wanted:
            return folder
    return None


class FolderLock:
    """An exclusive advisory lock on an output folder, held for the life of the command.

    ``acquire`` raises :class:`ConfigError` when another command holds it. The lock file
    stays behind (harmless); the lock itself ends with the process, even on ``kill -9``.
    """

    def __init__(self, folder: Path, key: str) -> None:
        self.folder, self.key = Path(folder), key
        self._fd: int | None = None

    def acquire(self) -> None:
        import fcntl

        path = self.folder / LOCK_FILE
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
        except OSError as exc:  # a folder, a link or an unwritable file in the lock's place
            raise ConfigError(self.key, str(self.folder), f"a folder whose lock file {path} "
                              f"can be opened ({exc.strerror or exc}); remove what is in its "
                              "place") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise ConfigError(self.key, str(self.folder), "a folder no other running "
                              "vpid-bench command is using (another one is running there)"
                              ) from None
        self._fd = fd

    def still_here(self) -> bool:
        """Whether the locked folder is still where it was (a sweep folder renamed or removed
        mid-sweep was once re-created, unlocked, by the next job, splitting the sweep in
        two without a word): the lock file at the folder's path is the one we hold."""
        if self._fd is None:
            return True
        try:
            held = os.fstat(self._fd)
            there = os.stat(self.folder / LOCK_FILE, follow_symlinks=False)
        except OSError:
            return False
        return (held.st_dev, held.st_ino) == (there.st_dev, there.st_ino)

    def release(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(OSError):
                os.close(self._fd)
            self._fd = None


def collect_job_statuses(sweep_dir: Path, invocation: str | None) -> list[dict[str, Any]]:
    """The ``job.json`` of every job this invocation ran below ``sweep_dir``, each with its
    ``job_dir``; one written by another command (another invocation id) is left out."""
    out = []
    for path in sorted(Path(sweep_dir).rglob(JOB_STATUS_FILE)):
        if path.is_symlink():
            continue
        status = read_job_status(path.parent)
        if status is None:
            out.append({"status": "unreadable", "detail": f"{path} is not readable JSON",
                        "job_dir": str(path.parent)})
            continue
        if invocation is not None and status.get("invocation") != invocation:
            continue
        out.append({**status, "job_dir": str(path.parent)})
    return out
