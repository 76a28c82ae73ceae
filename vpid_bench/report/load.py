"""Read run records from any set of job or sweep folders into one tidy table.

Every ``records/run-*.json`` below the given paths is read; a corrupt file is listed by name
and skipped, never fatal. Records that appear twice (the same ``run_id``, e.g. the same folder
given twice or one sweep copied into another) are kept once.

The tidy table has one row per run. Runs are grouped for comparison by:

* ``context``: what the optimizers are compared on: the problem, the population size ``ps``
  and any problem-config key that varies across the records (e.g. a noise level or noise
  seed), plus the budget when it varies;
* ``algorithm``: the optimizer name, plus any of its own parameters that vary across that
  optimizer's records (e.g. ``de1[F=0.5]``).

The top-level ``seed`` is not a grouping key: runs of different seeds are independent runs
of the same optimizer and are pooled.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..api import VpidBenchError
from ..records import CorruptRecordError, iter_record_files, read_job_status, read_record

#: Problem-config keys that never define a context of their own (ps is taken from the optimizer).
PROBLEM_KEYS_IGNORED = ("ps",)
#: Optimizer parameters that never distinguish algorithm variants (they are the protocol).
OPTIMIZER_KEYS_IGNORED = ("ps", "iterations")


class NoRecordsError(VpidBenchError):
    """No run record was found below the given paths."""


@dataclasses.dataclass
class LoadedRecords:
    """The records found below some paths, with what was skipped and the jobs' statuses."""

    records: list[dict[str, Any]]
    files: list[Path]
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
        out += [f"unreadable record {p}: {reason(p, why)}" for p, why in self.skipped]
        failed_runs = [r for r in self.records if r["status"] != "ok"]
        if failed_runs and not self.failed_jobs:
            out.append(f"{len(failed_runs)} failed run(s) in the records")
        return out


def reason(path: Path, why: str) -> str:
    """``why`` without a leading ``path: `` (a :class:`CorruptRecordError` names its file,
    and the lines that quote it name the file already)."""
    prefix = f"{path}: "
    return why[len(prefix):] if why.startswith(prefix) else why


def _job_dirs_below(paths: Iterable[Path]) -> set[Path]:
    """Folders below ``paths`` that hold a ``job.json`` (jobs that ended with no records)."""
    found = set()
    for p in paths:
        p = Path(p)
        if p.is_file() and p.name == "job.json":
            found.add(p.parent)
        elif p.is_dir():
            found.update(j.parent for j in p.rglob("job.json"))
    return found


def load_records(paths: Iterable[str | Path]) -> LoadedRecords:
    """Read every run record below ``paths`` (files or folders, any number, merged)."""
    paths = [Path(p) for p in paths]
    records: list[dict[str, Any]] = []
    files: list[Path] = []
    skipped: list[tuple[Path, str]] = []
    seen: set[str] = set()
    seen_files: set[Path] = set()
    duplicates = 0
    job_dirs = _job_dirs_below(paths)
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
        job_dirs.add(path.parent.parent)
        if record["run_id"] in seen:
            duplicates += 1
            continue
        seen.add(record["run_id"])
        record = dict(record)
        record["_file"] = str(path)
        record["_job_dir"] = str(path.parent.parent)
        records.append(record)
        files.append(path)
    statuses = {d: read_job_status(d) for d in sorted(job_dirs)}
    return LoadedRecords(records, files, skipped, duplicates, statuses)


def flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    """Nested mappings as one level, keys joined with dots; lists become tuples."""
    out: dict[str, Any] = {}
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            out.update(flatten(v, f"{prefix}{k}."))
        return out
    if isinstance(obj, list):
        obj = tuple(obj)
    out[prefix[:-1]] = obj
    return out


def _varying(rows: list[dict[str, Any]]) -> list[str]:
    """Keys whose value is not the same in every row (a missing key counts as a value)."""
    keys = sorted({k for r in rows for k in r})
    return [k for k in keys if len({repr(r.get(k, "<missing>")) for r in rows}) > 1]


def _fmt(value: Any) -> str:
    if isinstance(value, float) and value.is_integer():
        return f"{value:g}"
    return str(value)


def _num(value: Any, missing: float = math.inf) -> float:
    """A record number as float: ``None`` (a non-finite value in JSON) becomes ``missing``."""
    return missing if value is None else float(value)


def grouping(records: list[dict[str, Any]]) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """Varying problem keys per problem name, and varying optimizer keys per optimizer name."""
    by_problem: dict[str, list[dict[str, Any]]] = {}
    by_opt: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        pflat = flatten(r["problem"].get("config") or {})
        pflat["budget"] = r.get("budget")
        for k in PROBLEM_KEYS_IGNORED:
            pflat.pop(k, None)
        by_problem.setdefault(r["problem"]["name"], []).append(pflat)
        oflat = flatten(r["optimizer"].get("params") or {})
        for k in OPTIMIZER_KEYS_IGNORED:
            oflat.pop(k, None)
        by_opt.setdefault(r["optimizer"]["name"], []).append(oflat)
    return ({p: _varying(rows) for p, rows in by_problem.items()},
            {o: _varying(rows) for o, rows in by_opt.items()})


#: Context keys left out of the label when the population size and the other varying keys
#: already determine them (e.g. the budget of ``ps * (iterations + 1)`` when ps varies).
IMPLIED_KEYS = ("budget", "iterations")


def _drop_implied(
    records: list[dict[str, Any]], keys: dict[str, list[str]]
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
                pflat = flatten(r["problem"].get("config") or {})
                pflat["budget"] = r.get("budget")
                ps = (r["optimizer"].get("params") or {}).get("ps", pflat.get("ps"))
                ident = repr((ps, [pflat.get(k) for k in others]))
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
        pflat = flatten(r["problem"].get("config") or {})
        pflat["budget"] = r.get("budget")
        oflat = flatten(r["optimizer"].get("params") or {})
        ps = oflat.get("ps", pflat.get("ps"))
        pvary = {k: pflat.get(k) for k in problem_keys[pname]}
        ovary = {k: oflat.get(k) for k in optimizer_keys[oname]}
        context = f"{pname} ps={_fmt(ps)}" + "".join(
            f" {k}={_fmt(v)}" for k, v in pvary.items()
        )
        algorithm = oname + (
            "[" + ",".join(f"{k}={_fmt(v)}" for k, v in ovary.items()) + "]" if ovary else ""
        )
        out.append(RunLabel(context, algorithm, ps, pvary, ovary))
    return out


def metric_of(record: dict[str, Any], use_nore: bool) -> float:
    """A run's metric: its NoRE when ``use_nore`` (``inf`` when an ok run has none: a
    non-finite vector ranks last), else its best objective (``inf`` when not finite); NaN for
    a failed run."""
    res = record.get("result") or {}
    if record["status"] != "ok":
        return math.nan
    if use_nore:
        return _num(res.get("nore"))
    return _num(res.get("f_best")) if res else math.nan


def has_true(record: dict[str, Any]) -> bool:
    """Whether the record knows the true parameter values."""
    return (record.get("parameters") or {}).get("true") is not None


def runs_frame(records: list[dict[str, Any]]) -> Any:
    """The tidy table of all runs (a pandas DataFrame, one row per record).

    Columns: ``context``, ``problem``, ``ps``, ``algorithm``, ``optimizer``, one column per
    varying config key (``problem.<key>``, ``optimizer.<key>``), ``seed``, ``run_index``,
    ``status``, ``f_best``, ``nore`` (percent, NaN when no true values), ``metric`` (NoRE
    where every run of the context has it, else ``f_best``) and ``metric_name``,
    ``evaluations``, ``budget``, ``wall_time_s``, ``run_time_s``, ``stopped_by``, ``error``,
    ``x.<param>``, ``eps.<param>`` (relative error, percent), ``true.<param>``, ``run_id``,
    ``file``.
    Failed runs have NaN results. Non-finite objective values are ``inf``.
    """
    import pandas as pd

    rows = []
    for r, lab in zip(records, run_labels(records), strict=True):
        pname = r["problem"]["name"]
        oname = r["optimizer"]["name"]
        context, algorithm, ps = lab.context, lab.algorithm, lab.ps
        pvary, ovary = lab.problem_vary, lab.optimizer_vary
        res = r.get("result") or {}
        ok = r["status"] == "ok" and bool(res)
        timing = r.get("timing") or {}
        error = r.get("error") or {}
        row: dict[str, Any] = {
            "context": context,
            "problem": pname,
            "ps": ps,
            "algorithm": algorithm,
            "optimizer": oname,
            **{f"problem.{k}": _fmt(v) for k, v in pvary.items() if k != "budget"},
            **{f"optimizer.{k}": _fmt(v) for k, v in ovary.items()},
            "seed": (r.get("seeds") or {}).get("seed"),
            "run_index": r.get("run_index"),
            "status": r["status"],
            "f_best": _num(res.get("f_best")) if ok else np.nan,
            "nore": (_num(res.get("nore")) if ok and res.get("nore") is not None else np.nan),
            "evaluations": res.get("evaluations", np.nan) if ok else np.nan,
            "budget": r.get("budget"),
            "wall_time_s": _num(timing.get("wall_time_s"), np.nan),
            "run_time_s": _num(timing.get("run_time_s"), np.nan),
            "stopped_by": res.get("stopped_by") if ok else None,
            "error": (f"{error.get('type')}: {error.get('message')}" if error else None),
            "has_true": has_true(r),
        }
        names = (r.get("parameters") or {}).get("names") or []
        x = res.get("x_best") or [None] * len(names)
        eps = res.get("rel_error_percent") or [None] * len(names)
        true = (r.get("parameters") or {}).get("true") or [None] * len(names)
        for name, xi, ei, ti in zip(names, x, eps, true, strict=False):
            row[f"x.{name}"] = _num(xi, np.nan) if ok else np.nan
            row[f"eps.{name}"] = _num(ei, np.nan) if ok else np.nan
            row[f"true.{name}"] = _num(ti, np.nan)
        row["run_id"] = r["run_id"]
        row["file"] = r.get("_file")
        rows.append(row)
    df = pd.DataFrame(rows)
    if df.empty:
        return df
    # NoRE where every successful run of the context has true values; objective otherwise.
    ok = df["status"] == "ok"
    use_nore = df[ok].groupby("context")["has_true"].all()
    df["metric_name"] = df["context"].map(lambda c: "NoRE" if use_nore.get(c, False) else "f_best")
    df["metric"] = np.where(df["metric_name"] == "NoRE", df["nore"], df["f_best"])
    # An ok run with true values but a non-finite x has no NoRE: rank it last.
    df.loc[ok & (df["metric_name"] == "NoRE") & df["nore"].isna(), "metric"] = np.inf
    df = df.drop(columns="has_true")
    return df.sort_values(["context", "algorithm", "seed", "run_index"], kind="stable",
                          ignore_index=True)


def traces_frame(records: list[dict[str, Any]], runs: Any) -> Any:
    """Best-so-far traces of the successful runs, long form: context, algorithm, run_id,
    evaluations, best (``inf`` as NaN: nothing finite found yet)."""
    import pandas as pd

    labels = runs.set_index("run_id")[["context", "algorithm"]].to_dict("index")
    parts = []
    for r in records:
        trace = r.get("trace") or {}
        ev, best = trace.get("evaluations") or [], trace.get("best") or []
        if r["status"] != "ok" or not ev or r["run_id"] not in labels:
            continue
        lab = labels[r["run_id"]]
        parts.append(pd.DataFrame({
            "context": lab["context"], "algorithm": lab["algorithm"], "run_id": r["run_id"],
            "evaluations": np.asarray(ev, dtype=float),
            "best": np.array([np.nan if b is None else b for b in best], dtype=float),
        }))
    if not parts:
        return pd.DataFrame(columns=["context", "algorithm", "run_id", "evaluations", "best"])
    return pd.concat(parts, ignore_index=True)
