"""The table of docs/study.md: per problem, which optimizers the tests do not separate.

    .venv/bin/vpid-bench-report archive/smoke -o outputs/smoke-archive-report
    .venv/bin/python tools/not_separated.py outputs/smoke-archive-report

From a full report's tables (nothing recomputed), per context in Markdown: the leader by NoRE
and those the Holm-corrected pairwise tests do not separate from it, the same among the
black-box optimizers, those that beat both references, and the family's best black-box score
with the scores whose 95 % interval overlaps it (docs/study.md).
"""

from __future__ import annotations

import argparse
import csv
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from vpid_bench.plugins import Registry

REFERENCES = ("random", "centre")


def _read(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _names(items: Iterable[str]) -> str:
    items = [f"`{i}`" for i in items]
    return ", ".join(items) if items else "none"


def separated(pairs: list[dict[str, str]], context: str, a: str, b: str) -> str | None:
    """The better of ``a`` and ``b`` when the test of their pair is significant, else None."""
    for p in pairs:
        if p["context"] == context and {p["a"], p["b"]} == {a, b}:
            return p["better"] if p["significant"] == "True" else None
    return None


def context_row(context: str, ranked: list[str], pairs: list[dict[str, str]],
                black_box: set[str]) -> list[str]:
    """The cells of one context: all optimizers' leader and group, the black-box optimizers'
    leader and group, the black-box optimizers that beat both references."""
    leader = ranked[0]
    tied = [m for m in ranked[1:] if separated(pairs, context, leader, m) is None]
    bb = [m for m in ranked if m in black_box]
    bb_tied = [m for m in bb[1:] if separated(pairs, context, bb[0], m) is None]
    beat = [m for m in bb if all(separated(pairs, context, m, r) == m for r in REFERENCES)]
    return [f"`{leader}`; not separated: {_names(tied)}",
            f"`{bb[0]}`; not separated: {_names(bb_tied)}" if bb else "",
            _names(beat)]


def score_row(family: str, scores: list[dict[str, str]], black_box: set[str]) -> str:
    """The family's best black-box score and those whose interval overlaps it."""
    rows = [s for s in scores if s["group_kind"] == "family" and s["group"] == family
            and s["algorithm"] in black_box]
    if not rows:
        return ""
    rows.sort(key=lambda s: -float(s["score_auc"]))
    best = rows[0]
    lo = float(best["score_lo"])
    overlap = [s["algorithm"] for s in rows[1:] if float(s["score_hi"]) >= lo]
    return (f"`{best['algorithm']}` {float(best['score_auc']):.3f} "
            f"[{lo:.3f}, {float(best['score_hi']):.3f}]; overlapping: {_names(overlap)}")


def main(argv: Iterable[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("report", type=Path, help="a full report's folder (-o of the report)")
    args = parser.parse_args(None if argv is None else list(argv))
    tables = args.report / "tables"
    head = _read(tables / "headline.csv")
    pairs = _read(tables / "pairwise.csv")
    scores = _read(tables / "suite_scores.csv") if (tables / "suite_scores.csv").exists() else []
    registry = Registry()
    wants = {n for n, cls in registry.optimizers.items() if getattr(cls, "wants_residuals", False)}
    problem_of: Mapping[str, str] = {r["context"]: r["problem"]
                                     for r in _read(args.report / "runs.csv")}
    print("| problem (family) | by NoRE: the leader, and those the tests do not separate from "
          "it | without residuals: the leader, and those not separated from it | without "
          "residuals: beat random search and the box centre | without residuals: best "
          "family score (AUC), and the intervals overlapping it |")
    print("| --- | --- | --- | --- | --- |")
    for context in dict.fromkeys(r["context"] for r in head):
        rows = sorted((r for r in head if r["context"] == context), key=lambda r: int(r["rank"]))
        ranked = [r["optimizer"] for r in rows]
        black_box = {m for m in ranked if m not in wants and m not in REFERENCES}
        problem = problem_of[context]
        cls: Any = registry.problems.get(problem)
        family = getattr(cls, "family", "") or problem
        cells = context_row(context, ranked, pairs, black_box)
        print(f"| `{context}` ({family}) | " + " | ".join(cells) + " | "
              + score_row(family, scores, black_box) + " |")


if __name__ == "__main__":
    main()
