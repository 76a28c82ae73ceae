"""The advice per family and per budget that an archive supports, as a Markdown section for
docs/study.md, regenerated from the archive alone (nothing is run).

    MPLBACKEND=Agg .venv/bin/python tools/archive_advice.py archive/vpid1 \\
        [-o docs/study/vpid1-advice]

Writes (and prints) ``<out>/advice.md``, with ``ladder.csv``, ``scores.csv`` and the figure
``ecdf_families.png``: per group (all problems, each family) the report's aggregated ECDF at
the budget ladder's rungs, each optimizer's score, those not separated from the leader (all,
and black-box only: :func:`not_separated`) and the caveats with the archive's own facts
(what each means: docs/study.md).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.stats import bootstrap

from vpid_bench.errors import VpidBenchError
from vpid_bench.plugins import Registry
from vpid_bench.report import suite_scores as ss
from vpid_bench.report.anytime import RunHits, auc, run_hits
from vpid_bench.report.archive import budgets_per_dim
from vpid_bench.report.compute import compute
from vpid_bench.store.archive import ArchiveError
from vpid_bench.store.archive_records import read_archive

RESAMPLES = 10_000


def rung_rows(runs: Sequence[RunHits], facts: dict[str, tuple[str, int]]) -> list[list[Any]]:
    """Per group (all, each family) and optimizer that ran all of it: the aggregated ECDF at
    each rung of :data:`~vpid_bench.report.suite_scores.LADDER` (``nan`` beyond a problem's
    budget)."""
    budgets = {c: ss.context_budget(runs, c) for c in {r.context for r in runs}}
    by_alg: dict[str, dict[str, list[RunHits]]] = {}
    for r in runs:
        by_alg.setdefault(r.algorithm, {}).setdefault(r.context, []).append(r)
    out = []
    for g in ss.groups({c: f for c, f in facts.items() if c in budgets}):
        if g.kind == "dimension":
            continue
        dims = {c: max(facts[c][1], 1) for c in g.contexts}
        grid = np.asarray(ss.LADDER, float)
        beyond = [any(k * dims[c] > budgets[c] for c in g.contexts) for k in ss.LADDER]
        for alg, per in sorted(by_alg.items()):
            if not all(c in per for c in g.contexts):
                continue
            values = ss.aggregated_ecdf({c: per[c] for c in g.contexts}, dims, grid)
            out.append([g.name, len(g.contexts), alg,
                        *[math.nan if b else float(v) for v, b in zip(values, beyond,
                                                                      strict=True)]])
    return out


def run_aucs(data: Any, contexts: Sequence[str]) -> dict[str, dict[tuple[str, str], float]]:
    """Per optimizer, the AUC of each of its runs on ``contexts`` by (context, instance id):
    runs of two optimizers on the same instance pair."""
    by_id = {r["run_id"]: r for r in data.loaded.records}
    budgets = {c: ss.context_budget(data.hits, c) for c in contexts}
    out: dict[str, dict[tuple[str, str], float]] = {}
    for row in data.rows:
        if row["context"] not in budgets:
            continue
        for r in run_hits([by_id[row["run_id"]]], [row]):
            key = (row["context"], str(row.get("instance")))
            out.setdefault(row["algorithm"], {})[key] = auc([r], budgets[row["context"]])
    return out


def not_separated(aucs: dict[str, dict[tuple[str, str], float]],
                  score_rows: Sequence[Sequence[Any]], group: str,
                  leave_out: frozenset[str] = frozenset()
                  ) -> tuple[str, list[tuple[str, float, float]]]:
    """The group's leader and, for every other optimizer scored in it, the 95 % paired
    bootstrap interval of (leader - it) in per-run AUC over the (problem, instance) pairs
    both ran; the leader first. Optimizers in ``leave_out`` take no part (the black-box
    comparison leaves out those that use the residuals)."""
    scored = [r for r in score_rows if r[1] == group and r[2] not in leave_out]
    if not scored:
        return "", []
    leader = scored[0][2]  # score_rows are best first within each group
    mine = aucs.get(leader, {})
    out = []
    for row in scored[1:]:
        theirs = aucs.get(row[2], {})
        d = np.array([mine[k] - theirs[k] for k in sorted(set(mine) & set(theirs))])
        if d.size < 2:  # nothing to resample: not separated
            lo = hi = math.nan
        elif np.all(d == d[0]):
            lo = hi = float(d[0])
        else:
            ci = bootstrap((d,), np.mean, confidence_level=0.95, n_resamples=RESAMPLES,
                           method="percentile", random_state=0).confidence_interval
            lo, hi = float(ci.low), float(ci.high)
        out.append((row[2], lo, hi))
    return leader, out


def _fmt(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{v:.2f}"


def _names(names: Sequence[str]) -> str:
    """``"`a`, `b`"``, in the order given, or ``"none"``."""
    return ", ".join(f"`{n}`" for n in names) or "none"


def residual_users(names: Sequence[str]) -> frozenset[str]:
    """The optimizers among ``names`` whose installed class sets ``wants_residuals`` (they
    need a problem that offers residuals; one not installed here counts as black-box)."""
    registry, out = Registry(), set()
    for name in names:
        try:
            if getattr(registry.optimizer(name), "wants_residuals", False):
                out.add(name)
        except VpidBenchError:
            continue
    return frozenset(out)


def markdown(folder: Path, manifest: dict[str, Any], ladder: list[list[Any]],
             scores: list[list[Any]], separated: dict[str, tuple[str, list]],
             caveats: list[str], figure: str,
             black_box: dict[str, tuple[str, list]] | None = None,
             users: frozenset[str] = frozenset()) -> list[str]:
    black_box = black_box or {}
    rungs = [k for k in ss.LADDER if any(math.isfinite(r[3 + ss.LADDER.index(k)]) for r in ladder)]
    lines = [f"Made from `{folder}` (nothing run) by "
             f"`python tools/archive_advice.py {folder}`; the archive was made by "
             f"vpid-bench {manifest.get('vpid_bench_version')}, commit "
             f"{str(manifest.get('commit'))[:12]}, {manifest.get('made_at')}.", ""]
    for group in dict.fromkeys(r[0] for r in ladder):
        rows = sorted((r for r in ladder if r[0] == group),
                      key=lambda r: [-(r[3 + ss.LADDER.index(k)] if math.isfinite(
                          r[3 + ss.LADDER.index(k)]) else -1) for k in reversed(rungs)])
        n = rows[0][1]
        lines += [f"**{group}** ({n} problem{'s' if n != 1 else ''}): share of (run, target) "
                  "pairs solved by each budget, and the score (mean AUC, 95 % interval)", "",
                  "| optimizer | " + " | ".join(f"{k:,}·D" for k in rungs)
                  + " | score [95 % interval] |",
                  "| --- | " + " | ".join("---" for _ in rungs) + " | --- |"]
        by_alg = {r[2]: r for r in scores if r[1] == group}
        for r in rows:
            s = by_alg.get(r[2])
            score = f"{s[5]:.3f} [{s[6]:.3f}, {s[7]:.3f}]" if s else "not scored"
            lines.append(f"| `{r[2]}` | "
                         + " | ".join(_fmt(r[3 + ss.LADDER.index(k)]) for k in rungs)
                         + f" | {score} |")
        leader, others = separated.get(group, ("", []))
        tied = [name for name, lo, _ in others if not (lo > 0)]
        lines += ["", f"Not separated from the leader `{leader}` (the 95 % paired interval "
                  f"of the difference in per-run AUC contains 0): {_names(tied)}."]
        box_leader, box_others = black_box.get(group, ("", []))
        if box_leader and box_leader != leader:
            box_tied = [name for name, lo, _ in box_others if not (lo > 0)]
            lines += ["", f"Without residuals (leaving out {_names(sorted(users))}): the "
                      f"leader is `{box_leader}`; not separated from it: {_names(box_tied)}."]
        lines += [""]
    lines += [f"![ECDFs per family]({figure})", "", "Caveats:", ""]
    lines += [f"- {c}" for c in caveats] + [""]
    return lines


def caveats(manifest: dict[str, Any], records: list[dict[str, Any]]) -> list[str]:
    """The protocol's caveats, with the archive's own numbers."""
    per_cell: dict[tuple[str, str], int] = {}
    objectives, stops = set(), 0
    for r in records:
        key = (r["problem"]["name"], r["optimizer"]["name"])
        per_cell[key] = per_cell.get(key, 0) + 1
        cfg = r["problem"].get("config") or {}
        objectives.add(str(cfg.get("objective", "the problem's own")))
        stops += (r.get("result") or {}).get("stopped_by") == "target"
    n = sorted(set(per_cell.values()))
    return [
        f"{'-'.join(map(str, n[:1] + n[-1:] if len(n) > 1 else n))} instance(s) per problem and "
        "optimizer (truth, road and noise drawn per instance, shared by every optimizer): a "
        "small sample; the intervals say how small.",
        f"Budgets: {', '.join(f'{b:,}·D' for b in budgets_per_dim(records))} per run; the "
        "rungs are read off the same runs, so a rung says how far each run had got by then, "
        "not what a run given that budget would have done (a method that adapts to its "
        "budget, such as the paper's DE with a fixed number of generations, is not re-run "
        "at each rung).",
        f"{stops} of {len(records)} runs stopped at the final target (`target=`, "
        "docs/protocol.md): their fixed-target results are those of the whole run; their "
        "fixed-budget columns are those at the stop.",
        f"Objective: {', '.join(sorted(objectives))} (each member's default); another "
        "estimator has other optima and other floors (docs/estimators.md).",
        "Each optimizer runs at its library's or paper's defaults (docs/protocol.md, who was "
        "configured how); none was tuned on these instances, and a tuned method may rank "
        "otherwise.",
        "Every problem weighs the same in a family's ECDF and score, whatever its dimension; "
        "a family of one problem says something about that problem only.",
        "Scores and ECDFs measure search (reaching each instance's optimum of the objective), "
        "not identification: how near the truth an optimum lies is the problem's floor, in "
        "the report's first screen.",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("archive", type=Path)
    ap.add_argument("-o", "--out", type=Path, default=None,
                    help="folder for advice.md, the tables and the figure "
                         "(default: docs/study/<suite>-advice)")
    args = ap.parse_args()
    try:
        arch = read_archive(args.archive)
    except ArchiveError as exc:  # one line, as vpid-bench-report says it
        raise SystemExit(f"error: {exc}") from None
    out = args.out or Path(__file__).resolve().parents[1] / "docs" / "study" / \
        f"{arch.suite}-advice"
    out.mkdir(parents=True, exist_ok=True)
    data = compute([args.archive], True, 0.05, "random")
    facts = ss.context_facts(data.loaded.records, data.rows, ss.family_lookup(Registry()))
    scores, _ = ss.score_rows(data.hits, facts)
    ladder = rung_rows(data.hits, facts)
    groups = {g.name: g.contexts for g in ss.groups(facts) if g.kind != "dimension"}
    users = residual_users(sorted({r[2] for r in scores}))
    aucs = {name: run_aucs(data, contexts) for name, contexts in groups.items()}
    separated = {name: not_separated(aucs[name], scores, name) for name in groups}
    black_box = {name: not_separated(aucs[name], scores, name, users) for name in groups}
    fig = ss.figure(data.hits, facts, out / "ecdf_families.png")
    for name, headers, rows in (
            ("ladder.csv", ["group", "problems", "algorithm",
                            *[f"solved_at_{k}D" for k in ss.LADDER]], ladder),
            ("scores.csv", ss.HEADERS, scores)):
        with open(out / name, "w", newline="", encoding="utf-8") as fh:
            csv.writer(fh).writerows([headers, *rows])
    lines = markdown(args.archive, dict(arch.manifest), ladder, scores, separated,
                     caveats(dict(arch.manifest), arch.records),
                     Path(fig).name if isinstance(fig, Path) else str(fig),
                     black_box, users)
    (out / "advice.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    print(json.dumps({"written": [str(out / n) for n in ("advice.md", "ladder.csv",
                                                        "scores.csv", "ecdf_families.png")]}))


if __name__ == "__main__":
    main()
