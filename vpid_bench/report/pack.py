"""Making an archive (see :mod:`.archive` for what one holds and how it is read): the records and
instance optima of a finished sweep, its per-problem summary and IOHprofiler export, and the
manifest with each file's SHA-256.

Kept apart from the reader so that the report's computation (:mod:`.compute`, which reads
archives) and the packing (which computes a short report of the sweep) import each other in
one direction only: ``pack -> compute -> archive``.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import VpidBenchError
from ..store.optimum import read_optimum_data
from .archive import (
    DROPPED,
    IOH,
    JOB_FILES,
    JOBS,
    MANIFEST,
    OPTIMA,
    RECORDS,
    SCHEMA,
    SUMMARY,
    optimum_instance,
)


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _strip(record: Mapping[str, Any]) -> dict[str, Any]:
    """A record as archived: without the loader's ``_`` keys and the dependency lists."""
    def clean(obj: Any) -> Any:
        if isinstance(obj, Mapping):
            return {k: clean(v) for k, v in obj.items()
                    if k not in DROPPED and not str(k).startswith("_")}
        if isinstance(obj, list):
            return [clean(v) for v in obj]
        return obj
    return clean(record)


def compact_trace(record: Mapping[str, Any]) -> dict[str, Any]:
    """``record`` with its best-so-far trace cut to the batches that improved it (the first
    batch with a finite best, every strict improvement, and the last batch), each kept
    entry's batch number in ``trace.batch`` (1 for the first) and ``timing.trace_s`` cut
    alike. Lossless for every reading of the report: the trace is a step function, so the
    first batch at or below any level is an improvement (hits, ECDFs, ERT in evaluations,
    batches and seconds, the fixed-budget ladder), and the convergence figure and the IOH
    export draw the same steps. A run of 9,000 single-candidate batches keeps a few hundred."""
    out = dict(record)
    trace = record.get("trace")
    if not isinstance(trace, Mapping):
        return out
    ev, best = trace.get("evaluations"), trace.get("best")
    if not (isinstance(ev, list) and isinstance(best, list) and ev and len(ev) == len(best)):
        return out
    keep, last = [], None
    for i, b in enumerate(best):
        if b is not None and (last is None or b < last):
            keep.append(i)
            last = b
    if not keep or keep[-1] != len(ev) - 1:
        keep.append(len(ev) - 1)
    out["trace"] = {**trace, "evaluations": [ev[i] for i in keep],
                    "best": [best[i] for i in keep], "batch": [i + 1 for i in keep]}
    timing = record.get("timing")
    secs = timing.get("trace_s") if isinstance(timing, Mapping) else None
    if isinstance(secs, list) and len(secs) == len(ev):
        out["timing"] = {**timing, "trace_s": [secs[i] for i in keep]}
    return out


def pack(sweep_dir: Path, suite: str, out: Path, *, command: str, commit: str | None,
         made_at: str, optima_only: bool = False) -> dict[str, Any]:
    """Write the archive of the sweep in ``sweep_dir`` into ``out`` (see the module docstring)
    and return its manifest. The records and the instance optima are the sweep's own.
    ``optima_only``: ship the instance optima alone (no runs to rank beside a report's, the
    optima that ``target=`` stops at)."""
    from ..store.records import _jsonable
    from .compute import compute

    data = compute([sweep_dir], True, 0.05, "random", archive=False)
    out.mkdir(parents=True, exist_ok=True)
    found = sorted(data.loaded.records, key=lambda r: (
        r["problem"]["name"], r["optimizer"]["name"], r["run_index"]))
    records = [] if optima_only else found
    lines = "".join(json.dumps(_jsonable(compact_trace(_strip(r))), sort_keys=True,
                               allow_nan=False) + "\n" for r in records)
    with gzip.GzipFile(out / RECORDS, "wb", mtime=0) as fh:
        fh.write(lines.encode())
    from .optima import load_optima

    optima = load_optima([sweep_dir], data.loaded.records).optima
    lowest: dict[str, Any] = {}  # one per instance (jobs with folders of their own: several)
    for o in sorted(optima, key=lambda o: (o.problem, str(o.instance), o.f_opt)):
        lowest.setdefault(optimum_instance(o), o)
    (out / OPTIMA).write_text("".join(
        json.dumps(_optimum_data(o.path), sort_keys=True) + "\n"
        for o in lowest.values()), encoding="utf-8")
    job_files = [] if optima_only else _copy_job_files(found, out)
    _write_summary(out / SUMMARY, [] if optima_only else data.rows)
    _write_ioh(out / IOH, data, optima_only)
    problems = {}
    for r in found:
        p = r["problem"]
        problems.setdefault(p["name"], {"config": p.get("config"), "budget": r.get("budget"),
                                        "plugin": {k: (p.get("plugin") or {}).get(k)
                                                   for k in ("distribution", "version")}})
    from .. import __version__

    manifest = {
        "schema": SCHEMA, "suite": suite, "made_at": made_at, "command": command,
        "vpid_bench_version": __version__, "commit": commit,
        "optimizers": sorted({r["optimizer"]["name"] for r in records}),
        "runs": len(records), "problems": problems, "optima_only": optima_only,
        "files": {name: {"sha256": _sha256((out / name).read_bytes()),
                         "bytes": (out / name).stat().st_size}
                  for name in (RECORDS, OPTIMA, SUMMARY, IOH, *job_files)},
    }
    (out / MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n",
                                encoding="utf-8")
    return manifest


def _copy_job_files(records: Sequence[Mapping[str, Any]], out: Path) -> list[str]:
    """Per problem, the per-job files of its first job that has them, copied into
    ``jobs/<problem>/``; returns their names relative to ``out``."""
    import shutil

    names: list[str] = []
    done: set[str] = set()
    for r in records:
        problem = r["problem"]["name"]
        job = Path(str(r.get("_job_dir", "")))
        if problem in done or not problem.isidentifier():
            continue
        present = [f for f in JOB_FILES if (job / f).is_file() and not (job / f).is_symlink()]
        if not present:
            continue
        done.add(problem)
        (out / JOBS / problem).mkdir(parents=True, exist_ok=True)
        for f in present:
            shutil.copyfile(job / f, out / JOBS / problem / f)
            names.append(f"{JOBS}/{problem}/{f}")
    return names


SUMMARY_HEADERS = ["problem", "optimizer", "runs", "ok", "metric", "median_metric",
                   "median_rel_gap", "reached", "median_evaluations", "median_run_time_s"]


def _median(values: Sequence[float]) -> float:
    """The median of the numbers that are not NaN (NaN when none)."""
    vals = [float(v) for v in values if isinstance(v, (int, float)) and not math.isnan(v)]
    return statistics.median(vals) if vals else math.nan


def summary_rows(rows: Sequence[Mapping[str, Any]]) -> list[list[Any]]:
    """Per problem and optimizer: runs, ok runs, the headline metric's name and median, the
    median relative gap to the instance optimum, runs that reached it, median evaluations
    and run time."""
    from .optima import REACHED

    groups: dict[tuple[str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["problem"], r["algorithm"]), []).append(r)
    out = []
    for (problem, algorithm), g in sorted(groups.items()):
        ok = [r for r in g if r["status"] == "ok"]
        gaps = [float(r.get("rel_gap", math.nan)) for r in ok]
        out.append([problem, algorithm, len(g), len(ok), g[0]["metric_name"],
                    _median([r["metric"] for r in ok]), _median(gaps),
                    sum(1 for v in gaps if v <= REACHED),
                    _median([r["evaluations"] for r in ok]),
                    _median([r["run_time_s"] for r in ok])])
    return out


def _write_summary(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    from .render import write_csv

    write_csv(path, SUMMARY_HEADERS, summary_rows(rows))


def _write_ioh(path: Path, data: Any, empty: bool = False) -> None:
    """The runs in IOHprofiler's format, zipped with fixed dates (a rebuild of the same
    records gives the same bytes)."""
    import tempfile
    import zipfile

    from .ioh_export import export_ioh

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        files = [] if empty else export_ioh(root / "ioh", data.loaded.records, data.rows, root)
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            for f in sorted(files):
                info = zipfile.ZipInfo(str(f.relative_to(root)), date_time=(2026, 1, 1, 0, 0, 0))
                info.compress_type = zipfile.ZIP_DEFLATED
                zf.writestr(info, f.read_bytes())


def _optimum_data(path: Path) -> dict[str, Any]:
    """The optimum file ``path`` as its one reader takes it (it was read once already: a file
    changed since is refused, not copied)."""
    data, why = read_optimum_data(path)
    if data is None:
        raise VpidBenchError(f"optimum file {path}: {why}")
    return data
