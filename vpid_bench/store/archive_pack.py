"""Writing an archive folder (:mod:`.archive` reads it): the records and instance optima of a
finished sweep, its per-problem summary and IOHprofiler export, its jobs' files, and the
manifest with each file's SHA-256. What the summary says is the report's to compute
(:func:`vpid_bench.report.pack.pack` gathers it and calls :func:`write_archive`)."""

from __future__ import annotations

import gzip
import json
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from . import archive as arc
from .csv_table import write_csv
from .ioh import write_zip
from .optimum import Optimum
from .records import _jsonable

#: Record keys left out of an archive (each run's copy of its plugins' dependency list).
DROPPED = ("requires",)
#: The columns of ``summary.csv``: per problem and optimizer, runs, ok runs, the headline
#: metric's name and median, the median relative gap to the instance optimum, runs that
#: reached it, median evaluations and run time (s).
SUMMARY_HEADERS = ["problem", "optimizer", "runs", "ok", "metric", "median_metric",
                   "median_rel_gap", "reached", "median_evaluations", "median_run_time_s"]


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
    alike: lossless for every reading of the report (docs/protocol.md, the archive), as the
    trace is a step function. A run of 9,000 single-candidate batches keeps a few hundred.
    A trace cut already (an archived run's, packed again) comes back unchanged."""
    out = dict(record)
    trace = record.get("trace")
    if not isinstance(trace, Mapping):
        return out
    ev, best = trace.get("evaluations"), trace.get("best")
    if not (isinstance(ev, list) and isinstance(best, list) and ev and len(ev) == len(best)):
        return out
    batch = trace.get("batch")  # an archived run's trace, cut already: its batch numbers
    if not (isinstance(batch, list) and len(batch) == len(ev)):
        batch = list(range(1, len(ev) + 1))
    keep, last = [], None
    for i, b in enumerate(best):
        if b is not None and (last is None or b < last):
            keep.append(i)
            last = b
    if not keep or keep[-1] != len(ev) - 1:
        keep.append(len(ev) - 1)
    out["trace"] = {**trace, "evaluations": [ev[i] for i in keep],
                    "best": [best[i] for i in keep], "batch": [batch[i] for i in keep]}
    timing = record.get("timing")
    secs = timing.get("trace_s") if isinstance(timing, Mapping) else None
    if isinstance(secs, list) and len(secs) == len(ev):
        out["timing"] = {**timing, "trace_s": [secs[i] for i in keep]}
    return out


def write_archive(out: Path, suite: str, records: Sequence[Mapping[str, Any]],
                  rows: Sequence[Mapping[str, Any]], optima: Sequence[Optimum],
                  summary: Sequence[Sequence[Any]], *, command: str, commit: str | None,
                  made_at: str, version: str, optima_only: bool = False,
                  replaced: Sequence[Mapping[str, Any]] = ()) -> dict[str, Any]:
    """Write the archive of a sweep's ``records`` (as loaded, with their job folders) into
    ``out`` and return its manifest: the lowest of ``optima`` per instance, the
    ``summary`` rows (:data:`SUMMARY_HEADERS`) and the IOHprofiler export of the report's
    ``rows``. ``optima_only``: ship the instance optima alone (no runs to rank beside a
    report's, the optima that ``target=`` stops at). ``version``: vpid-bench's, for the
    manifest (given by the caller: the store imports nothing above it). ``replaced``: the
    sweeps whose runs replaced some optimizers' since ``command`` (optimizers, command, commit,
    made_at each), in the manifest when there are any."""
    out.mkdir(parents=True, exist_ok=True)
    found = sorted(records, key=lambda r: (
        r["problem"]["name"], r["optimizer"]["name"], r["run_index"]))
    runs = [] if optima_only else found
    lines = "".join(json.dumps(_jsonable(compact_trace(_strip(r))), sort_keys=True,
                               allow_nan=False) + "\n" for r in runs)
    with gzip.GzipFile(out / arc.RECORDS, "wb", mtime=0) as fh:
        fh.write(lines.encode())
    lowest: dict[str, Optimum] = {}  # one per instance (jobs with folders of their own: several)
    for o in sorted(optima, key=lambda o: (o.problem, str(o.instance), o.f_opt)):
        lowest.setdefault(arc.optimum_instance(o), o)
    (out / arc.OPTIMA).write_text("".join(
        json.dumps(o.data, sort_keys=True) + "\n"
        for o in lowest.values()), encoding="utf-8")
    job_files = [] if optima_only else _copy_job_files(found, out)
    write_csv(out / arc.SUMMARY, SUMMARY_HEADERS, [] if optima_only else summary)
    write_zip(out / arc.IOH, runs, [] if optima_only else rows)
    problems = {}
    for r in found:
        p = r["problem"]
        problems.setdefault(p["name"], {"config": p.get("config"), "budget": r.get("budget"),
                                        "plugin": {k: (p.get("plugin") or {}).get(k)
                                                   for k in ("distribution", "version")}})
    manifest = {
        "schema": arc.SCHEMA, "suite": suite, "made_at": made_at, "command": command,
        "vpid_bench_version": version, "commit": commit,
        "optimizers": sorted({r["optimizer"]["name"] for r in runs}),
        "runs": len(runs), "problems": problems, "optima_only": optima_only,
        **({"replaced": [dict(r) for r in replaced]} if replaced else {}),
        "files": {name: {"sha256": arc._sha256((out / name).read_bytes()),
                         "bytes": (out / name).stat().st_size}
                  for name in (arc.RECORDS, arc.OPTIMA, arc.SUMMARY, arc.IOH, *job_files)},
    }
    (out / arc.MANIFEST).write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n",
                                encoding="utf-8")
    return manifest


def _copy_job_files(records: Sequence[Mapping[str, Any]], out: Path) -> list[str]:
    """Per problem, the per-job files of its first job that has them, copied into
    ``jobs/<problem>/``; returns their names relative to ``out``."""
    names: list[str] = []
    done: set[str] = set()
    for r in records:
        problem = r["problem"]["name"]
        job = Path(str(r.get("_job_dir", "")))
        if problem in done or not problem.isidentifier():
            continue
        present = [f for f in arc.JOB_FILES if (job / f).is_file() and not (job / f).is_symlink()]
        if not present:
            continue
        done.add(problem)
        (out / arc.JOBS / problem).mkdir(parents=True, exist_ok=True)
        for f in present:
            shutil.copyfile(job / f, out / arc.JOBS / problem / f)
            names.append(f"{arc.JOBS}/{problem}/{f}")
    return names
