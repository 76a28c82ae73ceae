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

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..store.optimum import (  # noqa: F401  (the file format's home; names kept here)
    MAX_BYTES,
    SCHEMA,
    OptimaIndex,
    Optimum,
    _data_settings,
    _finite,
    check_optimum,
    match_optimum,
    matching_optima,
    optimum_from_data,
    read_optimum_file,
)

#: A run "reaches" its instance's optimum when its relative gap is at most this.
REACHED = 1e-6


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
