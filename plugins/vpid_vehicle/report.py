"""The vehicle's report section, the mean identified vector (the paper's Tables II and III):
per context and optimizer the mean vector's ε per parameter and NoRE, and the published row
beside it only where the runs follow the paper's protocol (:func:`protocol_gaps`; elsewhere a
line says why). Headline columns ``mean-vec NoRE``, ``paper NoRE``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from vpid_bench import Contribution, HeadlineColumn, ReportContext, Section

#: Where the README explains why our NoRE differs from the paper's.
WHY_LINK = ("README.md, section \"The paper's experiment, reproduced\" "
            "(`README.md#the-papers-experiment-reproduced`)")
#: The paper's protocol: what a context's records must say for the published numbers to be
#: comparable. (ps, iterations, noise, record window, step; the vehicle and bump defaults.)
PAPER_PS = (20, 30)
PAPER_ITERATIONS = 50
PAPER_NOISE = (0.05, "multiplicative")
PAPER_DT = 0.001


def _close(a: Any, b: float) -> bool:
    return isinstance(a, (int, float)) and not isinstance(a, bool) and math.isclose(
        float(a), b, rel_tol=1e-9, abs_tol=1e-12)


def protocol_gaps(record: Mapping[str, Any]) -> list[str]:
    """How a run record departs from the paper's protocol (:data:`PAPER_PS` ...: 5 %
    multiplicative noise, the 0.48 s window, the paper's bump and vehicle); empty: it follows."""
    from .config import BumpConfig, VehicleParams

    cfg = (record.get("problem") or {}).get("config") or {}
    params = (record.get("optimizer") or {}).get("params") or {}
    gaps = []
    noise = cfg.get("noise") or {}
    if not (_close(noise.get("level"), PAPER_NOISE[0]) and noise.get("model") == PAPER_NOISE[1]):
        gaps.append(f"noise {noise.get('model')} {noise.get('level')} (paper: 5 % multiplicative)")
    if (cfg.get("reference") or {}).get("file") is not None:
        gaps.append("a measured reference file")
    if not _close((cfg.get("record") or {}).get("extra"), 0.0):
        gaps.append(f"record.extra={(cfg.get('record') or {}).get('extra')} s (paper: 0, "
                    "a 0.48 s window)")
    if not _close(cfg.get("dt"), PAPER_DT):
        gaps.append(f"dt={cfg.get('dt')} s (paper: 0.001)")
    for key, default in (("bump", BumpConfig()), ("vehicle", VehicleParams())):
        given = cfg.get(key) or {}
        for name, value in vars(default).items():
            if not _close(given.get(name), value):
                gaps.append(f"{key}.{name}={given.get(name)} (paper: {value:g})")
    ps = params.get("ps", cfg.get("ps"))
    if ps not in PAPER_PS:
        gaps.append(f"ps={ps} (paper: 20 or 30)")
    iterations = params.get("iterations", cfg.get("iterations"))
    if iterations != PAPER_ITERATIONS:
        gaps.append(f"{iterations} generations (paper: {PAPER_ITERATIONS})")
    budget = record.get("budget")
    if isinstance(ps, int) and budget is not None and budget != ps * (PAPER_ITERATIONS + 1):
        gaps.append(f"budget {budget} (paper: ps * 51)")
    return gaps


def _mean_vectors(ctx: ReportContext) -> list[dict[str, Any]]:
    """Per context and algorithm with true values: names, units, true, mean, eps, NoRE."""
    import numpy as np

    from .problem import nore

    groups: dict[tuple[str, str], list[tuple[Mapping[str, Any], Mapping[str, Any]]]] = {}
    for row, rec in zip(ctx.rows, ctx.records, strict=True):
        groups.setdefault((row["context"], row["algorithm"]), []).append((row, rec))
    out = []
    for (context, algorithm), items in sorted(groups.items()):
        params = items[0][1].get("parameters") or {}
        names = list(params.get("names") or [])
        units = list(params.get("units") or [""] * len(names))
        true = params.get("true")
        if not names or true is None or any(v is None for v in true):
            continue
        X = np.array([[row.get(f"x.{n}", math.nan) for n in names]
                      for row, _ in items if row["status"] == "ok"], dtype=float)
        X = X[np.all(np.isfinite(X), axis=1)] if X.size else X
        if not len(X):
            continue
        true_a = np.asarray(true, dtype=float)
        mean = X.mean(axis=0)
        out.append({"context": context, "algorithm": algorithm,
                    "optimizer": items[0][0]["optimizer"], "ps": items[0][0]["ps"],
                    "n_runs": len(X), "names": names, "units": units, "true": true_a,
                    "mean": mean, "eps": 100.0 * (mean - true_a) / true_a,
                    "nore": nore(mean, true_a),
                    "gaps": sorted({g for _, rec in items for g in protocol_gaps(rec)})})
    return out


def _published(mv: Mapping[str, Any]) -> dict[str, Any] | None:
    """The paper's row for this mean vector, in its parameter order, or ``None``."""
    from . import paper

    if mv["gaps"] or mv["algorithm"] != mv["optimizer"] or list(mv["names"]) != list(
            paper.PARAMETERS):
        return None
    pub = paper.published(None, mv["optimizer"], int(mv["ps"]))
    if pub is None:
        return None
    return {**pub, "mean": [pub["mean"][p] for p in mv["names"]],
            "eps": [pub["eps"][p] for p in mv["names"]]}


def vehicle_sections(ctx: ReportContext) -> Contribution:
    """The vehicle's report section (see the module docstring)."""
    from . import paper

    mvs = _mean_vectors(ctx)
    if not mvs:
        return Contribution()
    csv_rows: list[list[Any]] = []
    mine: dict[tuple[str, str], Any] = {}
    theirs: dict[tuple[str, str], Any] = {}
    text = [ctx.para(
        "Mean over the successful runs of the identified vectors, the relative error ε (%) of "
        "each parameter of that mean, and its NoRE (%), the paper's ranking measure. Averaging "
        "vectors hides scatter (errors of opposite sign cancel), so the headline ranks by the "
        f"median per-run metric instead. The published rows: {paper.CITATION} (Table III's "
        "DE2 row repaired). They are shown only beside runs that follow the paper's protocol "
        "(5 % multiplicative noise, the 0.48 s record, dt = 1 ms, the paper's bump and "
        "vehicle, ps 20 or 30, 50 generations). Why our NoRE differs from the paper's: "
        f"{WHY_LINK}."), ""]
    header = None
    for context in ctx.contexts:
        g = [mv for mv in mvs if mv["context"] == context]
        if not g:
            continue
        names = g[0]["names"]
        header = header or names
        body = []
        for mv in g:
            key = (mv["context"], mv["algorithm"])
            mine[key] = mv["nore"]
            pub = _published(mv)
            body.append([mv["algorithm"], mv["n_runs"], *mv["eps"], mv["nore"]])
            base = [context, mv["algorithm"], mv["n_runs"]]
            csv_rows.append(base + ["ours", "mean", *mv["mean"], None, ""])
            csv_rows.append(base + ["ours", "eps_percent", *mv["eps"], mv["nore"], ""])
            if pub is not None:
                theirs[key] = pub["nore"]
                note = f"Table {pub['table']}" + (f"; {pub['note']}" if pub["note"] else "")
                body.append([f"{mv['algorithm']} (paper)", 30, *pub["eps"], pub["nore"]])
                csv_rows.append(base + ["paper", "mean", *pub["mean"], None, note])
                csv_rows.append(base + ["paper", "eps_percent", *pub["eps"], pub["nore"], note])
                csv_rows.append(base + ["difference", "eps_percent",
                                        *(a - b for a, b in zip(mv["eps"], pub["eps"],
                                                                strict=True)),
                                        mv["nore"] - pub["nore"], "ours - paper"])
        gaps = sorted({x for mv in g for x in mv["gaps"]})
        text += [f"### {ctx.escape(context)}: ε of the mean vector (%)", ""]
        if gaps:
            text += [ctx.para("The paper's numbers are not shown here: these runs differ from "
                              "its protocol (" + ctx.escape("; ".join(gaps[:4]))
                              + ("; ..." if len(gaps) > 4 else "") + ")."), ""]
        elif not any((context, mv["algorithm"]) in theirs for mv in g):
            text += [ctx.para("The paper's protocol, but the paper has no row for these "
                              "optimizers."), ""]
        text += [ctx.markdown_table(["optimizer", "n", *names, "NoRE"], body, keep=2, digits=3),
                 ""]
    units = mvs[0]["units"]
    csv_header = ["context", "algorithm", "n_runs", "source", "quantity",
                  *(f"{n} [{u}]" if u else n for n, u in zip(header or [], units, strict=False)),
                  "nore_percent", "note"]
    files = tuple(ctx.write_table("mean_vector", csv_header, csv_rows))
    text += [ctx.para("The means themselves (in the parameters' units), the published means "
                      "and the differences ours − paper are in `tables/mean_vector.csv`.")]
    columns = [HeadlineColumn("mean-vec NoRE", mine)]
    if theirs:
        columns.append(HeadlineColumn("paper NoRE", theirs))
    return Contribution(sections=(Section("The mean identified vector (the paper's Tables II "
                                          "and III)", "\n".join(text), files),),
                        headline=tuple(columns))
