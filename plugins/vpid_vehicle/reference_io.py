"""Reading a measured record and writing the fitted reference, as CSV with a header row.

Written (``reference.csv``): ``t`` (s), ``z1dd_clean``, ``z2dd_clean``, ``z1dd_noisy``,
``z2dd_noisy`` (m/s^2): the front (z1'') and rear (z2'') body accelerations of Eq. (5)
without and with noise. For a measured record the clean columns are left empty and ``t`` is
the record's own time.

Read (``problem.reference.file``, :func:`read_measured`): a record in the format of
:mod:`.record_file`, with columns ``t``, ``z1dd``, ``z2dd`` (or ``z1dd_noisy``,
``z2dd_noisy``, so a written reference.csv can be fitted again), at any rate and start;
units optional (``z1dd [g]``). Its first row is the model's t = 0: the front tyre at the
bump's leading edge, the vehicle at rest until then.
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
    """Write ``reference.csv`` (see module docstring); ``noisy``/``clean`` are ``(2, N)``.
    Atomic, like every file vpid-bench writes: a crash or a full disk leaves the old file or
    the new one, never a torn one, and a link planted at ``path`` is replaced, not followed."""
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
    """The measured z1'', z2'' (``outputs``, ``(2, N)``, m/s^2) at the record's times;
    :class:`~vpid_bench.api.ConfigError` naming the column, row or time problem of a file
    that does not fit (:func:`.record_file.read_record`). The input is the configured bump
    (part of the problem's design): a record carries no input column."""
    return read_record(path, CHANNELS, mapping=mapping, extra_ok=WRITTEN_ONLY)
