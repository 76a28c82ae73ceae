"""A user's record as a CSV file (``problem.reference.file``): the one reader of the format,
for every problem plugin that fits one (docs/own-record.md#the-file describes it for users).

A header row names the columns, a unit optional in brackets (``zsdd [m/s^2]``; converted
through the problem's unit table, else it must be the problem's); each data row holds
numbers. The problem's columns (:class:`RecordColumn`) are matched by name or alias, or
mapped with :class:`ColumnMap`. **Strict**: every column must be used (or listed in
``problem.reference.ignore``); ``t`` (s) must increase. Anything else is refused as one
:class:`~vpid_bench.errors.ConfigError` naming the column, row or value.
"""

from __future__ import annotations

import csv
import dataclasses
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..errors import ConfigError

KEY = "problem.reference.file"
#: A number as a record cell may write it: ASCII digits, an optional sign, point and
#: exponent (no ``1_000``, no full-width or other Unicode digits, which ``float`` accepts).
NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
#: Largest magnitude of a value in the problem's units: beyond it a channel's norm (a sum of
#: squares) overflows, so the fit would ignore the channel.
MAX_MAGNITUDE = 1e100
#: Smallest largest magnitude of a measured channel: below it (zero or denormal) the
#: channel's weight ``1 / ||channel||`` is not a finite number.
MIN_MAGNITUDE = 1e-100
#: A channel in which one sample holds more than this fraction of the sum of squares is
#: refused, naming the sample (a logger's spike, not a system's response).
MAX_SHARE = 0.5
#: A unit table: unit -> (quantity, factor to the quantity's SI unit).
Units = Mapping[str, tuple[str, float]]
_HEADER = re.compile(r"\s*([^\[\]]*?)\s*(?:\[\s*([^\[\]]*?)\s*\])?\s*")
_PLAIN = re.compile(r"[A-Za-z0-9_ .()'/\[\]-]{1,60}")


@dataclasses.dataclass(frozen=True)
class RecordColumn:
    """A column a problem asks for: its name, the unit its values are returned in (``None``:
    as written, any stated unit accepted) and other names it is accepted under."""

    name: str
    unit: str | None = None
    aliases: tuple[str, ...] = ()


#: The time column every record has (s).
TIME = RecordColumn("t", "s", ("time",))


@dataclasses.dataclass(frozen=True)
class ColumnMap:
    """``problem.reference``'s view of a record's columns: ``columns`` maps a problem name to
    the record's column (``{"h": "road [mm]"}``, a unit in brackets optional), ``ignore``
    lists record columns left unused on purpose."""

    columns: Mapping[str, str] = dataclasses.field(default_factory=dict)
    ignore: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class CsvRecord:
    """A read record's file and times (s); a problem's record adds its channels."""

    path: str
    t: np.ndarray

    @property
    def span(self) -> float:
        """The record's duration, last minus first time (s)."""
        return float(self.t[-1] - self.t[0])

    def rate_text(self) -> str:
        """``"500 Hz, regular"`` or ``"irregular, 480-520 Hz"``."""
        steps = np.diff(self.t)
        lo, hi = float(steps.min()), float(steps.max())
        if hi - lo <= 1e-6 * hi:
            return f"{1 / np.mean(steps):.6g} Hz, regular"
        return f"irregular, {1 / hi:.4g}-{1 / lo:.4g} Hz"


@dataclasses.dataclass(frozen=True)
class Found:
    """Where a :class:`RecordColumn` is: its name in the file, index and unit factor."""

    name: str
    index: int
    factor: float


def _plain(name: str) -> bool:
    """A name an error line may show: a few plain ASCII characters, so what a file holds
    that is no header (a password file's first line) is never quoted."""
    return _PLAIN.fullmatch(name) is not None


def shown(name: str) -> str:
    """A name read from a file, quoted, as an error line may show it."""
    return repr(name) if _plain(name) else "(a name with unusual characters)"


def _printable(text: str) -> str:
    return "".join(c if c.isprintable() else "?" for c in text[:20])


def _split(cell: str) -> tuple[str, str | None]:
    """``'road [mm]'`` -> ``('road', 'mm')``, ``'road'`` -> ``('road', None)``."""
    m = _HEADER.fullmatch(cell)
    name, unit = (m.group(1), m.group(2)) if m else (cell.strip(), None)
    return name, unit or None


class CsvTable:
    """A record file read and its header checked against the problem's columns (``TIME``
    and ``required`` must be found, ``optional`` may be)."""

    #: Fewest rows a record may have (a handful of samples identifies nothing).
    MIN_ROWS = 10
    #: Most rows read (a 1 kHz record of 16 minutes).
    MAX_ROWS = 1_000_000
    #: Largest file read (bytes).
    MAX_FILE_BYTES = 256 * 1024**2

    def __init__(self, path: str | Path, required: Sequence[RecordColumn],
                 optional: Sequence[RecordColumn] = (), mapping: ColumnMap | None = None,
                 units: Units | None = None) -> None:
        self.path = Path(path)
        self.mapping = mapping or ColumnMap()
        self.units = units or {}
        self.columns = (TIME, *required, *optional)
        need = ", ".join(c.name for c in (TIME, *required))
        if not self.path.is_file():
            raise self.fail(f"an existing CSV file (columns {need})")
        rows = self._rows()
        if not rows:
            raise self.fail(f"a CSV with a header row {need} (file is empty)")
        self.header = self._header(rows[0])
        self.body = [(k + 2, r) for k, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
        self._check_mapping()
        got = [(self.find(c), c) for c in (TIME, *required)]
        absent = [c.name for f, c in got if f is None]
        if absent:
            raise self.fail(f"a header with columns {need} (units optional, e.g. t [s]); column "
                            f"{absent[0]} is missing; {self.found()} (name one with "
                            f"problem.reference.columns={{{absent[0]}:<column>}})")
        self.time, *self.required = (f for f, _ in got if f is not None)

    def fail(self, allowed: str) -> ConfigError:
        """The error for this file (key ``problem.reference.file``)."""
        return ConfigError(KEY, str(self.path), allowed)

    def _rows(self) -> list[list[str]]:
        """The CSV rows (a UTF-8 byte-order mark is accepted), at most ``MAX_ROWS + 1``."""
        try:
            size = self.path.stat().st_size
            if size > self.MAX_FILE_BYTES:
                raise self.fail(f"a CSV file of at most {self.MAX_FILE_BYTES // 1024**2} MiB "
                                f"(this one: {size / 1024**2:.0f} MiB)")
            with open(self.path, newline="", encoding="utf-8-sig") as fh:
                rows = []
                for row in csv.reader(fh):
                    rows.append(row)
                    if len(rows) > self.MAX_ROWS + 1:
                        raise self.fail(f"at most {self.MAX_ROWS} rows of samples; found more")
                return rows
        except UnicodeDecodeError as exc:
            raise self.fail(f"a text CSV file in UTF-8 (byte {exc.start} is not UTF-8: a "
                            "binary file?)") from None
        except csv.Error as exc:
            raise self.fail(f"a text CSV file ({exc})") from None
        except OSError as exc:
            raise self.fail(f"a readable CSV file ({exc.strerror})") from None

    def _header(self, cells: list[str]) -> dict[str, tuple[int, str | None]]:
        """Column name -> (index, stated unit or None); a name twice is refused."""
        out: dict[str, tuple[int, str | None]] = {}
        for i, cell in enumerate(cells):
            name, unit = _split(cell)
            if not name:
                continue
            if name in out:
                raise self.fail(f"each column once; column {shown(name)} appears twice")
            out[name] = (i, unit)
        return out

    def found(self) -> str:
        """The header as read, when it looks like column names (never other file content)."""
        names = list(self.header)
        if names and len(names) <= 20 and all(map(_plain, names)):
            return "found columns " + ", ".join(names)
        return "found no such header row"

    def _check_mapping(self) -> None:
        names = [c.name for c in self.columns]
        for key, value in self.mapping.columns.items():
            if not isinstance(value, str) or not value.strip():
                raise ConfigError(f"problem.reference.columns.{key}", value, "a column name of "
                                  "the record (a unit in brackets optional: 'road [mm]')")
            if key not in names:
                raise ConfigError(f"problem.reference.columns.{key}", value, "a mapping from "
                                  "the problem's names, one of " + ", ".join(names))
        for name in self.mapping.ignore:
            if name not in self.header:
                raise ConfigError("problem.reference.ignore", list(self.mapping.ignore),
                                  f"columns of the record; {shown(name)} is not one ("
                                  f"{self.found()})")

    def _factor(self, column: str, given: str | None, unit: str | None) -> float:
        """What a column's values are multiplied by to be in ``unit``."""
        if given is None or unit is None or given == unit:
            return 1.0
        if unit not in self.units:
            raise self.fail(f"column {column} in its unit [{unit}] or without a unit (found "
                            f"[{_printable(given)}])")
        quantity = self.units[unit][0]
        if given not in self.units or self.units[given][0] != quantity:
            allowed = sorted(u for u, (q, _) in self.units.items() if q == quantity)
            raise self.fail(f"column {column} in a unit of {quantity}, one of "
                            f"{', '.join(allowed)} (found [{_printable(given)}])")
        return self.units[given][1] / self.units[unit][1]

    def find(self, col: RecordColumn) -> Found | None:
        """Where ``col`` is: the column the mapping names for it (its unit from the mapping
        or the header, which must agree), else its name or an alias; ``None`` if absent."""
        target = self.mapping.columns.get(col.name)
        if target is None:
            for name in (col.name, *col.aliases):
                if name in self.header:
                    index, unit = self.header[name]
                    return Found(name, index, self._factor(name, unit, col.unit))
            return None
        key = f"problem.reference.columns.{col.name}"
        name, unit = _split(target)
        if name not in self.header:
            raise ConfigError(key, target, f"a column of {self.path.name}; {self.found()}")
        index, stated = self.header[name]
        if unit and stated and unit != stated:
            raise ConfigError(key, target, f"the unit the header states for {name} "
                              f"([{_printable(stated)}]) or none")
        return Found(name, index, self._factor(name, unit or stated, col.unit))

    def read(self, measured: Sequence[Found], others: Sequence[Found],
             allowed: Sequence[str] | None = None, extra_ok: Sequence[str] = ()
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Times ``(N,)``, ``measured`` channels ``(p, N)`` (:func:`check_channels`) and
        ``others`` ``(N, r)``, in their columns' units, after refusing a column not used
        (``allowed``: the names the error offers, default every column asked for;
        ``extra_ok``: record columns left unread without a word)."""
        used = [self.time, *measured, *others]
        names = {f.name for f in used}
        allowed = [c.name for c in self.columns] if allowed is None else allowed
        for name in self.header:
            if name not in names and name not in self.mapping.ignore and name not in extra_ok:
                raise self.fail(f"only the columns the problem uses, {', '.join(allowed)}; "
                                f"column {shown(name)} is not used (map it with "
                                "problem.reference.columns, or list it in "
                                "problem.reference.ignore)")
        if len(self.body) < self.MIN_ROWS:
            raise self.fail(f"at least {self.MIN_ROWS} rows of samples; found {len(self.body)}")
        data = self._numbers(used)
        t = data[:, 0].copy()
        steps = np.diff(t)
        if np.any(steps <= 0):
            k = int(np.flatnonzero(steps <= 0)[0])
            raise self.fail(f"a t column that increases from row to row; row "
                            f"{self.body[k + 1][0]} has t = {t[k + 1]:.9g} s after "
                            f"{t[k]:.9g} s")
        p = len(measured)
        out = np.ascontiguousarray(data[:, 1:1 + p].T)
        check_channels(self.path, out, [f.name for f in measured], [r for r, _ in self.body])
        return t, out, np.ascontiguousarray(data[:, 1 + p:])

    def _numbers(self, cols: Sequence[Found]) -> np.ndarray:
        """The ``cols`` of the rows as floats in their units, ``(N, len(cols))``."""
        data = np.empty((len(self.body), len(cols)))
        for k, (line, row) in enumerate(self.body):
            for j, col in enumerate(cols):
                cell = row[col.index].strip() if col.index < len(row) else ""
                if not NUMBER.fullmatch(cell):
                    if cell.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                        raise self.fail(f"finite numbers; row {line} column {col.name} is "
                                        f"{cell[:12]}")
                    raise self.fail(f"a number in column {col.name} of every row; row {line} "
                                    "has none (ASCII digits, e.g. 1000.5 or -2e-3)")
                value = float(cell) * col.factor
                if not abs(value) <= MAX_MAGNITUDE:
                    si = " in SI units" if self.units else ""
                    raise self.fail(
                        f"values of magnitude at most {MAX_MAGNITUDE:g}{si}; row {line} column "
                        f"{col.name} is {float(cell):.6g}"
                        + (f" (x {col.factor:g}{si})" if col.factor != 1 else ""))
                data[k, j] = value
        return data


def check_channels(path: str | Path, out: np.ndarray, names: Sequence[str],
                   rows: Sequence[int]) -> None:
    """Refuse a measured channel (a row of ``out``, ``rows`` the file's row numbers of its
    samples) that is zero or denormal throughout (nothing to fit, its weight not finite) or
    in which one sample dominates the norm (a spike), naming it."""
    for c, name in enumerate(names):
        y = out[c]
        peak = float(np.max(np.abs(y)))
        if peak < MIN_MAGNITUDE:
            raise ConfigError(KEY, str(path), f"a record in which every measured channel moves "
                              f"(column {name} is {'zero' if peak == 0 else 'denormal'} "
                              f"throughout: its largest value is {peak:.3g})")
        share = (y / peak) ** 2
        k = int(np.argmax(share))
        total = float(np.sum(share))
        if share[k] > MAX_SHARE * total:
            raise ConfigError(KEY, str(path), f"no single sample making up most of a channel; "
                              f"row {rows[k]} column {name} ({y[k]:.6g}) makes up "
                              f"{100 * share[k] / total:.0f} % of its sum of squares (a "
                              "logger's spike? remove the row)")
