"""``problem=vehicle``'s records as CSV: ``reference.csv`` written (``t`` in s, then the clean
and noisy z1'', z2'' in m/s^2, the clean columns empty for a measured record) and
``problem.reference.file`` read (``t``, ``z1dd``, ``z2dd`` or a written file's noisy columns;
its first row is the model's t = 0, the front tyre at the bump's leading edge).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from vpid_bench import write_text_atomic

from .record_file import Column, ColumnMap, Record, read_record

HEADER = ("t", "z1dd_clean", "z2dd_clean", "z1dd_noisy", "z2dd_noisy")
#: The measured channels a record must carry, in m/s^2.
CHANNELS = (Column("z1dd", "m/s^2", ("z1dd_noisy", "z1''")),
            Column("z2dd", "m/s^2", ("z2dd_noisy", "z2''")))


def write_reference(
    path: Path, t: np.ndarray, noisy: np.ndarray, clean: np.ndarray | None
) -> Path:
    """Write ``reference.csv`` atomically (never torn; a planted link replaced, not followed)."""
    buffer = io.StringIO(newline="")
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(HEADER)
    for k in range(len(t)):
        c = ("", "") if clean is None else (repr(float(clean[0, k])), repr(float(clean[1, k])))
        writer.writerow(
            (repr(float(t[k])), *c, repr(float(noisy[0, k])), repr(float(noisy[1, k])))
        )
    return write_text_atomic(Path(path), buffer.getvalue())


#: Columns a written ``reference.csv`` carries that a fit never reads (empty for a measured
#: record): accepted without ``problem.reference.ignore``.
WRITTEN_ONLY = ("z1dd_clean", "z2dd_clean")


def read_measured(path: str | Path, mapping: ColumnMap | None = None) -> Record:
    """The measured z1'', z2'' ``(2, N)`` (m/s^2) at the record's times, or a ConfigError."""
    return read_record(path, CHANNELS, mapping=mapping, extra_ok=WRITTEN_ONLY)
