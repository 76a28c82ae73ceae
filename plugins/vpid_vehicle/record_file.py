"""A vehicle's own record (``problem.reference.file``, docs/own-record.md#the-file) through
vpid-bench's one CSV reader: the channels' column names, the units a vehicle logger writes
(converted to SI), the inputs (from the record, or the configured input where
``problem.reference.input=config`` says so; never a silent fallback), and how the model,
at rest at the first row and integrating at its own ``dt``, is read at the record's times
(:class:`Sampler`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vpid_bench import ColumnMap, ConfigError, CsvRecord, CsvTable
from vpid_bench import RecordColumn as Column

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
#: ``problem.reference.input`` values.
INPUT_MODES = ("record", "config")


@dataclasses.dataclass(frozen=True)
class Record(CsvRecord):
    """Times (s, as in the file), outputs ``(p, N)``, inputs ``(N, r)`` or ``None``; SI."""

    outputs: np.ndarray
    inputs: np.ndarray | None
    input_names: tuple[str, ...]


def column_name(channel: str) -> str:
    """A channel's CSV column name: ``''`` as ``dd``, ``'`` as ``d``, ``-`` as ``_``."""
    return channel.replace("''", "dd").replace("'", "d").replace("-", "_")


def read_record(path: str | Path, outputs: Sequence[Column], inputs: Sequence[Column] = (),
                inputs_required: str | None = None, mapping: ColumnMap | None = None,
                extra_ok: Sequence[str] = (), input_mode: str = "record") -> Record:
    """Read and check a record: ``outputs`` all required; ``inputs`` too unless
    ``input_mode`` is ``config`` (then none is read); ``inputs_required``: why the configured
    input cannot serve, or ``None``; ``mapping``: the user's names and ignored columns;
    ``extra_ok``: columns a record vpid-bench wrote may carry, left unread."""
    if input_mode not in INPUT_MODES:
        raise ConfigError("problem.reference.input", input_mode, "one of record (the record "
                          "carries the inputs), config (the configured input)")
    if inputs and input_mode == "config" and inputs_required:
        raise ConfigError("problem.reference.input", "config", f"record here: {inputs_required}")
    table = CsvTable(path, outputs, inputs, mapping, UNITS)
    read = tuple(inputs) if input_mode == "record" else ()
    names = [c.name for c in read]
    got = [table.find(c) for c in read]
    absent = [n for n, f in zip(names, got, strict=True) if f is None]
    if absent:
        why = inputs_required or (
            "the inputs the model is driven by: map a column with problem.reference.columns="
            f"{{{absent[0]}:<column>}}, or fit the configured input with "
            "problem.reference.input=config")
        raise table.fail(f"input columns {', '.join(names)} ({why}); column {absent[0]} is "
                         f"missing; {table.found()}")
    allowed = [c.name for c in (table.columns[0], *outputs, *read)]
    t, out, inp = table.read(table.required, [f for f in got if f], allowed, extra_ok)
    return Record(str(path), t, out, inp if read else None, tuple(names))


def check_span(record: Record, dt: float, max_steps: int) -> None:
    """Refuse a span of too few or more than ``max_steps`` model steps of ``dt`` s, naming it."""
    steps = record.span / dt + 1
    least = CsvTable.MIN_ROWS
    if steps < least:
        raise ConfigError("problem.reference.file", record.path, f"a record spanning at "
                          f"least {least} model steps (this one: t = {record.t[0]:.9g} ... "
                          f"{record.t[-1]:.9g} s spans {record.span:.3g} s, {steps:.3g} steps "
                          f"of dt = {dt:g} s; a time in other units is written e.g. t [ms])")
    if steps > max_steps:
        raise ConfigError("problem.reference.file", record.path, f"a record spanning at most "
                          f"{max_steps} model steps (this one: t = {record.t[0]:.6g} ... "
                          f"{record.t[-1]:.6g} s, {record.span:.6g} s at dt = {dt:g} s is "
                          f"{steps:.4g} steps; a time in ms is written t [ms])")


class Sampler:
    """The model's steps ``k dt``, ``k = 0 ... K`` (``K dt`` the first at or past the last
    row; model time = record time minus the first), and how the model is read at the rows."""

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
        """Input columns ``(N, r)`` at the times ``t`` linearly onto the model's steps."""
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
