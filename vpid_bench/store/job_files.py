"""A job's JSON files (diagnostics, bounds, floors per estimator, profile, comparisons),
written beside its records for the report: their names, one size cap, reader and writer.
The reader never follows a link, opens only a regular file, refuses one over
:data:`MAX_BYTES` or not JSON, and says why; each file's content is checked by :mod:`.job_checks`.
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
    """The JSON value of the job file ``path``: ``(value, "")``, or ``(None, why)``."""
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


#: Write the job file ``path`` atomically (never through a planted link).
write_job_json = write_json_atomic
