"""The report's "Which structure does the record support?" section (issue 43, item 2): runs
of one ride record under two or more structures, each refitted on the first two thirds from
its best run and compared on the rest (``vpid_bench.fit_structure``, ``structure_summary``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

from vpid_bench import Contribution, ReportContext, Section

#: Settings that shape the search, not the record.
PROTOCOL = ("ps", "iterations", "budget")


def record_groups(records: Sequence[Mapping[str, Any]]
                  ) -> dict[str, dict[tuple[str, str], list[Mapping[str, Any]]]]:
    """The ok runs by record (settings but structure and protocol), then by structure."""
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
    from .ride.full import RideFullProblem
    from .ride.half import RideHalfProblem
    from .ride.problem import RecordFileConfig
    from .ride.quarter import RideQuarterProblem
    from .ride.suites import MEMBERS

    classes = {c.name: c for c in (RideQuarterProblem, RideHalfProblem, RideFullProblem,
                                   *MEMBERS)}
    cls = classes[rec["problem"]["name"]]
    settings = dict(rec["problem"]["config"])
    reference = RecordFileConfig(**settings.pop("reference", {}))
    config = cls.Config(**settings, reference=reference)
    index = int((rec.get("instance") or {}).get("index", 0))
    return cls(config).instance(index)


def compare_record(runs: Mapping[tuple[str, str], Sequence[Mapping[str, Any]]]) -> list[Any]:
    """Each structure fitted and measured from the best of its runs."""
    import numpy as np

    from vpid_bench import fit_structure

    fits = []
    for (spring, damper), recs in sorted(runs.items()):
        best = min(recs, key=lambda r: r["result"]["f_best"])
        fits.append(fit_structure(_problem(best), f"spring={spring} damper={damper}",
                                  np.asarray(best["result"]["x_best"], dtype=float)))
    return fits


def structure_sections(ctx: ReportContext) -> Contribution | None:
    """The section (see the module); ``None`` when no record has two structures."""
    from vpid_bench import structure_summary

    groups = record_groups(ctx.records)
    if not groups:
        return None
    parts, files, method = [], [], ""
    for n, runs in enumerate(groups.values(), start=1):
        summary = structure_summary(compare_record(runs), ctx.alpha)
        method = summary.method
        first = next(iter(runs.values()))[0]
        where = (first["problem"]["config"].get("reference") or {}).get("file") or (
            f"{first['problem']['name']}, instance "
            f"{(first.get('instance') or {}).get('index', 0)}")
        files += ctx.write_table(f"structures_{n}", *summary.table)
        files += ctx.write_table(f"structure_values_{n}", *summary.values)
        parts.append("\n\n".join([
            f"Record: {ctx.escape(where)}.", ctx.para(summary.verdict),
            ctx.markdown_table(*summary.table), ctx.markdown_table(*summary.values)]))
    text = "\n\n".join([ctx.para(method + " docs/own-record.md, \"Which structure does my "
                                 "record support?\"."), *parts])
    return Contribution(sections=(Section("Which structure does the record support?", text,
                                          tuple(files)),))
