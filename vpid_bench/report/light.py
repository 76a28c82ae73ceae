"""The single job's report, light: numpy and tabulate only (no pandas, matplotlib, seaborn
or scipy.stats), so that ``vpid-bench`` without ``-m`` stays quick.

:func:`light_report` reads the records of one job folder and writes ``<out_dir>/report.md``:
the headline table (per-run metric statistics: NoRE where the problem knows the true
parameters, else the best objective), the mean identified vector with the relative error of
each parameter beside the paper's published row where there is one, and one line per run.
It returns the same headline as a terminal table. The full report with figures of the same
folder is ``vpid-bench-report <job dir> -o <job dir>/report`` (:func:`full_report_command`).

The numbers come from the helpers the full report uses (:func:`.tables.metric_stats`,
:func:`.tables.mean_vector_summary`, :func:`.load.run_labels`), so both agree.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import shlex
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from . import render, tables
from .load import (
    LoadedRecords,
    NoRecordsError,
    has_true,
    load_records,
    metric_of,
    reason,
    run_labels,
)

#: Headline columns: (header, key of a summary row). The full report's headline has the same
#: names; rank and the baseline verdict are left out (one job: one optimizer, no test).
HEADLINE = (
    ("context", "context"),
    ("optimizer", "algorithm"),
    ("n", "n_runs"),
    ("failed", "n_failed"),
    ("metric", "metric_name"),
    ("median", "median"),
    ("IQR", "iqr_text"),
    ("mean ± sd", "mean_sd_text"),
    ("best", "best"),
    ("worst", "worst"),
    ("mean-vector NoRE", "meanvec_nore"),
    ("paper NoRE", "paper_nore"),
    ("median f", "f_median"),
)


@dataclasses.dataclass
class LightReport:
    """What :func:`light_report` wrote and what it found wrong."""

    out_dir: Path
    report_md: Path
    headline: str
    n_records: int
    summary: list[dict[str, Any]]
    loaded: LoadedRecords

    @property
    def failures(self) -> list[str]:
        """One line per failed job, failed run or unreadable record file."""
        return self.loaded.failures


def full_report_command(job_dir: str | Path) -> str:
    """The command that builds the full report (figures included) of ``job_dir`` in place."""
    job = Path(job_dir)
    return f"vpid-bench-report {shlex.quote(str(job))} -o {shlex.quote(str(job / 'report'))}"


def sources_lines(paths: Iterable[Path], loaded: LoadedRecords,
                  failed_runs: list[tuple[Any, ...]]) -> list[str]:
    """Where the records came from, what was skipped, which jobs and runs failed.

    ``failed_runs``: per failed run (algorithm, context, run index, seed, error)."""
    n = len(loaded.records)
    n_ok = sum(r["status"] == "ok" for r in loaded.records)
    lines = [
        f"Built {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M UTC} from "
        f"{n} run record(s) ({n_ok} ok, {n - n_ok} failed) found in:",
        "",
        *[f"- `{p}`" for p in paths],
        "",
    ]
    if loaded.duplicates:
        lines.append(f"- {loaded.duplicates} duplicate record(s) (same run id) were counted once.")
    for p, why in loaded.skipped:
        lines.append(f"- **Skipped unreadable record** `{p}`: {reason(p, why)}")
    for d, why in loaded.failed_jobs:
        lines.append(f"- **Job not ok** `{d}`: {why}")
    for algorithm, context, run_index, seed, error in failed_runs:
        lines.append(f"- **Failed run** {algorithm} on {context}, run {run_index} "
                     f"(seed {seed}): {error}")
    return lines


def _error(record: dict[str, Any]) -> str | None:
    error = record.get("error") or {}
    return f"{error.get('type')}: {error.get('message')}" if error else None


def _vector(values: Any, n: int) -> list[float]:
    """A record's vector as n floats (``None``, a non-finite value in JSON, as NaN)."""
    values = list(values or [])
    if len(values) != n:
        return [math.nan] * n
    return [math.nan if v is None else float(v) for v in values]


def _run_key(item: tuple[dict[str, Any], Any]) -> tuple[Any, ...]:
    r = item[0]
    return ((r.get("seeds") or {}).get("seed") or 0, r.get("run_index") or 0)


def summarize(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per context and algorithm (sorted): the headline numbers, the mean vector and runs.

    Keys: context, problem, ps, algorithm, optimizer, metric_name, n_runs, n_failed, the
    :func:`.tables.metric_stats` keys (when a run succeeded), meanvec_nore, paper_nore,
    names, units, true, mean_vector (:func:`.tables.mean_vector_summary`, or for a problem
    without true values ``{"n_runs", "mean"}``; ``None`` when no run gave a finite vector),
    runs (per run, sorted by seed and index: run_index, seed, status, metric, f_best,
    evaluations, stopped_by, wall_time_s, error)."""
    labels = run_labels(records)
    groups: dict[tuple[str, str], list[tuple[dict[str, Any], Any]]] = {}
    for r, lab in zip(records, labels, strict=True):
        groups.setdefault((lab.context, lab.algorithm), []).append((r, lab))
    # NoRE where every successful run of the context has true values (as the full report).
    use_nore: dict[str, bool] = {}
    for r, lab in zip(records, labels, strict=True):
        if r["status"] == "ok":
            use_nore[lab.context] = use_nore.get(lab.context, True) and has_true(r)
    out = []
    for (context, algorithm), items in sorted(groups.items()):
        items = sorted(items, key=_run_key)
        first = items[0][0]
        nore = use_nore.get(context, False)
        ok = [r for r, _ in items if r["status"] == "ok"]
        params = first.get("parameters") or {}
        names = list(params.get("names") or [])
        units = [u or "" for u in params.get("units") or []]
        row: dict[str, Any] = {
            "context": context, "problem": first["problem"]["name"], "ps": items[0][1].ps,
            "algorithm": algorithm, "optimizer": first["optimizer"]["name"],
            "metric_name": "NoRE" if nore else "f_best",
            "n_runs": len(ok), "n_failed": len(items) - len(ok),
            "names": names, "units": units if len(units) == len(names) else [""] * len(names),
            "true": None, "mean_vector": None,
            "meanvec_nore": math.nan, "paper_nore": math.nan,
        }
        row.update(tables.metric_stats([metric_of(r, nore) for r in ok],
                                       [metric_of(r, False) for r in ok]))
        x = np.array([_vector((r.get("result") or {}).get("x_best"), len(names)) for r in ok],
                     dtype=float).reshape(len(ok), len(names))
        if names and nore:
            row["true"] = np.array(_vector(params.get("true"), len(names)))
            mv = tables.mean_vector_summary(
                x, row["true"], names, problem=row["problem"], optimizer=row["optimizer"],
                algorithm=algorithm, ps=row["ps"])
            row["mean_vector"] = mv
            if mv is not None:
                row["meanvec_nore"] = mv["nore"]
                if mv["paper"] is not None:
                    row["paper_nore"] = mv["paper"]["nore"]
        elif names:
            finite = x[np.all(np.isfinite(x), axis=1)]
            if len(finite):
                row["mean_vector"] = {"n_runs": len(finite), "mean": finite.mean(axis=0)}
        row["runs"] = [{
            "run_index": r.get("run_index"), "seed": (r.get("seeds") or {}).get("seed"),
            "status": r["status"], "metric": metric_of(r, nore), "f_best": metric_of(r, False),
            "evaluations": (r.get("result") or {}).get("evaluations"),
            "stopped_by": (r.get("result") or {}).get("stopped_by"),
            "wall_time_s": (r.get("timing") or {}).get("wall_time_s"),
            "error": _error(r),
        } for r, _ in items]
        out.append(row)
    return out


def _headline_cells(row: dict[str, Any]) -> dict[str, Any]:
    cells = dict(row)
    if "median" in row:
        cells["iqr_text"] = f"[{render.fmt(row['q1'])}, {render.fmt(row['q3'])}]"
        sd = row["sd"]
        cells["mean_sd_text"] = render.fmt(row["mean"]) + (
            f" ± {render.fmt(sd)}" if not math.isnan(sd) else "")
    return cells


def headline_table(summary: list[dict[str, Any]]) -> tuple[list[str], list[list[Any]]]:
    """Headers and rows of the headline; a column empty in every row is left out."""
    rows = [[_headline_cells(s).get(key) for _, key in HEADLINE] for s in summary]
    keep = [i for i in range(len(HEADLINE)) if any(render.fmt(r[i]) for r in rows)]
    return [HEADLINE[i][0] for i in keep], [[r[i] for i in keep] for r in rows]


def _mean_vector_md(s: dict[str, Any]) -> list[str]:
    lines = [f"### {s['context']}: {s['algorithm']}", ""]
    mv = s["mean_vector"]
    if mv is None:
        return lines + ["No successful run with a finite identified vector.", ""]
    names, units = s["names"], s["units"]
    if s["true"] is None:
        lines += [f"Mean over the {mv['n_runs']} successful run(s) of the identified vectors. "
                  "The problem has no true parameter values: no relative errors; the runs are "
                  "judged by the objective.", ""]
        rows = [[n, u, m] for n, u, m in zip(names, units, mv["mean"], strict=True)]
        return lines + [render.table(["parameter", "unit", "mean"], rows), ""]
    pub = mv["paper"]
    lines += [f"Mean over the {mv['n_runs']} successful run(s) of the identified vectors and "
              "the relative error of each parameter of that mean, ε = 100 (mean − true) / true "
              "(%)." + (f" `paper`: the published mean and ε, {_paper_source(pub)}."
                        if pub else ""), ""]
    headers = ["parameter", "unit", "true", "mean", "ε (%)"]
    cols = [names, units, s["true"], mv["mean"], mv["eps"]]
    if pub:
        headers += ["paper mean", "paper ε (%)"]
        cols += [pub["mean"], pub["eps"]]
    rows = [list(r) for r in zip(*cols, strict=True)]
    rows.append(["NoRE", "%", None, None, mv["nore"], None, pub["nore"]] if pub
                else ["NoRE", "%", None, None, mv["nore"]])
    return lines + [render.table(headers, rows), ""]


def _paper_source(pub: dict[str, Any]) -> str:
    from .paper import CITATION

    note = f"; {pub['note']}" if pub["note"] else ""
    return f"{CITATION} (this row: Table {pub['table']}{note})"


RUN_HEADERS = ["run", "seed", "status", "metric", "f", "evaluations", "stopped by",
               "wall time (s)", "error"]
RUN_KEYS = ["run_index", "seed", "status", "metric", "f_best", "evaluations", "stopped_by",
            "wall_time_s", "error"]


def light_report(job_dir: str | Path, out_dir: str | Path) -> LightReport:
    """Write the light report of the records below ``job_dir`` into ``out_dir/report.md``.

    Raises :class:`.load.NoRecordsError` when no readable record exists."""
    job_dir, out_dir = Path(job_dir), Path(out_dir)
    loaded = load_records([job_dir])
    if not loaded.records:
        extra = f" ({len(loaded.skipped)} unreadable)" if loaded.skipped else ""
        raise NoRecordsError(f"no run records (records/run-*.json) below {job_dir}{extra}")
    summary = summarize(loaded.records)
    headers, rows = headline_table(summary)
    failed = [(s["algorithm"], s["context"], run["run_index"], run["seed"], run["error"])
              for s in summary for run in s["runs"] if run["status"] != "ok"]
    lines = ["# vpid-bench report (single job)", ""]
    lines += sources_lines([job_dir], loaded, failed)
    lines += ["", "The light report of one job: per-run statistics and the mean identified "
              "vector, no tests, no figures. The full report, with figures (convergence, "
              "per-run metric, relative errors, measured vs fitted signals):", "",
              f"    {full_report_command(job_dir)}", "",
              "## Headline", "",
              "Per-run metric over the successful runs (`n`; `failed` runs are not in it): "
              "NoRE (%) where the problem knows the true parameters, else the best objective "
              "value; lower is better. `mean-vector NoRE`: NoRE of the mean identified vector "
              "(the paper's measure); `paper NoRE`: the published value for this optimizer and "
              "population size, where the paper has one. `median f`: median best objective.",
              "", render.table(headers, rows), "",
              "## Mean identified vector", ""]
    for s in summary:
        lines += _mean_vector_md(s)
    lines += ["## Runs", ""]
    for s in summary:
        if len(summary) > 1:
            lines += [f"### {s['context']}: {s['algorithm']}", ""]
        lines += [render.table(RUN_HEADERS, [[run[k] for k in RUN_KEYS] for run in s["runs"]]),
                  ""]
    out_dir.mkdir(parents=True, exist_ok=True)
    md = out_dir / "report.md"
    md.write_text("\n".join(lines), encoding="utf-8")
    return LightReport(out_dir, md, render.table(headers, rows, "simple"),
                       len(loaded.records), summary, loaded)
