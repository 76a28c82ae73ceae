"""Files a job writes beside its run records for the report: ``best_signals.csv``.

The report never rebuilds a problem from an (untrusted) record; the job, which has the
problem at hand, writes what a figure needs: the measured and fitted signals of its best run
(:meth:`~vpid_bench.api.Problem.signals`), with each channel's unit.

``best_signals.csv`` (UTF-8): the line :data:`MAGIC`, then ``# source: {JSON}`` (which run)
and ``# units: {JSON}``, then a CSV table: ``t`` (s), ``<channel>:measured``,
``<channel>:fitted``, ... (non-finite values as ``nan``).
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import loads_json, read_text_limited, write_text_atomic

BEST_SIGNALS = "best_signals.csv"
MAGIC = "# vpid-bench best signals 1"
#: A best_signals.csv larger than this is refused by the reader (bytes).
MAX_BYTES = 50_000_000


class BadArtifactError(ValueError):
    """A job artifact exists but is not what its writer writes."""


@dataclass(frozen=True)
class BestSignals:
    """A ``best_signals.csv``: times ``t`` (s), ``channels[name] = (measured, fitted)``
    (either may be ``None``), units per channel, and ``source`` (which run)."""

    t: np.ndarray
    channels: dict[str, tuple[np.ndarray | None, np.ndarray | None]]
    units: dict[str, str]
    source: dict[str, Any]


def best_of(records: Iterable[Mapping[str, Any]]) -> tuple[np.ndarray, dict[str, Any]] | None:
    """The best vector among the ok ``records`` with a numeric one and where it comes from
    (``run_index``, ``f_best``, ``ranked_by``, ``value``), or ``None``: the lowest first
    metric when every ok record has it, else the lowest ``f_best``."""
    runs = []
    for r in records:
        res = r.get("result")
        if r.get("status") != "ok" or not isinstance(res, Mapping):
            continue
        x = res.get("x_best")
        if not isinstance(x, list) or not x or any(not isinstance(v, (int, float)) for v in x):
            continue
        runs.append((r, res))
    if not runs:
        return None
    names = [list((res.get("metrics") or {}).keys()) for _, res in runs]
    metric = names[0][0] if names[0] and all(names[0][0] in n for n in names) else None

    def value(res: Mapping[str, Any]) -> float:
        v = (res.get("metrics") or {}).get(metric) if metric else res.get("f_best")
        return math.inf if v is None else float(v)

    r, res = min(runs, key=lambda item: value(item[1]))
    source = {"run_index": r.get("run_index"), "f_best": res.get("f_best"),
              "ranked_by": metric or "f_best", "value": value(res)}
    return np.asarray(res["x_best"], dtype=float), source


def write_best_signals(job_dir: Path, problem: Any, x: np.ndarray,
                       source: Mapping[str, Any] | None = None) -> Path | None:
    """Write ``job_dir/best_signals.csv`` from ``problem.signals(x)`` atomically; ``None``
    (nothing written) when the problem has no signals. ``source``: which run ``x`` is."""
    sig = problem.signals(np.asarray(x, dtype=float))
    if not sig or "t" not in sig:
        return None
    t = np.asarray(sig["t"], dtype=float).reshape(-1)
    keys = [k for k in sig if k != "t"]
    cols = [t] + [np.asarray(sig[k], dtype=float).reshape(-1) for k in keys]
    if any(c.shape != t.shape for c in cols):
        raise ValueError(f"problem {problem.name!r}: every signal must have the length of t")
    units = {"t": "s", **{str(k): str(v) for k, v in problem.signal_units().items()}}
    clean_source = {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                    for k, v in (source or {}).items()}
    buf = io.StringIO()
    buf.write(f"{MAGIC}\n# source: {json.dumps(clean_source)}\n# units: {json.dumps(units)}\n")
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["t", *keys])
    for row in np.column_stack(cols):
        writer.writerow([repr(float(v)) for v in row])
    return write_text_atomic(Path(job_dir) / BEST_SIGNALS, buf.getvalue())


def read_best_signals(path: Path, max_bytes: int = MAX_BYTES) -> BestSignals:
    """Read and check a (untrusted) ``best_signals.csv``: :class:`BadArtifactError` naming
    the file for a missing, oversized or malformed one."""
    path = Path(path)

    def bad(why: str) -> BadArtifactError:
        return BadArtifactError(f"{path}: not a best-signals file ({why})")

    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise bad(f"{size} bytes, more than {max_bytes}")
        text = read_text_limited(path, max_bytes)
    except (OSError, UnicodeDecodeError) as exc:
        raise bad(str(exc)) from exc
    lines = text.splitlines()
    if len(lines) < 5 or lines[0] != MAGIC:
        raise bad("no header")
    meta = {}
    for line, key in ((lines[1], "source"), (lines[2], "units")):
        prefix = f"# {key}: "
        try:
            value = loads_json(line[len(prefix):]) if line.startswith(prefix) else None
        except json.JSONDecodeError:
            value = None
        if not isinstance(value, dict):
            raise bad(f"line '{key}' is not a JSON object")
        meta[key] = value
    rows = list(csv.reader(lines[3:]))
    header = rows[0]
    if not header or header[0] != "t" or len(set(header)) != len(header):
        raise bad("the first column must be t and column names unique")
    channels: dict[str, dict[str, np.ndarray]] = {}
    try:
        data = np.array([[float(v) for v in row] for row in rows[1:]], dtype=float)
    except ValueError as exc:
        raise bad(f"a value is not a number: {exc}") from exc
    if data.ndim != 2 or data.shape[1] != len(header):
        raise bad("rows of different lengths")
    for j, name in enumerate(header[1:], start=1):
        channel, sep, kind = name.rpartition(":")
        if not sep or not channel or kind not in ("measured", "fitted"):
            raise bad(f"column {name!r} is not <channel>:measured or <channel>:fitted")
        channels.setdefault(channel, {})[kind] = data[:, j]
    units = {str(k): str(v) for k, v in meta["units"].items() if isinstance(v, str)}
    return BestSignals(data[:, 0], {c: (d.get("measured"), d.get("fitted"))
                                    for c, d in channels.items()}, units, meta["source"])
