"""The report's "Which structure does the record support?" section (issue 43, item 2).

When a report holds runs of one ride record under two or more suspension structures (a sweep
``problem.spring=linear,cubic problem.damper=linear,bilinear``), each structure is refitted on
the record's first two thirds from its best run and compared on the rest
(:mod:`vpid_bench.analysis.structures`: held-out error, AIC, BIC, Ljung-Box whiteness,
identified values with 95 % intervals). Runs of one record are those whose problem settings
differ only in ``spring`` and ``damper`` (and the protocol: ``ps``, ``iterations``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from vpid_bench import Contribution, ReportContext, Section

#: Settings that shape the search, not the record.
PROTOCOL = ("ps", "iterations", "budget")
STRUCTURE = ("spring", "damper")


def record_groups(records: Sequence[Mapping[str, Any]]
                  ) -> dict[str, dict[tuple[str, str], list[Mapping[str, Any]]]]:
    """The ok runs by record (problem, settings but the structure and protocol, instance),
    then by structure ``(spring, damper)``."""
    out: dict[str, dict[tuple[str, str], list[Mapping[str, Any]]]] = {}
    for rec in records:
        if rec.get("status") != "ok" or not (rec.get("result") or {}).get("x_best"):
            continue
        problem = rec.get("problem") or {}
        config = dict(problem.get("config") or {})
        structure = (str(config.pop("spring", "linear")), str(config.pop("damper", "linear")))
        for key in PROTOCOL:
            config.pop(key, None)
        # a user's record is every instance's (no id); a simulated instance has its id
        instance = (rec.get("instance") or {}).get("id")
        key = json.dumps([problem.get("name"), config, instance], sort_keys=True, default=str)
        out.setdefault(key, {}).setdefault(structure, []).append(rec)
    return {k: v for k, v in out.items() if len(v) >= 2}


def _problem(rec: Mapping[str, Any]) -> Any:
    """The record's problem instance, rebuilt from its settings."""
    from vpid_bench.params import build_dataclass

    from .ride.full import RideFullProblem
    from .ride.half import RideHalfProblem
    from .ride.quarter import RideQuarterProblem
    from .ride.suites import MEMBERS

    classes = {c.name: c for c in (RideQuarterProblem, RideHalfProblem, RideFullProblem,
                                   *MEMBERS)}
    cls = classes[rec["problem"]["name"]]
    config = build_dataclass(cls.Config, rec["problem"]["config"], prefix="problem")
    index = int((rec.get("instance") or {}).get("index", 0))
    return cls(config).instance(index)


def compare_record(runs: Mapping[tuple[str, str], Sequence[Mapping[str, Any]]]) -> list[Any]:
    """Each structure fitted and measured (:func:`.analysis.structures.fit_structure`) from
    the best of its runs."""
    import numpy as np

    from vpid_bench.analysis.structures import fit_structure

    fits = []
    for (spring, damper), recs in sorted(runs.items()):
        best = min(recs, key=lambda r: r["result"]["f_best"])
        fits.append(fit_structure(_problem(best), f"spring={spring} damper={damper}",
                                  np.asarray(best["result"]["x_best"], dtype=float)))
    return fits


def structure_sections(ctx: ReportContext) -> Contribution | None:
    """The section (see the module); ``None`` when no record has two structures."""
    from vpid_bench.analysis import structures as S  # noqa: N812

    groups = record_groups(ctx.records)
    if not groups:
        return None
    parts, files = [], []
    for n, runs in enumerate(groups.values(), start=1):
        fits = compare_record(runs)
        first = next(iter(runs.values()))[0]
        where = first["problem"]["config"].get("reference", {}).get("file") or (
            f"{first['problem']['name']}, instance "
            f"{(first.get('instance') or {}).get('index', 0)}")
        rows = S.table_rows(fits)
        values = S.value_rows(fits)
        files += ctx.write_table(f"structures_{n}", S.TABLE_HEADERS, rows)
        files += ctx.write_table(f"structure_values_{n}", S.VALUE_HEADERS, values)
        parts.append("\n\n".join([
            f"Record: {ctx.escape(where)}.",
            ctx.para(S.verdict(fits, ctx.alpha)),
            ctx.markdown_table(S.TABLE_HEADERS, rows),
            ctx.markdown_table(S.VALUE_HEADERS, values)]))
    text = "\n\n".join([ctx.para(
        "Each structure refitted (least squares) on each channel's first "
        f"{S.FIT_FRACTION:.3g} of samples from its best run, and judged on the rest: held-out "
        "error (Eq. 3 on the samples no fit saw), ΔAIC and ΔBIC from the best (each channel's "
        f"variance profiled out), the Ljung-Box whiteness p-value ({S.LAGS} lags, Bonferroni "
        "over channels; white when at least the report's alpha), the identified values with "
        "95 % Gauss-Newton intervals (none, nan, for a parameter left on a bound of the box). "
        "docs/own-record.md, \"Which structure does my record support?\"."), *parts])
    return Contribution(sections=(Section("Which structure does the record support?", text,
                                          tuple(files)),))
