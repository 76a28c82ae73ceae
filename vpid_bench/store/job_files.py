"""A job's JSON files: what the job computes once its runs are in, written beside its records
for the report to read (the fit diagnostics, the bounds, the floors per estimator, the profile
and comparisons of estimates) and the per-problem copies a sweep shares between jobs.

One home for their names, their one size cap, their reader and their writer. The reader
never follows a planted link, opens nothing but a regular file, refuses a file over
:data:`MAX_BYTES` and JSON that is not JSON (nested past the recursion limit included), and
says why in a few words; each file's content is checked by :mod:`.job_checks` (a report
never trusts what a job folder holds).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..fileio import loads_json, read_text_limited
from .records import write_json_atomic

DIAGNOSTICS = "diagnostics.json"
IDENTIFIABILITY = "identifiability.json"
ESTIMATORS = "estimators.json"
PROFILE = "profile.json"
COMPARISONS = "comparisons.json"
#: The largest job JSON file read (bytes): the largest a job writes is a few hundred kB
#: (``identifiability.json`` with 10,000 instances' bounds of 20 parameters).
MAX_BYTES = 2_000_000


def read_job_json(path: Path) -> tuple[Any, str]:
    """The JSON value of the job file ``path``: ``(value, "")``, or ``(None, why)`` for a file
    that is missing, a link, not a regular file, larger than :data:`MAX_BYTES`, not UTF-8 or
    not JSON."""
    try:
        if path.is_symlink():
            return None, "not a regular file"
        if not path.exists():
            return None, "missing"
        size = path.stat().st_size
        if size > MAX_BYTES:
            return None, f"{size} bytes, more than {MAX_BYTES}"
        return loads_json(read_text_limited(path, MAX_BYTES)), ""
    except OSError as exc:
        return None, "not a regular file" if "regular" in str(exc) else \
            f"unreadable ({type(exc).__name__})"
    except (UnicodeDecodeError, ValueError) as exc:
        return None, f"unreadable ({type(exc).__name__})"


def write_job_json(path: Path, data: Any) -> Path:
    """Write ``data`` to the job file ``path`` atomically (never through a planted link)."""
    return write_json_atomic(path, data)
