"""A user's own record (``problem.reference.file``): a CSV with a time column at any rate and
start, the measured channels and, where the model needs them, its inputs, matched by name.

**Format.** A header row names the columns; each data row holds numbers. A column's unit may
follow its name in square brackets, ``z1dd [m/s^2]``; a name without one is read in the SI
unit the problem states (so a ``reference.csv`` that vpid-bench wrote is read back as is).
Units of another size are converted (:data:`UNITS`: ``ms``, ``g``, ``mm``, ``cm``,
``km/h``, ``deg``, ``deg/s`` ...); a unit of another quantity, or one not in the table, is
refused. The same name twice is refused, and so is a column the problem does not use
(unless ``problem.reference.ignore`` lists it: a record is read whole or not at all).

**Mapping** (``problem.reference.columns``, :class:`ColumnMap`): a problem's name read from
another column, ``{h: road}``, its unit from the mapping (``'road [mm]'``) or the header.

**Time.** ``t`` (s) must increase from row to row; its rate and start are free (a record at
500 Hz from t = 12.3 s is read as it is). The record's first row is the model's time 0 (the
vehicle at rest, its input as the problem defines it from there). The model integrates on its
own step ``dt`` from 0 past the record's last time and is evaluated at the record's times:
exactly where they fall on its steps (a rate dividing ``1 / dt``), else by linear
interpolation between the two steps around each (:class:`Sampler`).

**Inputs** (the road under each wheel, the steer angle and speed): columns sampled at the
record's times, interpolated linearly onto the model's steps (:meth:`Sampler.onto_steps`).
A record without them is refused unless ``problem.reference.input=config`` says the
configured input is meant (never a silent fallback).

**Refused**, each with one line naming the column, row or time: no such file, not UTF-8
text, not CSV, no header, a required column missing, an unused column, a column twice, an
unknown unit or one of another quantity, a row without an ASCII number (:data:`NUMBER`) in a
used column, a non-finite value or one beyond :data:`MAX_MAGNITUDE` in SI units, a time
that does not increase, fewer than :data:`MIN_ROWS` rows, more than :data:`MAX_ROWS`, a
measured channel zero or denormal throughout or dominated by one sample
(:func:`check_channels`), a span of fewer than :data:`MIN_ROWS` model steps
(:func:`check_span`).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vpid_bench import ConfigError

KEY = "problem.reference.file"
#: Fewest rows a record may have (a handful of samples identifies nothing).
MIN_ROWS = 10
#: Most rows read (a 1 kHz record of 16 minutes).
MAX_ROWS = 1_000_000
#: Largest file read (bytes).
MAX_FILE_BYTES = 256 * 1024**2
#: A record time within this fraction of ``dt`` of a model step counts as on it.
ON_STEP_RTOL = 1e-6

#: Units a column may state: quantity and factor to the SI unit of that quantity. The one
#: home of the conversions (docs/own-record.md lists them).
UNITS: dict[str, tuple[str, float]] = {
    "s": ("time", 1.0), "ms": ("time", 1e-3),
    "m/s^2": ("acceleration", 1.0), "m/s²": ("acceleration", 1.0),
    "mm/s^2": ("acceleration", 1e-3), "g": ("acceleration", 9.80665),
    "m": ("length", 1.0), "cm": ("length", 1e-2), "mm": ("length", 1e-3),
    "m/s": ("speed", 1.0), "km/h": ("speed", 1 / 3.6), "mm/s": ("speed", 1e-3),
    "rad": ("angle", 1.0), "deg": ("angle", math.pi / 180), "°": ("angle", math.pi / 180),
    "rad/s": ("angular rate", 1.0), "deg/s": ("angular rate", math.pi / 180),
    "°/s": ("angular rate", math.pi / 180),
}
_HEADER = re.compile(r"\s*([^\[\]]*?)\s*(?:\[\s*([^\[\]]*?)\s*\])?\s*")
_NAME = re.compile(r"[A-Za-z0-9_ .()'/-]{1,40}")


@dataclasses.dataclass(frozen=True)
class Column:
    """A column a problem asks for: its name, SI unit (a key of :data:`UNITS`) and other
    names it is accepted under (a written ``reference.csv``'s ``z1dd_noisy``)."""

    name: str
    unit: str
    aliases: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Record:
    """A read record: times (s, as in the file), outputs ``(p, N)`` and inputs ``(N, r)``
    (``None`` when the file has none of them) in SI units."""

    path: str
    t: np.ndarray
    outputs: np.ndarray
    inputs: np.ndarray | None
    input_names: tuple[str, ...]

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


def column_name(channel: str) -> str:
    """A channel's CSV column name: ``''`` as ``dd``, ``'`` as ``d``, ``-`` as ``_``
    (``zs''`` is ``zsdd``, ``theta'`` is ``thetad``, ``zs-zu`` is ``zs_zu``)."""
    return channel.replace("''", "dd").replace("'", "d").replace("-", "_")


def _fail(path: Path, allowed: str) -> ConfigError:
    return ConfigError(KEY, str(path), allowed)


def _rows(path: Path, limit: int) -> list[list[str]]:
    """The CSV rows of ``path`` (a UTF-8 byte-order mark is accepted), at most ``limit``."""
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise _fail(path, f"a CSV file of at most {MAX_FILE_BYTES // 1024**2} MiB (this "
                        f"one: {size / 1024**2:.0f} MiB)")
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = []
            for row in csv.reader(fh):
                rows.append(row)
                if len(rows) > limit:
                    break
            return rows
    except UnicodeDecodeError as exc:
        raise _fail(path, f"a text CSV file in UTF-8 (byte {exc.start} is not UTF-8: a "
                    "binary file?)") from None
    except csv.Error as exc:
        raise _fail(path, f"a text CSV file ({exc})") from None
    except OSError as exc:
        raise _fail(path, f"a readable CSV file ({exc.strerror})") from None


def _found(header: list[str]) -> str:
    """The header as read, when it looks like column names (never other file content)."""
    if header and len(header) <= 20 and all(_NAME.fullmatch(h or "-") for h in header):
        return "found columns " + ", ".join(header)
    return "found no such header row"


def _parse_header(path: Path, cells: list[str]) -> dict[str, tuple[int, str | None]]:
    """Column name -> (index, stated unit or None); a name twice is refused."""
    out: dict[str, tuple[int, str | None]] = {}
    for i, cell in enumerate(cells):
        m = _HEADER.fullmatch(cell)
        name, unit = (m.group(1), m.group(2)) if m else (cell.strip(), None)
        if not name:
            continue
        if name in out:
            raise _fail(path, f"each column once; column {name!r} appears twice")
        out[name] = (i, unit or None)
    return out


def _factor(path: Path, column: str, given: str | None, si: str) -> float:
    """What a column's values are multiplied by to be in ``si``."""
    if given is None:
        return 1.0
    quantity = UNITS[si][0]
    allowed = sorted(u for u, (q, _) in UNITS.items() if q == quantity)
    if given not in UNITS or UNITS[given][0] != quantity:
        raise _fail(path, f"column {column} in a unit of {quantity}, one of "
                    f"{', '.join(allowed)} (found [{given[:20]}])")
    return UNITS[given][1] / UNITS[si][1]


def _pick(path: Path, header: dict[str, tuple[int, str | None]], col: Column
          ) -> tuple[str, int, float] | None:
    for name in (col.name, *col.aliases):
        if name in header:
            index, unit = header[name]
            return name, index, _factor(path, name, unit, col.unit)
    return None


@dataclasses.dataclass(frozen=True)
class ColumnMap:
    """How a record's columns meet the problem's names (``problem.reference``):
    ``columns`` maps a problem name to the record's column (``{"h": "road [mm]"}``, a unit
    in brackets optional), ``ignore`` lists record columns left unused on purpose, and
    ``input`` is ``record`` (the inputs come from the record) or ``config`` (the configured
    input; the record must not carry one)."""

    columns: dict[str, str] = dataclasses.field(default_factory=dict)
    ignore: tuple[str, ...] = ()
    input: str = "record"


#: ``problem.reference.input`` values.
INPUT_MODES = ("record", "config")


def _mapped(path: Path, header: dict[str, tuple[int, str | None]], col: Column,
            target: str) -> tuple[str, int, float]:
    """The column a mapping names for ``col`` (its unit from the mapping or the header)."""
    m = _HEADER.fullmatch(target)
    name, unit = (m.group(1), m.group(2)) if m else (target.strip(), None)
    if name not in header:
        raise ConfigError(f"problem.reference.columns.{col.name}", target,
                          f"a column of {path.name}; {_found(list(header))}")
    index, stated = header[name]
    if unit and stated and unit != stated:
        raise ConfigError(f"problem.reference.columns.{col.name}", target,
                          f"the unit the header states for {name} ([{stated[:20]}]) or none")
    return name, index, _factor(path, name, unit or stated, col.unit)


def _find(path: Path, header: dict[str, tuple[int, str | None]], col: Column,
          mapping: ColumnMap) -> tuple[str, int, float] | None:
    if col.name in mapping.columns:
        return _mapped(path, header, col, mapping.columns[col.name])
    return _pick(path, header, col)


def _check_mapping(mapping: ColumnMap, names: list[str], header: dict[str, Any]) -> None:
    for key, value in mapping.columns.items():
        if not isinstance(value, str) or not value.strip():
            raise ConfigError(f"problem.reference.columns.{key}", value, "a column name of "
                              "the record (a unit in brackets optional: 'road [mm]')")
        if key not in names:
            raise ConfigError(f"problem.reference.columns.{key}", mapping.columns[key],
                              "a mapping from the problem's names, one of " + ", ".join(names))
    for name in mapping.ignore:
        if name not in header:
            raise ConfigError("problem.reference.ignore", list(mapping.ignore),
                              f"columns of the record; {name!r} is not one ("
                              f"{_found(list(header))})")
    if mapping.input not in INPUT_MODES:
        raise ConfigError("problem.reference.input", mapping.input, "one of record (the "
                          "record carries the inputs), config (the configured input)")


def _inputs(path: Path, header: dict[str, Any], inputs: Sequence[Column],
            inputs_required: str | None, mapping: ColumnMap, first_row: list[str]
            ) -> list[tuple[str, int, float]]:
    """The input columns used: all of ``inputs`` (the record's) or none (the configured
    input, ``input=config``, which must be said); a partial set is refused."""
    if not inputs:
        return []
    if mapping.input == "config":
        if inputs_required:
            raise ConfigError("problem.reference.input", "config",
                              f"record here: {inputs_required}")
        return []
    got = [(_find(path, header, c, mapping), c) for c in inputs]
    absent = [c.name for p, c in got if p is None]
    if absent:
        names = ", ".join(c.name for c in inputs)
        why = inputs_required or (
            "the inputs the model is driven by: map a column with problem.reference.columns="
            f"{{{absent[0]}:<column>}}, or fit the configured input with "
            "problem.reference.input=config")
        raise _fail(path, f"input columns {names} ({why}); column {absent[0]} is missing; "
                    f"{_found(first_row)}")
    return [p for p, _ in got if p is not None]


def _unused(path: Path, header: dict[str, Any], used: list[tuple[str, int, float]],
            mapping: ColumnMap, expected: list[str], extra_ok: Sequence[str]) -> None:
    names = {u[0] for u in used}
    for name in header:
        if name not in names and name not in mapping.ignore and name not in extra_ok:
            raise ConfigError("problem.reference.file", str(path),
                              f"only the columns the problem uses, {', '.join(expected)}; "
                              f"column {name[:40]!r} is not used (map it with "
                              "problem.reference.columns, or list it in "
                              "problem.reference.ignore)")


def read_record(path: str | Path, outputs: Sequence[Column], inputs: Sequence[Column] = (),
                inputs_required: str | None = None, mapping: ColumnMap | None = None,
                extra_ok: Sequence[str] = ()) -> Record:
    """Read and check a record (see the module). ``outputs``: the measured channels, all
    required; ``inputs``: input columns, all required unless ``mapping.input`` is
    ``config``; ``inputs_required``: why the problem cannot use a configured input, or
    ``None``; ``mapping``: the user's column names and ignored columns; ``extra_ok``: columns
    a record vpid-bench wrote may carry and the problem never uses (left unread)."""
    path = Path(path)
    mapping = mapping or ColumnMap()
    need = ", ".join(["t", *(c.name for c in outputs)])
    if not path.is_file():
        raise _fail(path, f"an existing CSV file (columns {need})")
    rows = _rows(path, MAX_ROWS + 1)
    if not rows:
        raise _fail(path, f"a CSV with a header row {need} (file is empty)")
    header = _parse_header(path, rows[0])
    time_col = Column("t", "s", ("time",))
    _check_mapping(mapping, [c.name for c in (time_col, *outputs, *inputs)], header)
    time = _find(path, header, time_col, mapping)
    used = [(_find(path, header, c, mapping), c) for c in outputs]
    missing = [c.name for (p, c) in used if p is None]
    if time is None or missing:
        what = "t" if time is None else missing[0]
        raise _fail(path, f"a header with columns {need} (units optional, e.g. t [s]); "
                    f"column {what} is missing; {_found(rows[0])} (name one with "
                    f"problem.reference.columns={{{what}:<column>}})")
    got_inputs = _inputs(path, header, inputs, inputs_required, mapping, rows[0])
    cols = [time, *(p for p, _ in used), *got_inputs]
    expected = [need, *(c.name for c in inputs if mapping.input == "record")]
    _unused(path, header, cols, mapping, expected, extra_ok)
    body = [(k + 2, r) for k, r in enumerate(rows[1:]) if any(c.strip() for c in r)]
    if len(rows) > MAX_ROWS + 1:
        raise _fail(path, f"at most {MAX_ROWS} rows of samples; found more")
    if len(body) < MIN_ROWS:
        raise _fail(path, f"at least {MIN_ROWS} rows of samples; found {len(body)}")
    data = _numbers(path, body, cols)
    t = data[:, 0]
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise _fail(path, f"a t column that increases from row to row; row {body[k + 1][0]} "
                    f"has t = {t[k + 1]:.9g} s after {t[k]:.9g} s")
    p = len(outputs)
    out = np.ascontiguousarray(data[:, 1:1 + p].T)
    check_channels(path, out, [u[0] for u in cols[1:1 + p]], body)
    inp = np.ascontiguousarray(data[:, 1 + p:]) if got_inputs else None
    return Record(str(path), t.copy(), out, inp, tuple(c.name for c in inputs) if got_inputs
                  else ())


#: A number as a record cell may write it: ASCII digits, an optional sign, point and
#: exponent (no ``1_000``, no full-width or other Unicode digits, which ``float`` accepts).
NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
#: Largest magnitude of a value in SI units: beyond it a channel's norm (a sum of squares)
#: overflows, so the fit would ignore the channel.
MAX_MAGNITUDE = 1e100
#: Smallest largest magnitude of a measured channel: below it (zero or denormal) the
#: channel's weight ``1 / ||channel||`` is not a finite number.
MIN_MAGNITUDE = 1e-100
#: A channel in which one sample holds more than this fraction of the sum of squares is
#: refused, naming the sample (a logger's spike, not a vehicle's response).
MAX_SHARE = 0.5


def _numbers(path: Path, body: list[tuple[int, list[str]]],
             cols: list[tuple[str, int, float]]) -> np.ndarray:
    """The used columns of the rows as floats in SI units, ``(N, len(cols))``."""
    data = np.empty((len(body), len(cols)))
    for k, (line, row) in enumerate(body):
        for j, (name, index, factor) in enumerate(cols):
            cell = row[index].strip() if index < len(row) else ""
            if not NUMBER.fullmatch(cell):
                if cell.lower().lstrip("+-") in ("nan", "inf", "infinity"):
                    raise _fail(path, f"finite numbers; row {line} column {name} is "
                                f"{cell[:12]}")
                raise _fail(path, f"a number in column {name} of every row; row {line} has "
                            "none (ASCII digits, e.g. 1000.5 or -2e-3)")
            value = float(cell) * factor
            if not abs(value) <= MAX_MAGNITUDE:
                raise _fail(path, f"values of magnitude at most {MAX_MAGNITUDE:g} in SI "
                            f"units; row {line} column {name} is {float(cell):.6g}"
                            + (f" (x {factor:g} in SI units)" if factor != 1 else ""))
            data[k, j] = value
    return data


def check_channels(path: str | Path, out: np.ndarray, names: Sequence[str],
                   body: Sequence[tuple[int, list[str]]]) -> None:
    """Refuse a measured channel that is zero or denormal throughout (nothing to fit, its
    weight not finite) or in which one sample dominates the norm (a spike), naming it."""
    path = Path(path)
    for c, name in enumerate(names):
        y = out[c]
        peak = float(np.max(np.abs(y)))
        if peak < MIN_MAGNITUDE:
            raise _fail(path, f"a record in which every measured channel moves (column "
                        f"{name} is {'zero' if peak == 0 else 'denormal'} throughout: its "
                        f"largest value is {peak:.3g})")
        share = (y / peak) ** 2
        k = int(np.argmax(share))
        total = float(np.sum(share))
        if share[k] > MAX_SHARE * total:
            raise _fail(path, f"no single sample making up most of a channel; row "
                        f"{body[k][0]} column {name} ({y[k]:.6g}) makes up "
                        f"{100 * share[k] / total:.0f} % of its sum of squares (a logger's "
                        "spike? remove the row)")


def check_span(record: Record, dt: float, max_steps: int) -> None:
    """Refuse a record whose span needs more than ``max_steps`` model steps of ``dt`` s (a
    time column in ms read as s once asked for hours of simulation), naming the span."""
    steps = record.span / dt + 1
    if steps < MIN_ROWS:
        raise _fail(Path(record.path), f"a record spanning at least {MIN_ROWS} model steps "
                    f"(this one: t = {record.t[0]:.9g} ... {record.t[-1]:.9g} s spans "
                    f"{record.span:.3g} s, {steps:.3g} steps of dt = {dt:g} s; a time in "
                    "other units is written e.g. t [ms])")
    if steps > max_steps:
        raise _fail(Path(record.path), f"a record spanning at most {max_steps} model steps "
                    f"(this one: t = {record.t[0]:.6g} ... {record.t[-1]:.6g} s, "
                    f"{record.span:.6g} s at dt = {dt:g} s is {steps:.4g} steps; a time in ms "
                    "is written t [ms])")


class Sampler:
    """The model's steps for a record and how the model is read at the record's times.

    The model's time is the record's minus its first time; its steps are ``k dt`` for
    ``k = 0 ... K`` with ``K dt`` the first step at or past the record's last time."""

    def __init__(self, t: np.ndarray, dt: float) -> None:
        self.dt = float(dt)
        self.t0 = float(t[0])
        tau = np.asarray(t, dtype=float) - self.t0
        k = tau / self.dt
        steps = int(math.ceil(k[-1] - ON_STEP_RTOL)) + 1
        self.steps = np.arange(steps) * self.dt
        nearest = np.rint(k)
        self.on_steps = bool(np.all(np.abs(k - nearest) <= ON_STEP_RTOL))
        if self.on_steps:
            self.index = nearest.astype(np.int64)
            self.weight = np.zeros(tau.size)
        else:
            self.index = np.minimum(np.floor(k).astype(np.int64), steps - 2)
            self.weight = k - self.index
        self.identity = self.on_steps and self.index.size == steps and bool(
            np.all(self.index == np.arange(steps)))

    def at_record(self, y: np.ndarray) -> np.ndarray:
        """``y`` given on the model's steps along its last axis, at the record's times."""
        if self.identity:
            return y
        lo = np.take(y, self.index, axis=-1)
        if self.on_steps:
            return lo
        hi = np.take(y, self.index + 1, axis=-1)
        return lo + self.weight * (hi - lo)

    def onto_steps(self, t: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Input columns ``(N, r)`` given at the record's times ``t``, linearly interpolated
        onto the model's steps, ``(K + 1, r)`` (a step past the last row holds its value)."""
        tau = np.asarray(t, dtype=float) - self.t0
        return np.stack([np.interp(self.steps, tau, values[:, j])
                         for j in range(values.shape[1])], axis=1)

    def describe(self, record: Record) -> str:
        """The one info line: what was read and how the model meets it."""
        how = ("each on a model step: read there, no interpolation" if self.on_steps else
               "linear interpolation between the two model steps around each")
        inputs = (f"; inputs {', '.join(record.input_names)} from the record, interpolated "
                  "linearly onto the model's steps" if record.input_names else "")
        return (f"record {Path(record.path).name}: {record.t.size} rows, t = "
                f"{record.t[0]:.9g} ... {record.t[-1]:.9g} s ({record.rate_text()}); the "
                f"model starts at rest at the first row (t = {self.t0:.9g} s is its t = 0), "
                f"integrates at dt = {self.dt:g} s over {self.steps.size} steps and is "
                f"evaluated at the record's times ({how}){inputs}")
