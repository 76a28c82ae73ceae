"""The report's "Model error" section (issue 43, item 3) on members whose record a richer
model made: per instance the at-fit and at-truth ratios (:mod:`.ride.model_error`), read from
its shipped file, so the report computes nothing (another seed gets a line saying how).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from vpid_bench import Contribution, ReportContext, Section


def model_error_sections(ctx: ReportContext) -> Contribution | None:
    """The section (see the module); ``None`` for a problem without model error."""
    from .ride.model_error import read_ratios

    entry: Mapping[str, Any] | None = read_ratios().get(ctx.problem)
    if entry is None:
        return None
    fit_with = entry.get("fit_with") or "none in the suite"
    head = (f"The record of {ctx.escape(ctx.problem)} was made by a richer model than the "
            f"fitted one ({ctx.escape(entry['record_model'])}). What no parameter vector of "
            "the fitted model removes is the at-fit ratio below: the rms of the clean record's "
            "misfit at the fitted model's best fit, over the noise (at least 1: the model "
            "error is as large as the noise). The ratio at the truth is larger and is not the "
            f"model error. The richer fitted structure: {ctx.escape(fit_with)}. From "
            "plugins/vpid_vehicle/ride/model_error_ratios.json (`python -m "
            "vpid_vehicle.ride.model_error --write`).")
    seeds = {((r.get("problem") or {}).get("config") or {}).get("seed") for r in ctx.records}
    if seeds != {entry["seed"]}:
        return Contribution(sections=(Section("Model error", ctx.para(
            head + f" Not computed for these runs' seed (the file's is {entry['seed']}): "
            f"`python -m vpid_vehicle.ride.model_error {ctx.problem}` prints instance 0's."),),))
    at_fit, at_truth = entry["ratio_at_fit"], entry["ratio_at_truth"]
    instances = {int((r.get("instance") or {}).get("index", 0)) for r in ctx.records}
    rows = [[i, at_fit[i], at_truth[i]] for i in sorted(instances) if i < len(at_fit)]
    headers = ["instance", "model error / noise (at the fit)", "at the truth"]
    files = ctx.write_table("model_error", headers, rows)
    return Contribution(sections=(Section(
        "Model error", ctx.para(head) + "\n\n" + ctx.markdown_table(headers, rows, digits=3),
        tuple(files)),))
