"""``job.json``: one job's status, read by the command after a sweep whatever process ran
it; it carries the invocation id of the command that wrote it (``VPID_BENCH_INVOCATION``), so
an earlier command's statuses are not mistaken for this one's.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

from ..fileio import loads_json, read_text_limited
from .records import _jsonable, write_record

JOB_STATUS_FILE = "job.json"


def write_job_status(job_dir: Path, status: str, detail: Any) -> Path:
    """Write ``{"status", "detail", "invocation"}``: ``ok``, ``failed_runs`` (their records
    say why), ``error`` or ``interrupted``; ``detail`` a JobSummary or a message."""
    if dataclasses.is_dataclass(detail) and not isinstance(detail, type):
        detail = {k: (str(v) if isinstance(v, Path) else v)
                  for k, v in dataclasses.asdict(detail).items() if k != "record_paths"}
    return write_record(Path(job_dir) / JOB_STATUS_FILE, {
        "status": status, "detail": _jsonable(detail),
        "invocation": os.environ.get("VPID_BENCH_INVOCATION")})


def read_job_status(job_dir: Path) -> dict[str, Any] | None:
    """The job status in ``job_dir``, or None when there is none (or it is unreadable)."""
    path = Path(job_dir) / JOB_STATUS_FILE
    try:
        status = loads_json(read_text_limited(path))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None
    return status if isinstance(status, dict) else None
