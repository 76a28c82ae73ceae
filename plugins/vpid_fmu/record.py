"""The record an FMU is fitted to: vpid-bench's CSV record (docs/own-record.md#the-file),
a column ``t``, one for every input and for the outputs compared (by name or
``problem.reference.columns``). A header's unit must be the FMU's own (no conversion); at
least one output needs a column.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from vpid_bench import ColumnMap, CsvRecord, CsvTable, RecordColumn


@dataclasses.dataclass(frozen=True)
class FmuRecord(CsvRecord):
    """Times ``t`` (s), inputs ``(N, r)``, compared outputs ``(p, N)`` and their columns."""

    inputs: np.ndarray
    outputs: np.ndarray
    output_names: tuple[str, ...]
    columns: dict[str, str]


def read(path: str | Path, inputs: Sequence[tuple[str, str | None]],
         outputs: Sequence[tuple[str, str | None]], columns: Mapping[str, str],
         ignore: Sequence[str] = ()) -> FmuRecord:
    """Read the record at ``path`` for an FMU's ``(name, unit)`` inputs and outputs."""
    ins = [RecordColumn(n, u) for n, u in inputs]
    outs = [RecordColumn(n, u) for n, u in outputs]
    table = CsvTable(Path(path).expanduser(), ins, outs, ColumnMap(dict(columns), tuple(ignore)))
    compared = [(c.name, f) for c, f in ((c, table.find(c)) for c in outs) if f is not None]
    if not compared:
        raise table.fail("a column for at least one FMU output (outputs: "
                         + ", ".join(n for n, _ in outputs) + ")")
    t, y, u = table.read([f for _, f in compared], table.required)
    used = [*zip((c.name for c in ins), table.required, strict=True), *compared]
    return FmuRecord(str(table.path), t, u, y, tuple(n for n, _ in compared),
                     {n: f.name for n, f in used})
