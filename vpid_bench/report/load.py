"""Read the run records below any folders (a corrupt file is named and skipped; a run given
twice is kept once) into one tidy table, a row per run, grouped by ``context`` (the problem,
``ps`` and every problem setting that varies across the records, the budget too) and
``algorithm`` (the optimizer, with its own varying parameters: ``de1[F=0.5]``). Runs of
different seeds are pooled."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import VpidBenchError
from ..problem import FILLED_PARAMS
from ..store.job_status import read_job_status
from ..store.record_check import check_record
from ..store.records import CorruptRecordError, decode_number, iter_record_files, read_record
from .safe import clean

#: Records, or rows of the run table: read-only mappings.
Rows = Sequence[Mapping[str, Any]]
#: Problem-config keys that never define a context of their own (ps, the problem's protocol
#: as its record states it under ``problem.config``, is the context's first token).
PROBLEM_KEYS_IGNORED = ("ps",)
#: Optimizer parameters that never distinguish algorithm variants (the protocol and the
#: budget the job fills in; records of older versions may hold them under the optimizer).
OPTIMIZER_KEYS_IGNORED = FILLED_PARAMS


class NoRecordsError(VpidBenchError):
    """No run record was found below the given paths."""


@dataclasses.dataclass
class LoadedRecords:
    """The records found below some paths, with what was skipped and the jobs' statuses."""

    records: list[dict[str, Any]]
    skipped: list[tuple[Path, str]]
    duplicates: int
    job_status: dict[Path, dict[str, Any] | None]

    @property
    def failed_jobs(self) -> list[tuple[Path, str]]:
        """Jobs whose ``job.json`` says anything but ``ok`` (or that have none), with why."""
        out = []
        for job_dir, status in sorted(self.job_status.items()):
            if status is None:
                out.append((job_dir, "no job.json (the job did not finish)"))
            elif status.get("status") != "ok":
                detail = status.get("detail")
                if isinstance(detail, Mapping) and detail.get("failed"):
                    detail = f"failed runs {detail['failed']}"
                out.append((job_dir, f"{status.get('status')}: {detail}"))
        return out

    @property
    def failures(self) -> list[str]:
        """One line per failed job, failed run or unreadable record file (each names it)."""
        out = [f"job {d}: {why}" for d, why in self.failed_jobs]
        out += [why if why.startswith(f"archive {p}:") else  # an archive that names itself
                f"unreadable record {p}: {reason(p, why)}" for p, why in self.skipped]
        failed_runs = [r for r in self.records if r["status"] != "ok"]
        if failed_runs and not self.failed_jobs:
            out.append(f"{len(failed_runs)} failed run(s) in the records")
        return out


def grouped(items: Iterable[Any], key: Callable[[Any], Any]) -> dict[Any, list[Any]]:
    """``items`` grouped by ``key(item)``, in order of appearance."""
    out: dict[Any, list[Any]] = {}
    for s in items:
        out.setdefault(key(s), []).append(s)
    return out


def by_context(items: Iterable[Any]) -> dict[str, list[Any]]:
    """``items`` (mappings with a ``context``) grouped by it, in order of appearance."""
    return grouped(items, lambda s: s["context"])


def reason(path: Path, why: str) -> str:
    """``why`` without a leading ``path: `` (a :class:`CorruptRecordError` names its file,
    and the lines that quote it name the file already)."""
    return why.removeprefix(f"{path}: ")


def load_records(paths: Iterable[str | Path]) -> LoadedRecords:
    """Read every run record below ``paths`` (files or folders, any number, merged)."""
    paths = [Path(p) for p in paths]
    records: list[dict[str, Any]] = []
    skipped: list[tuple[Path, str]] = []
    seen: set[str] = set()
    seen_files: set[Path] = set()
    duplicates = 0
    # jobs that ended with no records hold a job.json too
    job_dirs = {p.parent for p in paths if p.is_file() and p.name == "job.json"}
    job_dirs.update(j.parent for p in paths if p.is_dir() for j in p.rglob("job.json"))
    for path in iter_record_files(paths):
        resolved = path.resolve()
        if resolved in seen_files:
            continue
        seen_files.add(resolved)
        try:
            record = read_record(path)
        except CorruptRecordError as exc:
            skipped.append((path, str(exc)))
            continue
        bad = check_record(record, path.name)
        if bad:
            skipped.append((path, f"field {bad}"))
            continue
        job_dirs.add(path.parent.parent)
        if record["run_id"] in seen:
            duplicates += 1
            continue
        seen.add(record["run_id"])
        records.append({**record, "_file": str(path), "_job_dir": str(path.parent.parent)})
    statuses = {d: read_job_status(d) for d in sorted(job_dirs)}
    return LoadedRecords(records, skipped, duplicates, statuses)


def flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    """Nested mappings as one level, keys joined with dots; lists become tuples."""
    if isinstance(obj, Mapping):
        return {key: v for k, value in obj.items()
                for key, v in flatten(value, f"{prefix}{k}.").items()}
    return {prefix[:-1]: tuple(obj) if isinstance(obj, list) else obj}


def _varying(rows: list[dict[str, Any]]) -> list[str]:
    """Keys whose value is not the same in every row (a missing key counts as a value)."""
    keys = sorted({k for r in rows for k in r})
    return [k for k in keys if len({repr(r.get(k, "<missing>")) for r in rows}) > 1]


def _fmt(value: Any) -> str:
    if isinstance(value, float) and value.is_integer():
        return f"{value:g}"
    return str(value)


def _settings(r: Mapping[str, Any]) -> dict[str, Any]:
    """A record's problem settings, flat, with its budget."""
    return {**flatten(r["problem"].get("config") or {}), "budget": r.get("budget")}


def grouping(records: list[dict[str, Any]]) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """Varying problem keys per problem name, and varying optimizer keys per optimizer name."""
    problems = grouped(records, lambda r: r["problem"]["name"])
    optimizers = grouped(records, lambda r: r["optimizer"]["name"])
    return ({p: _varying([{k: v for k, v in _settings(r).items() if k not in PROBLEM_KEYS_IGNORED}
                          for r in rs]) for p, rs in problems.items()},
            {o: _varying([{k: v for k, v in flatten(r["optimizer"].get("params") or {}).items()
                           if k not in OPTIMIZER_KEYS_IGNORED} for r in rs])
             for o, rs in optimizers.items()})


#: Context keys left out of the label when the population size and the other varying keys
#: already determine them (e.g. the budget of ``ps * (iterations + 1)`` when ps varies).
IMPLIED_KEYS = ("budget", "iterations")


def _drop_implied(records: list[dict[str, Any]], keys: dict[str, list[str]]
                  ) -> dict[str, list[str]]:
    """``keys`` without the implied keys that ps and the other varying keys determine."""
    out = {}
    for pname, varying in keys.items():
        kept = list(varying)
        for key in IMPLIED_KEYS:
            if key not in kept:
                continue
            others = [k for k in kept if k not in IMPLIED_KEYS]
            seen: dict[str, set[str]] = {}
            for r in records:
                if r["problem"]["name"] != pname:
                    continue
                pflat = _settings(r)
                ident = repr((pflat.get("ps"), [pflat.get(k) for k in others]))
                seen.setdefault(ident, set()).add(repr(pflat.get(key)))
            if all(len(v) == 1 for v in seen.values()):
                kept.remove(key)
        out[pname] = kept
    return out


@dataclasses.dataclass(frozen=True)
class RunLabel:
    """Where a run belongs: its context, algorithm, population size and varying keys."""

    context: str
    algorithm: str
    ps: Any
    problem_vary: dict[str, Any]
    optimizer_vary: dict[str, Any]


def run_labels(records: list[dict[str, Any]]) -> list[RunLabel]:
    """The context and algorithm of every record (see the module docstring), in order."""
    problem_keys, optimizer_keys = grouping(records)
    problem_keys = _drop_implied(records, problem_keys)
    out = []
    for r in records:
        pname = r["problem"]["name"]
        oname = r["optimizer"]["name"]
        pflat = _settings(r)
        oflat = flatten(r["optimizer"].get("params") or {})
        ps = pflat.get("ps")
        pvary = {k: pflat.get(k) for k in problem_keys[pname]}
        ovary = {k: oflat.get(k) for k in optimizer_keys[oname]}
        # labels every renderer shows (tables, figures, the terminal): one printable line
        context = clean(f"{pname} ps={_fmt(ps)}"
                        + "".join(f" {k}={_fmt(v)}" for k, v in pvary.items()))
        params = ",".join(f"{k}={_fmt(v)}" for k, v in ovary.items())
        algorithm = clean(oname + (f"[{params}]" if ovary else ""))
        out.append(RunLabel(context, algorithm, ps, pvary, ovary))
    return out


def _num(value: Any, missing: float = math.inf) -> float:
    """A record number as float (``-inf`` stays ``-inf``); ``None`` becomes ``missing``."""
    if value is None:
        return missing
    return float(decode_number(value))


def _metrics(record: Mapping[str, Any]) -> dict[str, float]:
    """``result.metrics`` of an ok record, ``null`` (non-finite) as ``inf``."""
    res = record.get("result") or {}
    return {str(k): _num(v) for k, v in (res.get("metrics") or {}).items()}


def choose_metrics(records: list[dict[str, Any]], labels: list[RunLabel]) -> dict[str, str]:
    """Per context, the headline metric: the first of the problem's metrics (in the order of
    the context's first ok record) that every ok run of the context has; else ``f_best``."""
    common: dict[str, list[str]] = {}
    for r, lab in zip(records, labels, strict=True):
        if r["status"] == "ok" and r.get("result"):
            keys = (r["result"].get("metrics") or {}).keys()
            common[lab.context] = [k for k in common.get(lab.context, keys) if k in keys]
    return {lab.context: next(iter(common.get(lab.context, [])), "f_best") for lab in labels}


def metric_unit(record: Mapping[str, Any], name: str) -> str:
    """The unit of metric ``name`` the problem states (``problem.info.metric_units``), or ``""``."""
    info = (record.get("problem") or {}).get("info")
    units = info.get("metric_units") if isinstance(info, Mapping) else None
    unit = units.get(name) if isinstance(units, Mapping) else None
    return unit if isinstance(unit, str) and len(unit) <= 16 and unit.isprintable() else ""


def run_rows(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The tidy table of all runs as plain rows (no pandas: the single job's report uses it),
    sorted by context, algorithm, seed and run index: one column per varying setting
    (``problem.<key>``, ``optimizer.<key>``), ``metric.<name>`` per metric, ``metric`` (the
    context's headline, :func:`choose_metrics`), ``x.``/``eps.`` (%)/``true.<param>``, ...
    Failed runs have NaN results; a ``null`` objective or metric is ``inf``."""
    labels = run_labels(records)
    chosen = choose_metrics(records, labels)
    metric_names = list(dict.fromkeys(k for r in records for k in _metrics(r)))
    rows = []
    for r, lab in zip(records, labels, strict=True):
        res = r.get("result") or {}
        ok = r["status"] == "ok" and bool(res)
        timing = r.get("timing") or {}
        error = r.get("error") or {}
        mets = _metrics(r) if ok else {}
        f = _num(res.get("f_best")) if ok else math.nan
        name = chosen[lab.context]
        row: dict[str, Any] = {
            "context": lab.context, "problem": clean(r["problem"]["name"]), "ps": lab.ps,
            "algorithm": lab.algorithm, "optimizer": clean(r["optimizer"]["name"]),
            **{clean(f"problem.{k}"): clean(_fmt(v)) for k, v in lab.problem_vary.items()
               if k != "budget"},
            **{clean(f"optimizer.{k}"): clean(_fmt(v)) for k, v in lab.optimizer_vary.items()},
            "seed": (r.get("seeds") or {}).get("seed"), "run_index": r.get("run_index"),
            "status": r["status"], "f_best": f,
            **{f"metric.{k}": mets.get(k, math.nan) for k in metric_names},
            "metric": (f if name == "f_best" else mets.get(name, math.inf)) if ok else math.nan,
            "metric_name": name, "metric_unit": metric_unit(r, name),
            "evaluations": res.get("evaluations", math.nan) if ok else math.nan,
            "budget": r.get("budget"),
            "wall_time_s": _num(timing.get("wall_time_s"), math.nan),
            "run_time_s": _num(timing.get("run_time_s"), math.nan),
            "stopped_by": res.get("stopped_by") if ok else None,
            "error": (f"{error.get('type')}: {error.get('message')}" if error else None)}
        params = r.get("parameters") or {}
        names = params.get("names") or []
        n = len(names)
        x = res.get("x_best") if ok and len(res.get("x_best") or []) == n else [None] * n
        eps = res.get("rel_error_percent") if ok else None
        eps = eps if eps is not None and len(eps) == n else [None] * n
        true = params.get("true")
        true = true if true is not None and len(true) == n else [None] * n
        for pname, xi, ei, ti in zip([clean(n) for n in names], x, eps, true, strict=True):
            row[f"x.{pname}"] = _num(xi, math.nan) if ok else math.nan
            row[f"eps.{pname}"] = _num(ei, math.nan) if ok else math.nan
            row[f"true.{pname}"] = _num(ti, math.nan)
        row["run_id"] = r["run_id"]
        row["file"] = r.get("_file")
        rows.append(row)
    return sorted(rows, key=lambda row: (row["context"], row["algorithm"],
                                         _sort_key(row["seed"]), _sort_key(row["run_index"])))


def _sort_key(value: Any) -> tuple[int, Any]:
    return (0, value) if isinstance(value, int) else (1, str(value))


def runs_frame(rows: list[dict[str, Any]]) -> Any:
    """:func:`run_rows` as a pandas DataFrame (the full report's tests and figures)."""
    import pandas as pd

    return pd.DataFrame(rows)


def trace_sets(records: list[dict[str, Any]], rows: list[dict[str, Any]]
               ) -> dict[str, dict[str, list[tuple[np.ndarray, np.ndarray]]]]:
    """Best-so-far traces of the successful runs in ``rows``: ``out[context][algorithm]``, a
    list of (evaluations, best) arrays in the order of ``rows`` (``null`` as NaN)."""
    by_id = {r["run_id"]: r for r in records}
    out: dict[str, dict[str, list[tuple[np.ndarray, np.ndarray]]]] = {}
    for row in rows:
        r = by_id.get(row["run_id"])
        if r is None or r["status"] != "ok":
            continue
        trace = r.get("trace") or {}
        ev, best = trace.get("evaluations") or [], trace.get("best") or []
        if not ev:
            continue
        out.setdefault(row["context"], {}).setdefault(row["algorithm"], []).append((
            np.asarray(ev, dtype=float),
            np.array([np.nan if b is None else b for b in best], dtype=float)))
    return out


def first_file_by_context(records: Rows, rows: Rows, name: str,
                          read: Callable[[Path, Mapping[str, Any]], Any]) -> dict[str, Any]:
    """Per context, the first file ``name`` of its jobs (each tried once) that
    ``read(path, record)`` accepts (returns other than ``None``)."""
    out: dict[str, Any] = {}
    by_id = {r["run_id"]: r for r in records}
    tried: set[Path] = set()
    for row in rows:
        context, rec = row["context"], by_id[row["run_id"]]
        path = Path(str(rec.get("_job_dir", "."))) / name
        if context in out or path in tried:
            continue
        tried.add(path)
        data = read(path, rec)
        if data is not None:
            out[context] = data
    return out
