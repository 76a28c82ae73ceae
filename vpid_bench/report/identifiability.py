"""The report's identifiability section: what each record design can determine (the
Cramér–Rao bounds each job wrote, ``identifiability.json``), beside what the records allowed
(the instances' optima). A *design* is the problem and its settings without the protocol
(``<problem> ps=20`` and ``ps=30`` share one). Files from a results folder are untrusted: a
bad one is skipped with one line in the section. Also the convergence figure's reference
levels (:func:`reference_levels`)."""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..analysis.identifiability import ROUNDING
from ..analysis.optimum import find_optimum, load_optima, record_settings
from ..analysis.profile import STRUCTURAL_RATIO
from ..estimators import DESCRIPTION, OBJECTIVES
from ..problem import FILLED_PARAMS
from ..store.job_checks import finite, read_estimator_floors, read_identifiability
from ..store.job_files import ESTIMATORS, IDENTIFIABILITY
from ..store.records import stable_hash
from .figures import _plt
from .load import Rows, first_file_by_context
from .optima import opt_column_names
from .safe import escape
from .sections import Contribution, ReportContext, Section

#: A parameter whose Cramér–Rao bound (relative sd, %) exceeds this is "not determined": a
#: 95 % interval would span more than ±20 %.
UNDETERMINED_PERCENT = 10.0
FILE = IDENTIFIABILITY
#: The noise convention, in words (σ from ``Problem.residual_sigma``).
CONVENTION = (
    "Bounds: the Fisher information at the true parameters from a central-difference "
    "Jacobian of the clean responses, under independent Gaussian noise of the size that was "
    "simulated (the problem's own residual_sigma: per sample σ_k = noise level × |z_k| for "
    "multiplicative noise, σ_c = noise level × rms of the clean channel c for additive noise, "
    "divided by √3 for uniform noise). The bound belongs to the records, whatever objective "
    "was optimised; a floor belongs to the objective (estimator) it was computed with. "
    "`CRB %` is the Cramér–Rao lower bound of a parameter's relative standard "
    "deviation, 100·sqrt((F⁻¹)_jj)/|θ_j|; `CRB norm` the norm of those bounds (the rms "
    "norm of relative errors an efficient unbiased estimator would reach). Singular "
    "values: of the Jacobian whitened by σ and scaled by the true values. Samples whose σ "
    f"is at most {ROUNDING:g} of their channel's largest (a value that is zero in exact "
    "arithmetic, computed to rounding) carry no information and are left out.")


def optima_by_run(records: Rows) -> dict[str, Mapping[str, Any]]:
    """By ``run_id``, the optimum of its instance (checked ``<job>/optima``, ``<sweep>/optima``)."""
    jobs = dict.fromkeys(Path(str(rec.get("_job_dir", "."))) for rec in records)
    optima = load_optima(dict.fromkeys(f for job in jobs
                                       for f in (job / "optima", job.parent / "optima")))
    found = {rec["run_id"]: find_optimum(rec, optima) for rec in records} if optima else {}
    return {k: v for k, v in found.items() if v is not None}


def _instance(rec: Mapping[str, Any]) -> Any:
    inst = rec.get("instance")
    return inst.get("id") if isinstance(inst, Mapping) else None


def reference_levels(records: Rows, rows: Rows) -> tuple[dict[str, float], dict[str, float]]:
    """Per context, the median over its instances of the objective at the truth
    (``problem.info.f_at_true``) and of the record optimum ``f*``; a context is left out
    where an instance lacks a finite value."""
    context = {r["run_id"]: r["context"] for r in rows}
    optima = optima_by_run(records)
    f_true: dict[str, dict[Any, float]] = {}
    f_opt: dict[str, dict[Any, float]] = {}
    for rec in records:
        c = context.get(rec["run_id"])
        if c is None:
            continue
        info = (rec.get("problem") or {}).get("info") or {}
        v = info.get("f_at_true") if isinstance(info, Mapping) else None
        f_true.setdefault(c, {})[_instance(rec)] = float(v) if finite(v) else math.nan
        opt = optima.get(rec["run_id"])
        f_opt.setdefault(c, {})[_instance(rec)] = float(opt["f_opt"]) if opt else math.nan

    def medians(levels: dict[str, dict[Any, float]]) -> dict[str, float]:
        return {c: statistics.median(v.values()) for c, v in levels.items()
                if v and all(math.isfinite(x) for x in v.values())}

    return medians(f_true), medians(f_opt)


def _read_bounds(path: Path, rec: Mapping[str, Any]) -> dict[str, Any] | None:
    """A job's ``identifiability.json`` for the record's parameters (``None``: unreadable)."""
    names = list((rec.get("parameters") or {}).get("names") or [])
    return read_identifiability(path, names)[0] if path.exists() else None


def estimator_floors_by_context(records: Rows, rows: Rows) -> dict[str, dict[str, Any]]:
    """Per context, the first readable ``estimators.json`` of its jobs (each estimator's floor)."""
    return first_file_by_context(records, rows, ESTIMATORS,
                                 lambda path, _: read_estimator_floors(path)[0])


def crb_norm_by_context(records: Rows, rows: Rows) -> dict[str, float]:
    """Per context, the norm of the Cramér–Rao bounds (%) of the first readable
    ``identifiability.json`` of its jobs: what an efficient estimator could reach."""
    found = first_file_by_context(records, rows, FILE, _read_bounds)
    return {c: float(d["crb_norm_percent"]) for c, d in found.items()}


def crb_norms_by_instance(records: Rows, rows: Rows) -> dict[str, dict[Any, float]]:
    """Per context, each instance's own bound norm (%), keyed as the rows' ``instance``
    column (its id, or the run index where every run fits the same data): what the verdicts
    compare each instance's floor with (:func:`.verdicts.floor_over_bound`)."""
    found = first_file_by_context(records, rows, FILE, lambda path, rec: (
        _read_bounds(path, rec) or {}).get("instances") or None)
    return {context: {k: float(e["crb_norm_percent"]) for e in entries
                      for k in ([e["instance"]] if isinstance(e["instance"], str) else e["runs"])}
            for context, entries in found.items()}


def _design_label(rows: Rows) -> str:
    """The labels of a design's contexts without the protocol: the problem and its varying
    settings (``problem.<key>`` columns) but ``ps``, ``iterations`` and the budget."""
    return " / ".join(dict.fromkeys(str(row["problem"]) + "".join(
        f" {k.removeprefix('problem.')}={v}" for k, v in row.items()
        if k.startswith("problem.") and k.removeprefix("problem.") not in FILLED_PARAMS)
        for row in rows))


def _by_design(ctx: ReportContext) -> list[dict[str, Any]]:
    """``ctx``'s runs grouped by design: contexts, records, rows and job folders of each."""
    by_key: dict[str, dict[str, Any]] = {}
    for row, rec in zip(ctx.rows, ctx.records, strict=True):
        try:
            key = stable_hash({"problem": ctx.problem,
                               "settings": record_settings(rec["problem"].get("config") or {})})
        except (TypeError, ValueError, AttributeError):
            continue
        d = by_key.setdefault(key, {"contexts": {}, "records": [], "rows": [], "jobs": {}})
        d["contexts"][row["context"]] = d["jobs"][ctx.job_dir(rec)] = None  # once each
        d["records"].append(rec)
        d["rows"].append(row)
    return list(by_key.values())


def _first_bounds(jobs: Sequence[Path], names: Sequence[str], notes: list[str]
                  ) -> dict[str, Any] | None:
    """The first readable ``identifiability.json`` of ``jobs`` (a bad one is noted)."""
    for job in jobs:
        path = job / FILE
        if not path.exists() and not path.is_symlink():
            continue
        data, why = read_identifiability(path, names)
        if data is not None:
            return data
        notes.append(f"skipped `{escape(path)}`: {escape(why)}")
    return None


def _floors(d: Mapping[str, Any], names: Sequence[str], metric: Any,
            optima: Mapping[str, Mapping[str, Any]]
            ) -> tuple[dict[Any, float], dict[Any, list[float]]]:
    """Per instance of a design: its optimum's metric (the rows' floor column first, so an
    archive's optima count too) and absolute relative error per parameter (%)."""
    floors: dict[Any, float] = {}
    errors: dict[Any, list[float]] = {}
    column, _ = opt_column_names(d["rows"])
    for rec, row in zip(d["records"], d["rows"], strict=True):
        if column and finite(row.get(column)):
            floors.setdefault(_instance(rec), float(row[column]))
        opt = optima.get(rec["run_id"])
        if opt is None:
            continue
        value = (opt.get("metrics") or {}).get(metric)
        if finite(value):
            floors[_instance(rec)] = float(value)
        rec_true = (rec.get("parameters") or {}).get("true")
        if (isinstance(rec_true, list) and len(rec_true) == len(names)
                and all(finite(t) and t != 0 for t in rec_true)):
            errors[_instance(rec)] = [abs(100.0 * (x - t) / t)
                                      for x, t in zip(opt["x_opt"], rec_true, strict=True)]
    return floors, errors


def _designs(ctx: ReportContext) -> tuple[list[dict[str, Any]], list[str]]:
    """The record designs of ``ctx``'s runs, bounds and measured floors; a line per skipped file."""
    notes: list[str] = []
    optima = optima_by_run(ctx.records)
    out = []
    for d in _by_design(ctx):
        names = list((d["records"][0].get("parameters") or {}).get("names") or [])
        crb = _first_bounds(d["jobs"], names, notes)
        if crb is None:
            continue
        metric = d["rows"][0].get("metric_name")
        floors, errors = _floors(d, names, metric, optima)
        per_estimator = next((data for job in d["jobs"] for data in
                              [read_estimator_floors(job / ESTIMATORS)[0]] if data), None)
        out.append({
            "label": _design_label(d["rows"]), "contexts": sorted(d["contexts"]),
            "names": names, "crb": crb, "metric": metric,
            "floor": statistics.median(floors.values()) if floors else None,
            "floor_errors": ([statistics.median(e[j] for e in errors.values())
                              for j in range(len(names))] if errors else None),
            "instances": len(floors) if floors else len(errors),
            "estimators": per_estimator, "unit": str(d["rows"][0].get("metric_unit") or "")})
    out.sort(key=lambda x: x["label"])
    labels = [x["label"] for x in out]
    for x in out:
        if labels.count(x["label"]) > 1:  # settings that differ beyond the context's keys
            x["label"] += f" [{', '.join(x['contexts'])}]"
    return out, notes


def draw_design(design: Mapping[str, Any]) -> Any:
    """Bars: each parameter's bound (%, log axis); dots: the median |error| of the instances'
    optima; a dashed line at :data:`UNDETERMINED_PERCENT`."""
    from matplotlib.ticker import FuncFormatter

    names = design["names"]
    crb = design["crb"]["crb_percent"]
    fig, ax = _plt().subplots(figsize=(max(5.0, 0.7 * len(names) + 2.0), 3.8))
    xs = range(len(names))
    ax.bar(xs, [max(v, 1e-6) for v in crb], color="#4c72b0",
           label="Cramér–Rao bound (relative sd, %)")
    if design["floor_errors"] is not None:
        ax.plot(xs, [max(v, 1e-6) for v in design["floor_errors"]], "o", color="#dd8452",
                label=f"median |error| of the record optima x* ({design['instances']} "
                      "instance(s))")
    ax.axhline(UNDETERMINED_PERCENT, color="black", ls="--", lw=1.0,
               label=f"{UNDETERMINED_PERCENT:g} %: above it, not determined")
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(FuncFormatter(lambda y, _: f"{y:g}"))
    ax.set_xticks(list(xs), names)
    ax.set_xlabel("parameter")
    ax.set_ylabel("relative standard deviation / error (%, log scale)")
    ax.set_title(f"What the record design {design['label']} can determine\n"
                 f"(CRB norm {design['crb']['crb_norm_percent']:.3g} %)", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return fig


def _design_text(ctx: ReportContext, design: Mapping[str, Any]) -> str:
    crb, floor = design["crb"], design["floor"]
    cond = crb.get("condition_number")
    undetermined = [f"{escape(n)} ({ctx.fmt(b, 3)} %)" for n, b in zip(
        design["names"], crb["crb_percent"], strict=True) if b > UNDETERMINED_PERCENT]
    text = (f"Record design **{escape(design['label'])}** (contexts: "
            f"{escape(', '.join(design['contexts']))}). "
            f"CRB norm {ctx.fmt(crb['crb_norm_percent'], 3)} %"
            + (f"; measured floor: median {escape(design['metric'])} of the record optima x* "
               f"{ctx.fmt(floor, 3)} % over {design['instances']} instance(s)"
               if floor is not None else "; no instance optimum was found for a measured floor")
            + f". Condition number {ctx.fmt(cond, 3) if cond is not None else 'infinite'}; "
            f"singular values {', '.join(ctx.fmt(v, 3) for v in crb['singular_values'])}. ")
    est = design.get("estimators")
    if est:  # "...: ordinary least squares (objective=ols) 27.1 %; ..."
        floors, unit = est["floors"], escape(design["unit"])
        text += (f"Floors per estimator: median {escape(est['metric'])} of each estimator's "
                 f"optimum on the first {est['instances']} instance(s): " + "; ".join(
                     f"{DESCRIPTION[o]} (objective={o}) {ctx.fmt(floors[o]['median'], 3)} "
                     f"{unit}".rstrip() for o in OBJECTIVES if floors.get(o) is not None) + ". ")
    if cond is None or cond >= 1.0 / STRUCTURAL_RATIO:
        text += ("The record is blind to a combination of the parameters (a structural "
                 "symmetry: the smallest singular value is at most "
                 f"{STRUCTURAL_RATIO:g} of the largest), so no record of this design can "
                 "identify the parameters in it; `vpid-bench-design --profile` names them. ")
    if undetermined:
        text += (f"This design cannot determine {', '.join(undetermined)}: the bound exceeds "
                 f"{UNDETERMINED_PERCENT:g} %.")
    else:
        text += f"Every parameter's bound is within {UNDETERMINED_PERCENT:g} %."
    return ctx.para(text + _sensitivity_text(ctx, crb) + _instances_text(ctx, crb))


def _sensitivity_text(ctx: ReportContext, crb: Mapping[str, Any]) -> str:
    """The rounding-level samples left out and the bound under a σ floor, or ``""``."""
    text = ""
    if crb.get("excluded_entries"):
        text += (f" {crb['excluded_entries']} sample(s) with no or rounding-level noise (σ at "
                 f"most {ROUNDING:g} of its channel's largest) are left out of the bound.")
    floors = crb.get("sigma_floor_sensitivity")
    if floors:
        parts = [f"{ctx.fmt(e['crb_norm_percent'], 3)} % at {e['fraction']:g}" for e in floors]
        text += (" The noise's σ varies along the record, so the bound rests on the samples "
                 "where it is smallest (near the signal's zero crossings): with every σ "
                 "floored at a fraction of its channel's rms σ, the CRB norm is "
                 + ", ".join(parts) + " (a small additive noise in a real sensor would take "
                 "that much away).")
    return text


def _instances_text(ctx: ReportContext, crb: Mapping[str, Any]) -> str:
    """The spread of the per-instance bounds where instances differ, or ``""``."""
    norms = [e["crb_norm_percent"] for e in crb.get("instances") or []]
    if len(norms) < 2 or max(norms) <= min(norms) * (1 + 1e-6):
        return ""
    return (f" Each instance has its own truth and record, so its own bound: CRB norm median "
            f"{ctx.fmt(statistics.median(norms), 3)} % over {len(norms)} instances (from "
            f"{ctx.fmt(min(norms), 3)} to {ctx.fmt(max(norms), 3)} %); the numbers above are "
            "instance 0's.")


def section(ctx: ReportContext) -> Contribution | None:
    """The identifiability section of one problem's runs (``None``: no identifiability.json)."""
    designs, notes = _designs(ctx)
    if not designs:
        if not notes:
            return None
        return Contribution(sections=(Section(
            "Identifiability", ctx.para("Not built: " + "; ".join(notes) + ".")),))
    files = ctx.write_table("identifiability", [
        "context", "design", "parameter", "crb_percent", "floor_median_abs_error_percent",
        "instances"],
        [[context, d["label"], name, d["crb"]["crb_percent"][j],
          d["floor_errors"][j] if d["floor_errors"] is not None else None, d["instances"]]
         for d in designs for j, name in enumerate(d["names"]) for context in d["contexts"]])
    files += ctx.write_table("identifiability_designs", [
        "design", "contexts", "crb_norm_percent", "floor_metric", "floor_median", "instances",
        "condition_number", "singular_values", "sigma"],
        [[d["label"], "; ".join(d["contexts"]), d["crb"]["crb_norm_percent"], d["metric"],
          d["floor"], d["instances"], d["crb"].get("condition_number"),
          " ".join(repr(float(v)) for v in d["crb"]["singular_values"]),
          " ".join(repr(float(v)) for v in d["crb"]["sigma"])] for d in designs])
    files += ctx.write_table(
        "identifiability_instances",
        ["design", "instance", "runs", "crb_norm_percent", "sigma_floor_norms"],
        [[d["label"], e["instance"], " ".join(str(i) for i in e["runs"]),
          e["crb_norm_percent"], " ".join(repr(float(v)) for v in e.get("sigma_floor_norms")
                                          or [])]
         for d in designs for e in d["crb"].get("instances") or []])
    parts = [ctx.para(
        f"What each record design allows, beside what the records gave. {CONVENTION} "
        f"A parameter whose bound exceeds {UNDETERMINED_PERCENT:g} % is one this design "
        "cannot determine. The measured floor is each instance's optimum x* (the lowest "
        "objective its record allows, polished by the job): its metric, median over the "
        "instances of the design, and per parameter the median |x*_j − θ_j|/|θ_j|. A floor "
        "far above the bound means the noise draws are unlucky or the objective (a sum of "
        "norms) is not the likelihood; a run cannot be expected to do better than its "
        "record's x*."), ""]
    for d in designs:
        parts += [_design_text(ctx, d), ""]
        body = [[n, b, (d["floor_errors"][j] if d["floor_errors"] is not None else None),
                 "not determined" if b > UNDETERMINED_PERCENT else ""]
                for j, (n, b) in enumerate(zip(d["names"], d["crb"]["crb_percent"], strict=True))]
        parts += [ctx.markdown_table(["parameter", "CRB %", "floor median |error| %", ""],
                                     body, digits=3), ""]
        if not ctx.short:
            files.append(ctx.save_figure(draw_design(d), f"identifiability_{d['label']}"))
    if notes:
        parts += [ctx.para("Skipped: " + "; ".join(notes) + "."), ""]
    return Contribution(sections=(Section("Identifiability", "\n".join(parts).rstrip(),
                                          tuple(files)),))
