"""Each run judged against its instance's optimum, read (never computed) from the optimum
files the jobs wrote (``optima/<key>.json``, :mod:`vpid_bench.store.optimum`; a bad file is
skipped with one line). :func:`add_optimum_columns` adds to each row ``instance``, ``f_opt``,
``gap``, ``rel_gap`` (``gap / |f_opt|``; the gap itself where ``f_opt`` is 0),
``<metric>_floor`` (the problem's first metric of ``x*``, lower-cased, or ``rel_error``) and
``<metric>_to_opt`` (``100 ||(x_best - x*) / x_true||``, %). A run below its optimum keeps
its negative gap and is named in one line."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..store.optimum import OptimaIndex, _finite, match_optimum, read_optimum_file

#: A run "reaches" its instance's optimum when its relative gap is at most this.
REACHED = 1e-6


def optima_folders(paths: Iterable[Path], records: Sequence[Mapping[str, Any]]) -> list[Path]:
    """``optima/`` in every given folder, every record's job folder and the folder above."""
    found: list[Path] = []
    jobs = [Path(str(r.get("_job_dir", ""))) for r in records]
    cands = [Path(p) / "optima" for p in paths]
    cands += [f / "optima" for j in jobs for f in (j, j.parent)]  # each job's and the one above
    for c in cands:
        try:
            if c.is_dir() and not c.is_symlink() and c.resolve() not in found:
                found.append(c.resolve())
        except OSError:
            continue
    return found


def load_optima(paths: Iterable[Path], records: Sequence[Mapping[str, Any]]) -> OptimaIndex:
    """Read and check every ``optima/*.json`` in :func:`optima_folders`."""
    read = [(path, *read_optimum_file(path)) for folder in optima_folders(paths, records)
            for path in sorted(folder.glob("*.json"))]
    return OptimaIndex([opt for _, opt, _ in read if opt is not None],
                       [(path, str(why)) for path, opt, why in read if opt is None])


def rel_gap(gap: float, f_opt: float) -> float:
    """``gap / |f_opt|``; the gap itself where ``f_opt`` is 0 (no relative scale)."""
    if not math.isfinite(gap):
        return gap
    return gap / abs(f_opt) if f_opt != 0 else gap


def distance_percent(x: Sequence[float], x_opt: Sequence[float], x_true: Sequence[float]) -> float:
    """``100 ||(x - x_opt) / x_true||`` (%); NaN when a value is missing or a truth zero."""
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
    """Add the module's columns to every row (in place; NaN where no optimum is known);
    return one line per run below its instance's optimum."""
    by_id = {r["run_id"]: r for r in records}
    notes: list[str] = []
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
            stem = (mname or next(iter(opt.metrics), "rel_error")).lower()  # of the columns
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
    stems = dict.fromkeys(k for e in computed for k in e if k.endswith(("_floor", "_to_opt")))
    cols = ["instance", "f_opt", "gap", "rel_gap", *stems, "opt_on_edge"]
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
    """1.0 when a parameter of ``x_opt`` lies on the box's edge (the box holds the optimum:
    its error is cut), 0.0 when none does, NaN when the bounds are not readable."""
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
