"""Sweeps that survive: where a sweep lives, how to find it again, and what its jobs did.

* :class:`SweepStatus` is a Hydra callback (listed in conf/config.yaml). At the start of a
  multirun it prints the sweep folder and the exact command that resumes it, and remembers
  the folder for :func:`vpid_bench.cli.main`, which reads the jobs' ``job.json`` files after
  Hydra returns. ``job.json`` is the channel that works for every launcher (basic, joblib
  worker processes, submitit, ray): each job writes it, tagged with this command's
  invocation id (environment variable ``VPID_BENCH_INVOCATION``, inherited by workers).
* :func:`find_previous` implements ``vpid-bench --resume``: the newest earlier sweep (or
  single run) whose command-line overrides match the current ones, ignoring ``hydra.*``
  (launcher choice, ...) and the operational keys ``progress``, ``report`` and ``resume``.
"""

from __future__ import annotations

import os
import shlex
import sys
import uuid
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback

from .jobstatus import JOB_STATUS_FILE, read_job_status

INVOCATION_ENV = "VPID_BENCH_INVOCATION"
#: Keys that do not change any result, so they may differ between a sweep and its resume.
OPERATIONAL_KEYS = frozenset({"progress", "report", "resume"})

# The sweep folder of the multirun running in this process (set by SweepStatus).
_CURRENT: dict[str, Any] = {}


def new_invocation() -> str:
    """A fresh invocation id, exported so that launcher workers inherit it."""
    token = uuid.uuid4().hex
    os.environ[INVOCATION_ENV] = token
    _CURRENT.clear()
    return token


def current_invocation() -> str | None:
    """The invocation id of the command this process (or its parent) is running."""
    return os.environ.get(INVOCATION_ENV) or None


def current_sweep_dir() -> Path | None:
    """The folder of the multirun that ran in this process, once it has started."""
    return _CURRENT.get("sweep_dir")


def _command_text(argv: Sequence[str]) -> str:
    return " ".join(["vpid-bench", *(shlex.quote(a) for a in argv)])


class SweepStatus(Callback):
    """Prints the sweep folder and resume hint; remembers the folder for the exit status."""

    def on_multirun_start(self, config: Any, **kwargs: Any) -> None:
        sweep_dir = Path(str(config.hydra.sweep.dir))
        _CURRENT["sweep_dir"] = sweep_dir
        args = [a for a in sys.argv[1:] if not a.startswith("hydra.sweep.dir=")]
        hint = _command_text([*args, f"hydra.sweep.dir={sweep_dir}"])
        print(
            f"sweep folder: {sweep_dir}\n"
            f"  if this sweep stops, resume it (only missing runs are run) with:\n  {hint}\n"
            "  (or run the same command with --resume: it finds the newest sweep like it)",
            file=sys.stderr,
            flush=True,
        )


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
        (p for p in root.iterdir() if p.is_dir()), key=lambda p: p.stat().st_mtime, reverse=True
    )
    for folder in candidates:
        saved = _saved_task_overrides(folder, multirun)
        if saved is not None and normalise_overrides(saved) == wanted:
            return folder
    return None


def collect_job_statuses(sweep_dir: Path, invocation: str | None) -> list[dict[str, Any]]:
    """The ``job.json`` of every job this invocation ran below ``sweep_dir``.

    Each entry is the status dict plus ``job_dir``. A status without the invocation id (or
    with another one) belongs to an earlier command and is ignored.
    """
    out = []
    for path in sorted(Path(sweep_dir).rglob(JOB_STATUS_FILE)):
        status = read_job_status(path.parent)
        if status is None:
            out.append({"status": "unreadable", "detail": f"{path} is not readable JSON",
                        "job_dir": str(path.parent)})
            continue
        if invocation is not None and status.get("invocation") != invocation:
            continue
        out.append({**status, "job_dir": str(path.parent)})
    return out
