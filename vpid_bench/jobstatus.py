"""``job.json``: the status of one job, written atomically into its output directory.

The sweep callback reads these to tell which jobs failed, whatever launcher ran them.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

from .records import _jsonable, write_record

JOB_STATUS_FILE = "job.json"


def write_job_status(job_dir: Path, status: str, detail: Any) -> Path:
    """Write ``{"status": ..., "detail": ...}``; ``detail`` may be a JobSummary or a message."""
    if dataclasses.is_dataclass(detail) and not isinstance(detail, type):
        detail = {k: (str(v) if isinstance(v, Path) else v)
                  for k, v in dataclasses.asdict(detail).items() if k != "record_paths"}
    return write_record(Path(job_dir) / JOB_STATUS_FILE, {"status": status, "detail": _jsonable(detail)})


def read_job_status(job_dir: Path) -> dict[str, Any] | None:
    """The job status in ``job_dir``, or None when there is none (or it is unreadable)."""
    path = Path(job_dir) / JOB_STATUS_FILE
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return None
