"""Each run judged against its instance's attainable optimum: the report's side.

A job with a problem that offers residuals and knows its truth writes, per instance, the
lowest objective value its record allows (``optima/<key>.json`` in the sweep folder, or in
the job folder for a single job; see :mod:`vpid_bench.analysis.optimum`). The report only
*reads* those files: it never polishes or simulates (result folders are untrusted input).
Every field of a file is checked; a bad file is skipped with one line naming it.

Per run, :func:`add_optimum_columns` adds to the tidy rows:

``instance``
    the instance's id (the index when ids are null: all instances identical);
``f_opt``, ``gap``, ``rel_gap``
    the instance's optimum, ``f_best - f_opt`` and ``gap / |f_opt|`` (the gap itself where
    ``f_opt`` is 0: a relative gap is undefined there);
``<metric>_floor``
    the problem's first metric of ``x*`` (e.g. ``nore_floor``): what the record allows;
``<metric>_to_opt``
    the run's distance to ``x*``, ``100 ||(x_best - x*) / x_true||`` in percent (the form of
    a norm of relative errors, measured against ``x*`` instead of the truth).

``<metric>`` is the lower-cased name of the problem's first metric, or ``rel_error`` for a
problem that reports none. A run whose ``f_best`` lies below its instance's ``f_opt`` (the
job re-polishes from every run's best, so this should not happen) keeps its negative gap and
is named in one line.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..fileio import loads_json
from ..problem import PROTOCOL_KEYS

#: The schema string of an optimum file (written by vpid_bench.analysis.optimum).
SCHEMA = "vpid-bench/instance-optimum/1"
#: A larger optimum file is not read (bytes): a real one holds a few vectors.
MAX_BYTES = 1_000_000
#: A run "reaches" its instance's optimum when its relative gap is at most this.
REACHED = 1e-6


@dataclasses.dataclass(frozen=True)
class Optimum:
    """One checked optimum file."""

    path: Path
    problem: str
    instance: str | None
    settings: Mapping[str, Any] | None
    x_opt: tuple[float, ...]
    f_opt: float
    f_true: float | None
    metrics: Mapping[str, float]
    starts: int


def _finite(v: Any) -> bool:
    return (isinstance(v, (int, float)) and not isinstance(v, bool)
            and math.isfinite(float(v)))


def check_optimum(data: Any) -> str | None:
    """The first bad field of a parsed optimum file as ``"<field>: expected ..."``, or
    ``None`` when every field the report reads is well-typed."""
    if not isinstance(data, Mapping):
        return "the file: expected a JSON object"
    checks: list[tuple[str, bool, str]] = [
        ("schema", data.get("schema") == SCHEMA, repr(SCHEMA)),
        ("problem", isinstance(data.get("problem"), str) and bool(data.get("problem")),
         "a text"),
        ("instance", data.get("instance") is None or isinstance(data.get("instance"), str),
         "a text or null"),
        ("settings", data.get("settings") is None or isinstance(data.get("settings"), Mapping),
         "a mapping or absent"),
        ("x_opt", isinstance(data.get("x_opt"), list) and len(data["x_opt"]) > 0
         and all(_finite(v) for v in data["x_opt"]), "a non-empty list of finite numbers"),
        ("f_opt", _finite(data.get("f_opt")), "a finite number"),
        ("f_true", data.get("f_true") is None or _finite(data.get("f_true")),
         "a finite number or null"),
        ("metrics", isinstance(data.get("metrics") or {}, Mapping)
         and all(isinstance(k, str) and _finite(v)
                 for k, v in (data.get("metrics") or {}).items()),
         "a mapping of names to finite numbers"),
        ("starts", isinstance(data.get("starts"), int) and not isinstance(data["starts"], bool)
         and data["starts"] >= 1, "a positive integer"),
    ]
    for name, ok, expected in checks:
        if not ok:
            return f"{name}: expected {expected}"
    return None


def read_optimum_file(path: Path) -> tuple[Optimum | None, str | None]:
    """``(optimum, None)`` for a good file, ``(None, why)`` for a bad one."""
    try:
        if path.is_symlink() or not path.is_file():
            return None, "not a regular file"
        if path.stat().st_size > MAX_BYTES:
            return None, f"larger than {MAX_BYTES} bytes"
        data = loads_json(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        return None, f"unreadable: {type(exc).__name__}"
    return optimum_from_data(data, path)


def optimum_from_data(data: Any, path: Path) -> tuple[Optimum | None, str | None]:
    """``(optimum, None)`` for parsed optimum data that passes :func:`check_optimum` (from a
    file, or a line of the archive named by ``path``), ``(None, why)`` otherwise."""
    bad = check_optimum(data)
    if bad:
        return None, f"field {bad}"
    return Optimum(path=path, problem=data["problem"], instance=data.get("instance"),
                   settings=data.get("settings"),
                   x_opt=tuple(float(v) for v in data["x_opt"]), f_opt=float(data["f_opt"]),
                   f_true=None if data.get("f_true") is None else float(data["f_true"]),
                   metrics={k: float(v) for k, v in (data.get("metrics") or {}).items()},
                   starts=int(data["starts"])), None


def optima_folders(paths: Iterable[Path], records: Sequence[Mapping[str, Any]]) -> list[Path]:
    """Where optimum files may be: ``optima/`` in every given folder, in every record's job
    folder and in the folder above it (a sweep's shared ``optima/``)."""
    found: list[Path] = []
    cands = [Path(p) / "optima" for p in paths]
    for r in records:
        job = Path(str(r.get("_job_dir", "")))
        cands += [job / "optima", job.parent / "optima"]
    for c in cands:
        try:
            if c.is_dir() and not c.is_symlink() and c.resolve() not in found:
                found.append(c.resolve())
        except OSError:
            continue
    return found


@dataclasses.dataclass
class OptimaIndex:
    """The checked optimum files found for a report, and the files skipped (with why)."""

    optima: list[Optimum]
    skipped: list[tuple[Path, str]]


def load_optima(paths: Iterable[Path], records: Sequence[Mapping[str, Any]]) -> OptimaIndex:
    """Read and check every ``optima/*.json`` in :func:`optima_folders`."""
    optima, skipped = [], []
    for folder in optima_folders(paths, records):
        for path in sorted(folder.glob("*.json")):
            opt, why = read_optimum_file(path)
            if opt is None:
                skipped.append((path, str(why)))
            else:
                optima.append(opt)
    return OptimaIndex(optima, skipped)


def _data_settings(settings: Mapping[str, Any] | None) -> str | None:
    """The settings that define an instance's data (protocol keys left out), canonical."""
    if settings is None:
        return None
    return json.dumps({k: v for k, v in settings.items() if k not in PROTOCOL_KEYS},
                      sort_keys=True, default=str)


def matching_optima(record: Mapping[str, Any], index: OptimaIndex) -> list[Optimum]:
    """Every optimum of a record's instance: files with the record's problem, instance id,
    data settings (the protocol keys ``ps``/``iterations`` do not change a record's data) and
    dimension. A file without settings matches only by a non-null instance id (the id names
    the data)."""
    problem = record["problem"]["name"]
    inst = (record.get("instance") or {}).get("id") if isinstance(
        record.get("instance"), Mapping) else None
    inst = inst if isinstance(inst, str) else None
    settings = _data_settings(record["problem"].get("config") or {})
    dim = len((record.get("parameters") or {}).get("names") or [])
    found = []
    for o in index.optima:
        if o.problem != problem or o.instance != inst or len(o.x_opt) != dim:
            continue
        if o.settings is None:
            if inst is None:
                continue
        elif _data_settings(o.settings) != settings:
            continue
        found.append(o)
    return found


def match_optimum(record: Mapping[str, Any], index: OptimaIndex) -> Optimum | None:
    """The optimum of a record's instance (:func:`matching_optima`). Several files (e.g. one
    per population size of a sweep on the same record) hold optima of the same instance: the
    lowest is the best known."""
    return min(matching_optima(record, index), key=lambda o: o.f_opt, default=None)


def column_stem(metrics: Mapping[str, float], record_metrics: Sequence[str]) -> str:
    """``<metric>`` of the column names: the problem's first metric, lower-cased, else
    ``rel_error``."""
    names = list(record_metrics) or list(metrics)
    return names[0].lower() if names else "rel_error"


def rel_gap(gap: float, f_opt: float) -> float:
    """``gap / |f_opt|``; the gap itself where ``f_opt`` is 0 (no relative scale)."""
    if not math.isfinite(gap):
        return gap
    return gap / abs(f_opt) if f_opt != 0 else gap


def distance_percent(x: Sequence[float], x_opt: Sequence[float], x_true: Sequence[float]
                     ) -> float:
    """``100 ||(x - x_opt) / x_true||`` (percent); NaN when a value is missing or a true value
    is zero."""
    try:
        terms = [100.0 * (float(a) - float(b)) / float(t)
                 for a, b, t in zip(x, x_opt, x_true, strict=True)]
    except (TypeError, ValueError, ZeroDivisionError):
        return math.nan
    if not terms or not all(math.isfinite(v) for v in terms):
        return math.nan
    return math.sqrt(sum(v * v for v in terms))


def add_optimum_columns(rows: list[dict[str, Any]], records: Sequence[Mapping[str, Any]],
                        index: OptimaIndex) -> list[str]:
    """Add the module's columns to every row (in place; NaN where no optimum is known) and
    return one line per run whose ``f_best`` lies below its instance's optimum."""
    by_id = {r["run_id"]: r for r in records}
    notes: list[str] = []
    stems: list[str] = []
    computed: list[dict[str, Any]] = []
    for row in rows:
        rec = by_id[row["run_id"]]
        inst = rec.get("instance") if isinstance(rec.get("instance"), Mapping) else {}
        iid = inst.get("id") if isinstance(inst.get("id"), str) else None
        idx = inst.get("index")
        label = iid if iid is not None else (idx if isinstance(idx, int) and not isinstance(
            idx, bool) else row["run_index"])
        opt = match_optimum(rec, index)
        extra: dict[str, Any] = {"instance": label, "f_opt": math.nan, "gap": math.nan,
                                 "rel_gap": math.nan, "opt_on_edge": math.nan}
        if opt is not None:
            mnames = list(((rec.get("result") or {}).get("metrics") or {}).keys())
            mname = mnames[0] if mnames else next(iter(opt.metrics), None)
            stem = column_stem(opt.metrics, [mname] if mname else [])
            if stem not in stems:
                stems.append(stem)
            extra["f_opt"] = opt.f_opt
            extra["opt_on_edge"] = on_edge(opt.x_opt, rec.get("parameters") or {})
            if row["status"] == "ok":
                gap = float(row["f_best"]) - opt.f_opt
                extra["gap"], extra["rel_gap"] = gap, rel_gap(gap, opt.f_opt)
                if gap < 0:
                    notes.append(
                        f"run {row['run_index']} of {row['algorithm']} on {row['context']} ends "
                        f"below its instance's optimum (f_best {row['f_best']:.6g} < f_opt "
                        f"{opt.f_opt:.6g}, gap {gap:.3g}; file {opt.path.name}): the optimum "
                        "file is stale or not this record's")
            true = (rec.get("parameters") or {}).get("true") or []
            if mname is None:
                floor = distance_percent(opt.x_opt, true, true) if true else math.nan
            else:
                floor = opt.metrics.get(mname, math.nan)
            extra[f"{stem}_floor"] = floor
            x = ((rec.get("result") or {}).get("x_best") or []) if row["status"] == "ok" else []
            extra[f"{stem}_to_opt"] = (distance_percent(x, opt.x_opt, true)
                                       if x and true else math.nan)
        computed.append(extra)
    cols = ["instance", "f_opt", "gap", "rel_gap"]
    for s in stems:
        cols += [f"{s}_floor", f"{s}_to_opt"]
    cols.append("opt_on_edge")
    for row, extra in zip(rows, computed, strict=True):
        new = {}
        for k, v in row.items():
            new[k] = v
            if k == "metric_name":
                new.update({c: extra.get(c, math.nan) for c in cols})
        row.clear()
        row.update(new)
    return notes


#: A parameter of an optimum within this fraction of the box width of a bound is on the edge.
EDGE_RTOL = 1e-6


def on_edge(x_opt: Sequence[float], params: Mapping[str, Any]) -> float:
    """1.0 when a parameter of ``x_opt`` lies on the record's box edge (within
    :data:`EDGE_RTOL` of the width), 0.0 when none does, NaN when the record's bounds are not
    readable: the box then holds the optimum, and its error is cut by the box."""
    lo, hi = params.get("lower"), params.get("upper")
    n = len(x_opt)
    if not (isinstance(lo, list) and isinstance(hi, list) and len(lo) == len(hi) == n
            and all(_finite(v) for v in (*lo, *hi))):
        return math.nan
    return float(any(min(x - a, b - x) <= EDGE_RTOL * (b - a)
                     for x, a, b in zip(x_opt, lo, hi, strict=True)))


def opt_column_names(rows: Sequence[Mapping[str, Any]]) -> tuple[str | None, str | None]:
    """The ``(<metric>_floor, <metric>_to_opt)`` columns present in the rows (first seen)."""
    for r in rows:
        for k in r:
            if k.endswith("_floor") and f"{k[:-6]}_to_opt" in r:
                return k, f"{k[:-6]}_to_opt"
    return None, None
