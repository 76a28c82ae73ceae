"""The record an FMU is fitted to (``problem.reference.file``): a CSV with a time column
``t`` (s, increasing, any rate and start), a column for every FMU input and for the FMU outputs
compared, matched by name or mapped with ``problem.reference.columns={fmu_name: column}``.

The same format as the vehicle problems' own records (docs/own-record.md): a header row of
names, a unit optional in square brackets after a name (``zsdd [m/s2]``). Here the unit, where
given, must be the FMU variable's declared unit as written in its description (no conversion:
an FMU states its own units). Every column must be used: a column that is neither ``t``, an
input nor an output of the FMU is refused, naming it and the names allowed, unless listed in
``problem.reference.ignore``. An FMU input without a column is refused. Limits: at most
:data:`MAX_ROWS` rows and :data:`MAX_FILE_BYTES` bytes, at least :data:`MIN_ROWS` rows, every
used cell a finite number.

(The vehicle plugin's reader, ``vpid_vehicle.record_file``, checks the same things but plugins
import only ``vpid_bench``, so this is its own, smaller reader for names an FMU defines.)
"""

from __future__ import annotations

import csv
import dataclasses
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from vpid_bench import ConfigError

KEY = "problem.reference.file"
MIN_ROWS = 10
MAX_ROWS = 1_000_000
MAX_FILE_BYTES = 256 * 1024**2
_HEADER = re.compile(r"\s*([^\[\]]*?)\s*(?:\[\s*([^\[\]]*?)\s*\])?\s*")
_SHOWN = re.compile(r"[A-Za-z0-9_ .()'/\[\]-]{1,60}")


@dataclasses.dataclass(frozen=True)
class FmuRecord:
    """A read record: times ``t`` (s), inputs ``(N, r)`` in the FMU's input order, outputs
    ``(p, N)`` of the ``output_names`` compared, and which column each came from."""

    path: str
    t: np.ndarray
    inputs: np.ndarray
    outputs: np.ndarray
    output_names: tuple[str, ...]
    columns: dict[str, str]

    def rate_text(self) -> str:
        steps = np.diff(self.t)
        lo, hi = float(steps.min()), float(steps.max())
        if hi - lo <= 1e-6 * hi:
            return f"{1 / np.mean(steps):.6g} Hz, regular"
        return f"irregular, {1 / hi:.4g}-{1 / lo:.4g} Hz"


def _fail(path: Path | str, allowed: str) -> ConfigError:
    return ConfigError(KEY, str(path), allowed)


def _shown(name: str) -> str:
    return repr(name) if _SHOWN.fullmatch(name) else "(a name with unusual characters)"


def _rows(path: Path) -> list[list[str]]:
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise _fail(path, f"a CSV file of at most {MAX_FILE_BYTES // 1024**2} MiB")
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = []
            for row in csv.reader(fh):
                rows.append(row)
                if len(rows) > MAX_ROWS + 1:
                    raise _fail(path, f"at most {MAX_ROWS} rows of samples")
            return rows
    except UnicodeDecodeError as exc:
        raise _fail(path, f"a text CSV file in UTF-8 (byte {exc.start} is not)") from None
    except csv.Error as exc:
        raise _fail(path, f"a text CSV file ({exc})") from None
    except OSError as exc:
        raise _fail(path, f"a readable CSV file ({exc.strerror})") from None


def _header(path: Path, cells: list[str]) -> dict[str, tuple[int, str | None]]:
    out: dict[str, tuple[int, str | None]] = {}
    for i, cell in enumerate(cells):
        m = _HEADER.fullmatch(cell)
        name, unit = (m.group(1), m.group(2)) if m else (cell.strip(), None)
        if not name:
            continue
        if name in out:
            raise _fail(path, f"each column once; column {_shown(name)} appears twice")
        out[name] = (i, unit or None)
    return out


def read(path: str | Path, inputs: Sequence[tuple[str, str | None]],
         outputs: Sequence[tuple[str, str | None]], columns: Mapping[str, str],
         ignore: Sequence[str] = ()) -> FmuRecord:
    """Read the record at ``path`` for an FMU with ``inputs`` and ``outputs`` (``(name,
    unit)`` each); ``columns`` maps FMU names to record columns (others by their own name)."""
    path = Path(path).expanduser()
    known = {n for n, _ in (*inputs, *outputs)}
    for name in columns:
        if name not in known:
            raise ConfigError(f"problem.reference.columns.{name}", columns[name],
                              "an FMU input or output name: one of "
                              + ", ".join(sorted(known)))
    if not path.is_file():
        raise _fail(path, "an existing CSV file with columns t, the FMU's inputs and outputs")
    rows = _rows(path)
    if not rows:
        raise _fail(path, "a CSV with a header row (file is empty)")
    header = _header(path, rows[0])
    col = {n: columns.get(n, n) for n in known}
    if "t" not in header:
        raise _fail(path, "a header with a time column t (s)")
    compared = _check_columns(path, header, col, inputs, outputs, ignore)
    used = ["t", *(col[n] for n, _ in inputs), *(col[n] for n, _ in compared)]
    body = [(k + 2, r) for k, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
    if len(body) < MIN_ROWS:
        raise _fail(path, f"at least {MIN_ROWS} rows of samples; found {len(body)}")
    data = _numbers(path, body, [(c, header[c][0]) for c in used])
    t = data[:, 0]
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise _fail(path, f"a t column that increases from row to row; row {body[k + 1][0]} "
                    f"has t = {t[k + 1]:.9g} s after {t[k]:.9g} s")
    r = len(inputs)
    y = np.ascontiguousarray(data[:, 1 + r:].T)
    scale = np.linalg.norm(y, axis=1)
    if np.any(scale <= 0):
        c = compared[int(np.flatnonzero(scale <= 0)[0])][0]
        raise _fail(path, f"a record in which every compared output moves (column "
                    f"{_shown(col[c])} is zero throughout)")
    return FmuRecord(str(path), t.copy(), np.ascontiguousarray(data[:, 1:1 + r]), y,
                     tuple(n for n, _ in compared), {n: col[n] for n, _ in (*inputs,
                                                                           *compared)})


def _check_columns(path: Path, header: dict[str, tuple[int, str | None]],
                   col: dict[str, str], inputs: Sequence[tuple[str, str | None]],
                   outputs: Sequence[tuple[str, str | None]], ignore: Sequence[str]
                   ) -> list[tuple[str, str | None]]:
    """The outputs compared (those with a column), after refusing an unused column, an
    input without one and a unit that is not the FMU's."""
    by_column = {c: n for n, c in col.items()}
    for name in header:
        if name != "t" and name not in by_column and name not in ignore:
            raise _fail(path, f"only columns t and the FMU's inputs and outputs ("
                        f"{', '.join(sorted(col.values()))}) or columns listed in "
                        f"problem.reference.ignore; column {_shown(name)} is none of them")
    missing = [n for n, _ in inputs if col[n] not in header]
    if missing:
        raise _fail(path, f"a column for every FMU input; input {missing[0]} has none "
                    f"(expected column {_shown(col[missing[0]])}, or map it with "
                    f"problem.reference.columns.{missing[0]}=<column>)")
    compared = [(n, u) for n, u in outputs if col[n] in header]
    if not compared:
        raise _fail(path, "a column for at least one FMU output (outputs: "
                    + ", ".join(n for n, _ in outputs) + ")")
    for name, unit in (*inputs, *compared):
        given = header[col[name]][1]
        if given is not None and unit is not None and given != unit:
            raise _fail(path, f"column {_shown(col[name])} in the FMU's unit [{unit}] or "
                        f"without a unit (found [{given[:20]}])")
    return compared


def _numbers(path: Path, body: list[tuple[int, list[str]]], cols: list[tuple[str, int]]
             ) -> np.ndarray:
    data = np.empty((len(body), len(cols)))
    for k, (line, row) in enumerate(body):
        for j, (name, index) in enumerate(cols):
            try:
                value = float(row[index])
            except (ValueError, IndexError):
                raise _fail(path, f"a number in column {_shown(name)} of every row; row "
                            f"{line} has none") from None
            if not math.isfinite(value):
                raise _fail(path, f"finite numbers; row {line} column {_shown(name)} is "
                            f"{value}")
            data[k, j] = value
    return data
