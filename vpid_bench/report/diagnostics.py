"""The report's fit diagnostics: does the fitted model explain the record, and which interval
can be trusted? From each job's ``diagnostics.json`` (:mod:`vpid_bench.analysis.diagnostics`,
untrusted: a field of the wrong type is left out), per context: one plain line where the
model does not explain the record (:func:`plain_line`), a table per channel, the white-noise
and robust intervals and which is trusted; the residual figure is a core section
(:func:`section`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.diagnostics import MISFIT
from ..analysis.intervals import Z95
from ..store.job_checks import read_diagnostics
from ..store.job_files import DIAGNOSTICS
from .figures import _plt
from .render import fmt
from .safe import escape
from .sections import Contribution, Section

TITLE = "Fit diagnostics: residual autocorrelation and cross-correlation"


def by_context(records: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]]
               ) -> dict[str, dict[str, Any]]:
    """Per context, the readable ``diagnostics.json`` of its jobs at the lowest objective."""
    by_id = {r["run_id"]: r for r in records}
    found: dict[str, dict[str, Any]] = {}
    tried: set[Path] = set()
    for row in rows:
        rec = by_id.get(row["run_id"])
        path = None if rec is None else Path(str(rec.get("_job_dir", "."))) / DIAGNOSTICS
        if path is None or path in tried:
            continue
        tried.add(path)
        data, old = read_diagnostics(path), found.get(row["context"])
        if data is not None and (old is None or data["f"] < old["f"]):
            found[row["context"]] = data
    return found


def plain_line(diag: Mapping[str, Any]) -> str:
    """ONE plain line when the model does not explain the record, else ``""``."""
    if diag["explained"]:
        return ""
    bad = [g for g in diag["groups"] if g["correlated"]]
    inputs = [g for g in diag["groups"] if g["input_correlated"]]
    if bad:
        w = max(bad, key=lambda g: abs(g["lag1"]))
        where = f"{escape(w['name'])}: " if len(diag["groups"]) > 1 else ""
        text = (f"The residuals are correlated ({where}lag-1 {fmt(w['lag1'], 3)}, "
                f"{len(bad)} of {len(diag['groups'])} channel(s) fail the whiteness test): the "
                "model misses dynamics the record holds; the white-noise intervals are too "
                "narrow")
    else:
        text = ("The residuals follow an input (their cross-correlation leaves its 99 % "
                "band): the model misses how the record responds to it; the white-noise "
                "intervals are too narrow")
    if bad and inputs:
        text += ", and the residuals follow an input"
    return text + "."


def trust_text(diag: Mapping[str, Any], model_error: str = "") -> str:
    """Which interval the report trusts, and why (with model error: it describes the fitted
    model, not the system that made the record)."""
    iv = diag.get("intervals")
    if iv is None:
        return ""
    ratios = [r / s for r, s in zip(iv["robust_se"], iv["se"], strict=True)
              if r is not None and s is not None and s > 0]
    spread = (f" (robust/white half-width {fmt(min(ratios), 2)} to {fmt(max(ratios), 2)})"
              if ratios else "")
    lags = f", {iv['lags']} lags" if iv.get("lags") else ""
    if diag["explained"]:
        text = ("Intervals: the white-noise (Jacobian) interval is trusted: the residuals pass "
                f"the whiteness test, and the robust (HAC{lags}) interval agrees{spread}.")
    else:
        text = ("Intervals: the robust (HAC: the wider of the plain and the prewhitened "
                f"Newey–West sandwich{lags}) interval is trusted{spread}; the white-noise "
                "(Jacobian) interval counts every sample as independent, which correlated "
                "residuals are not.")
    if model_error or not diag["explained"]:
        why = (f"the record was made by a richer model ({escape(model_error)})" if model_error
               else "the residuals show model error")
        text += (f" With model error ({why}), an interval describes the fitted model's "
                 "best fit to this record, not the system that made it: its true values may "
                 "lie outside both.")
    return text


def channel_rows(diag: Mapping[str, Any]) -> tuple[list[str], list[list[Any]]]:
    """Per channel: residual rms against the signal's and the noise's, lag-1
    autocorrelation, whiteness test, and the largest cross-correlation with an input."""
    headers = ["channel", "residual rms", "% of signal rms", "noise σ", "rms / σ",
               "lag-1 (99 % band)", "Ljung–Box p", "max |xcorr| with an input (band)"]
    rows = []
    for g in diag["groups"]:
        cross = max(g["cross"].items(), key=lambda kv: kv[1]["max_abs"] / kv[1]["band99"],
                    default=None)
        rows.append([
            escape(g["name"]), g["rms"],
            100 * g["rms_over_signal"] if math.isfinite(g["rms_over_signal"]) else None,
            f"{fmt(g['sigma'], 3)} ({g['sigma_source']})", g["rms_over_sigma"],
            f"{fmt(g['lag1'], 3)} (±{fmt(g['band99'], 2)})", g["ljung_box_p"],
            "" if cross is None else
            f"{fmt(cross[1]['max_abs'], 2)} at lag {int(cross[1]['lag_at_max'])} with "
            f"{escape(cross[0])} (±{fmt(cross[1]['band99'], 2)})"])
    return headers, rows


def interval_rows(diag: Mapping[str, Any]) -> tuple[list[str], list[list[Any]]]:
    """Per parameter: the value at the optimum, the white and robust 95 % half-widths (%)."""
    iv = diag["intervals"]
    headers = ["parameter", "value at the optimum", "± % white", "95 % interval (robust, HAC)",
               "± % robust", "robust / white"]
    rows = []
    for name, x, s, r in zip(diag["names"], diag["x"], iv["se"], iv["robust_se"], strict=True):
        def pct(v: float | None, x: float = x) -> float | None:
            return None if v is None or x == 0 else 100.0 * Z95 * v / abs(x)
        rows.append([escape(name), x, pct(s),
                     "[open, open]" if r is None else
                     f"[{fmt(x - Z95 * r)}, {fmt(x + Z95 * r)}]", pct(r),
                     r / s if r is not None and s else None])
    return headers, rows


def blocks(diag: Mapping[str, Any] | None, model_error: str = ""
           ) -> list[tuple[str, list[str], list[list[Any]]]]:
    """The first screen's fit-diagnostics blocks of one context, ``(Markdown text, headers,
    rows)``: the channel table, then the intervals and which is trusted."""
    if diag is None:
        return []
    worst = max(diag["groups"], key=lambda g: abs(g["lag1"]))
    head = plain_line(diag) or (f"The residuals look like noise (lag-1 {fmt(worst['lag1'], 3)}, "
                                "every channel passes the whiteness test): the model explains "
                                "the record.")
    misfit = [x["name"] for x in diag["groups"] if x["misfit"]]
    if misfit:
        head += (f" The residual exceeds {MISFIT:g} noise σ on {', '.join(map(escape, misfit))}"
                 ": a misfit beyond the noise.")
    held = diag.get("held_out")
    if held:
        unit = held.get("unit")
        unit = f" {escape(unit[:16])}" if isinstance(unit, str) and unit else ""
        head += (f" Held out: error {fmt(held['error'], 3)}{unit} against "
                 f"{fmt(held['naive'], 3)}{unit} for a naive predictor.")
    out = [(f"Fit diagnostics at the optimum: {head}", *channel_rows(diag))]
    trust = trust_text(diag, model_error)
    if trust:
        out.append((trust, *interval_rows(diag)))
    return out


def draw(diag: Mapping[str, Any], title: str) -> Any:
    """Per channel: the residual's autocorrelation and its cross-correlation with each input,
    each with its 99 % band."""
    groups = diag["groups"]
    fig, axes = _plt().subplots(len(groups), 2, figsize=(9, 2.4 * len(groups) + 0.8),
                             squeeze=False)
    for (ax, axc), g in zip(axes, groups, strict=True):
        rho = np.asarray(g["acf"])
        lags = np.arange(1, rho.size)
        ax.vlines(lags, 0, rho[1:], color="C0")
        ax.axhspan(-g["band99"], g["band99"], color="0.85", label="99 % band (white)")
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_title(f"{g['name']}: autocorrelation of the residual", fontsize=9)
        ax.set_xlabel("lag (samples)")
        for i, (name, c) in enumerate(g["cross"].items()):
            v = np.asarray(c["ccf"])
            k = np.arange(v.size) - v.size // 2
            axc.plot(k, v, marker=".", lw=0.8, color=f"C{i + 1}", label=name)
            axc.hlines([-c["band99"], c["band99"]], k[0], k[-1], colors=f"C{i + 1}", lw=0.6,
                       linestyles="--")
        axc.axhline(0, color="0.5", lw=0.6)
        axc.set_title(f"{g['name']}: cross-correlation with each input (dashed: 99 % band)",
                      fontsize=9)
        axc.set_xlabel("lag k (samples): residual at t against input at t − k")
        if g["cross"]:
            axc.legend(fontsize=7)
        else:
            axc.text(0.5, 0.5, "no input exposed", ha="center", transform=axc.transAxes)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    return fig


def section(ctx: Any) -> Any:
    """The residual figure of the problem's best context (full report only)."""
    if ctx.short:
        return None
    found = by_context(ctx.records, ctx.rows)
    if not found:
        return None
    context, diag = min(found.items(), key=lambda kv: kv[1]["f"])
    png = ctx.save_figure(draw(diag, f"Residuals at the optimum, {context}"),
                          f"residuals_{ctx.problem}")
    text = ctx.para(
        f"The residuals at the optimum of {ctx.escape(context)} (objective "
        f"{ctx.fmt(diag['f'])}), per channel: their autocorrelation and their "
        "cross-correlation with each input the problem exposes. White residuals stay inside "
        "the grey 99 % band at 99 % of the lags; bars beyond it say the model misses dynamics "
        "the record holds, a cross-correlation beyond its dashed band (Bartlett's, which "
        "allows for both series' autocorrelation) says how the record responds to that input. "
        "Command: the job's `diagnostics.json`, drawn by `vpid-bench-report`.")
    return Contribution(sections=(Section(TITLE, text, (png,)),))
