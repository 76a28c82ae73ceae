"""The EMPS section of the report: per context, the best run's values and 95 % intervals
beside the data set's published estimate, from the run records only."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from vpid_bench import Contribution, ReportContext, Section

from .problem import NAMES, PUBLISHED, UNITS


def _number(v: Any) -> float | None:
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
    return float(v) if ok else None


def _best(ctx: ReportContext, context: str) -> tuple[Mapping[str, Any], Mapping[str, Any]] | None:
    """The ok run of ``context`` with the lowest objective, as (row, record)."""
    runs = [(row, rec) for row, rec in zip(ctx.rows, ctx.records, strict=True)
            if row["context"] == context and row["status"] == "ok"
            and _number(row.get("f_best")) is not None]
    return min(runs, key=lambda item: item[0]["f_best"]) if runs else None


def _interval(intervals: Any, j: int) -> str:
    if not isinstance(intervals, Mapping):
        return ""
    lo, hi = (intervals.get(k) for k in ("lower", "upper"))
    if not (isinstance(lo, list) and isinstance(hi, list) and len(lo) == len(hi) == len(NAMES)):
        return ""
    a, b = _number(lo[j]), _number(hi[j])
    return f"[{'open' if a is None else f'{a:.5g}'}, {'open' if b is None else f'{b:.5g}'}]"


def emps_sections(ctx: ReportContext) -> Contribution | None:
    """Per context, the best run's values beside the published estimate, then its metrics."""
    texts: list[str] = []
    rows_csv: list[list[Any]] = []
    for context in ctx.contexts:
        best = _best(ctx, context)
        if best is None:
            continue
        row, rec = best
        res = rec.get("result") or {}
        x = res.get("x_best")
        if not (isinstance(x, list) and len(x) == len(NAMES)) or any(
                _number(v) is None for v in x):
            continue
        table = []
        for j, name in enumerate(NAMES):
            ours, pub = float(x[j]), float(PUBLISHED[j])
            diff = 100.0 * (ours - pub) / abs(pub)
            table.append([name, UNITS[j], ours, _interval(res.get("intervals"), j), pub, diff])
            rows_csv.append([context, row["algorithm"], name, UNITS[j], ours, pub, diff])
        metrics = res.get("metrics") or {}
        rms = _number(metrics.get("val_rms_um"))
        unexplained = _number(metrics.get("val_unexplained_pct"))
        texts.append(f"### {ctx.escape(context)}\n\n" + ctx.para(
            f"The best run ({ctx.escape(row['algorithm'])}, objective "
            f"{ctx.fmt(row['f_best'])} µm², the mean square position error on DATA_EMPS.mat) "
            "beside the data set's published IDIM-LS estimate, which is a point of "
            "comparison, not a truth. On the validation record (DATA_EMPS_PULSES.mat) this "
            f"run's simulated position misses the measured one by {ctx.fmt(rms)} µm rms"
            + ("" if unexplained is None else
               f" (fit {ctx.fmt(100.0 - unexplained, 6)} %)") + "; the published estimate's "
            "figures are in the comparison rows of the first screen.") + "\n\n"
            + ctx.markdown_table(["parameter", "unit", "identified", "95 % interval",
                                  "published", "difference %"], table, digits=6))
    if not texts:
        return None
    files = ctx.write_table("emps_identified_vs_published",
                            ["context", "algorithm", "parameter", "unit", "identified",
                             "published", "difference_pct"], rows_csv)
    return Contribution(sections=(Section("EMPS: identified beside the published estimate",
                                          "\n\n".join(texts), tuple(files)),))
