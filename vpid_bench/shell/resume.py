"""Sweeps that survive: finding an earlier sweep (``--resume``: :func:`find_previous`), one
command per output folder (:func:`check_reuse`, :class:`FolderLock`), the ``job.json`` of
this invocation's jobs (:func:`collect_job_statuses`; its id in ``VPID_BENCH_INVOCATION``,
inherited by launcher workers).
"""

from __future__ import annotations

import contextlib
import os
import shlex
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf

from ..errors import ConfigError
from ..spec import OPERATIONAL_KEYS
from ..store.job_status import JOB_STATUS_FILE, read_job_status
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
    candidates = sorted((p for p in root.iterdir() if p.is_dir() and not p.is_symlink()),
                        key=lambda p: p.stat().st_mtime, reverse=True)
    for folder in candidates:
        saved = _saved_task_overrides(folder, multirun)
        if saved is not None and normalise_overrides(saved) == wanted:
            return folder
    return None


def check_reuse(folder: Path, planned: Sequence[Path], overrides: Sequence[str],
                multirun: bool, merge: bool, key: str) -> str | None:
    """Whether this command may write into ``folder`` (a second sweep was once merged into a
    finished one without a word). Jobs there it does not plan (``planned``) are another
    command's: :class:`ConfigError`, unless ``merge``, when the returned line says so.
    Without ``planned`` the earlier command's saved overrides must equal these."""
    def is_job(p: Path) -> bool:  # a job folder an earlier command left (itself, or below)
        return not p.is_symlink() and ((p / "records").is_dir() or (p / JOB_STATUS_FILE).is_file())

    folder = Path(folder)
    if not folder.is_dir():
        return None
    earlier = {p.resolve() for p in folder.iterdir() if p.is_dir() and is_job(p)}
    earlier |= {folder.resolve()} if is_job(folder) else set()
    if not earlier:
        return None
    if planned:
        foreign = sorted(earlier - {Path(p).resolve() for p in planned})
    else:
        saved = _saved_task_overrides(folder, multirun)
        same = saved is not None and normalise_overrides(saved) == normalise_overrides(overrides)
        foreign = [] if same else sorted(earlier)
    if not foreign:
        return None
    names = ", ".join(p.name for p in foreign[:2]) + (", ..." if len(foreign) > 2 else "")
    what = (f"{len(foreign)} job(s) another command ran ({names}), which its report would "
            "rank beside this command's")
    if merge:
        return f"merge: {folder} holds {what}: merged, as --merge asks"
    raise ConfigError(key, str(folder), f"a folder without another command's jobs: it holds "
                      f"{what}; choose another folder, or add --merge to merge them")


class FolderLock:
    """An exclusive advisory lock on an output folder for the life of the command (ends with
    the process, even on ``kill -9``); ``acquire`` refuses a second command."""

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
        """Whether the lock file at the folder's path is the one held (a sweep folder renamed
        mid-sweep was once re-created, unlocked, by the next job)."""
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
    """The ``job.json`` of every job this invocation ran below ``sweep_dir``, with its folder."""
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


def resume_command(argv: Sequence[str], output_dir: Path, key: str) -> str:
    """The command that continues ``argv``, quoted for a POSIX shell: ``--resume`` alone
    when ``key`` (the output folder) is on the command line, else ``--resume=<output_dir>``."""
    args = [a for a in argv if a != "--resume" and not a.startswith("--resume=")]
    named = any(a.lstrip("+").startswith(key + "=") for a in args)
    args.append("--resume" if named else f"--resume={output_dir}")
    return shlex.join(["vpid-bench", *args])
