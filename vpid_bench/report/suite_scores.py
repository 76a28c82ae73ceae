"""Across the suite: runtime ECDFs aggregated over problems and targets on evaluations/D, each
context weighing the same, and a score per optimizer and group (all, per family, per
dimension): the mean over contexts of its AUC (:func:`.anytime.auc`), with a 95 % percentile
bootstrap interval over the runs (2,000 draws, seed 0), and the share solved by the end. Only
optimizers that ran every context of a group are scored in it; the others are named."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .anytime import RunHits, auc, context_budget, ecdf
from .figures import _plt, save
from .load import grouped
from .styles import lookup

#: Bootstrap draws of the score interval, and the interval's level.
N_BOOT = 2000
LEVEL = 0.95
HEADERS = ["group_kind", "group", "algorithm", "contexts", "runs", "score_auc", "score_lo",
           "score_hi", "solved"]


@dataclasses.dataclass(frozen=True)
class Group:
    """A set of contexts scored together: its kind (``all``, ``family``, ``dimension``)."""

    kind: str
    name: str
    contexts: tuple[str, ...]


def context_facts(records: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]],
                  family_of: Callable[[str], str]) -> dict[str, tuple[str, int]]:
    """Per context: (family, dimension), from its first record (``family_of(problem)``)."""
    by_id = {r["run_id"]: r for r in records}
    out: dict[str, tuple[str, int]] = {}
    for row in rows:
        if row["context"] in out:
            continue
        rec = by_id.get(row["run_id"]) or {}
        dim = len(((rec.get("parameters") or {}).get("names")) or [])
        out[row["context"]] = (family_of(row["problem"]) or row["problem"], dim)
    return out


def groups(facts: Mapping[str, tuple[str, int]]) -> list[Group]:
    """All contexts, then a group per family and per dimension where these are not all one."""
    ctx = tuple(sorted(facts))
    out = [Group("all", "all problems", ctx)]
    for kind, key in (("family", 0), ("dimension", 1)):
        values = sorted({facts[c][key] for c in ctx}, key=str)
        if len(values) < 2:
            continue
        for v in values:
            out.append(Group(kind, f"D={v}" if kind == "dimension" else str(v),
                             tuple(c for c in ctx if facts[c][key] == v)))
    return out


def _by(runs: Sequence[RunHits]) -> dict[str, dict[str, list[RunHits]]]:
    return {alg: grouped(rs, lambda r: r.context)
            for alg, rs in grouped(runs, lambda r: r.algorithm).items()}


def _budgets(runs: Sequence[RunHits]) -> dict[str, float]:
    """Each context's budget (evaluations), the one every fixed-budget reading is up to."""
    return {c: context_budget(runs, c) for c in {r.context for r in runs}}


def score(per_context: Mapping[str, list[RunHits]], budgets: Mapping[str, float],
          rng: np.random.Generator) -> tuple[float, float, float, float]:
    """(score, low, high, solved) of one optimizer over its contexts (see the module)."""
    values = [np.array([auc([r], budgets[c]) for r in g]) for c, g in per_context.items()]
    mean = float(np.mean([v.mean() for v in values]))
    boot = np.zeros(N_BOOT)
    for v in values:
        boot += v[rng.integers(0, v.size, (N_BOOT, v.size))].mean(axis=1)
    boot /= len(values)
    lo, hi = np.quantile(boot, [(1 - LEVEL) / 2, (1 + LEVEL) / 2])
    solved = float(np.mean([np.isfinite(np.asarray([r.hits for r in g], float)).mean()
                            for g in per_context.values()]))
    return mean, float(lo), float(hi), solved


def score_rows(runs: Sequence[RunHits], facts: Mapping[str, tuple[str, int]]
               ) -> tuple[list[list[Any]], list[str]]:
    """The rows of ``tables/suite_scores.csv`` (best first within each group) and one line
    per optimizer left out of a group for not having run all of it."""
    by_alg = _by(runs)
    budgets = _budgets(runs)
    rows, notes = [], []
    for g in groups({c: f for c, f in facts.items() if c in budgets}):
        scored = []
        for alg, per in sorted(by_alg.items()):
            missing = [c for c in g.contexts if c not in per]
            if missing:
                if g.kind == "all":
                    notes.append(f"{alg} is not scored across the suite: it has no runs "
                                 f"with known optima on {', '.join(missing[:3])}"
                                 + (" ..." if len(missing) > 3 else ""))
                continue
            rng = np.random.default_rng(0)
            s, lo, hi, solved = score({c: per[c] for c in g.contexts}, budgets, rng)
            n = sum(len(per[c]) for c in g.contexts)
            scored.append([g.kind, g.name, alg, len(g.contexts), n, s, lo, hi, solved])
        rows += sorted(scored, key=lambda r: (-r[5], r[2]))
    return rows, notes


def aggregated_ecdf(per_context: Mapping[str, list[RunHits]], dims: Mapping[str, int],
                    grid: np.ndarray) -> np.ndarray:
    """The mean over contexts of each context's ECDF at ``grid`` evaluations/D."""
    return np.mean([ecdf(g, grid * max(dims[c], 1)) for c, g in per_context.items()], axis=0)


def figure(runs: Sequence[RunHits], facts: Mapping[str, tuple[str, int]], path: Path,
           style_of: Mapping[str, Any] | None = None) -> Path | str:
    """Aggregated ECDFs: a panel for all problems, one per family (up to five)."""
    budgets = _budgets(runs)
    gs = [g for g in groups({c: f for c, f in facts.items() if c in budgets})
          if g.kind in ("all", "family")][:6]
    if len(gs[0].contexts) < 2:
        return "needs runs with known optima on two or more problems"
    dims = {c: facts[c][1] for c in budgets}
    top = max(budgets[c] / max(dims[c], 1) for c in budgets)
    grid = np.geomspace(min(1.0 / max(dims.values()), 0.1), max(top, 1.0), 300)
    cols = min(len(gs), 3)
    nrows = math.ceil(len(gs) / cols)
    fig, axes = _plt().subplots(nrows, cols, figsize=(5.2 * cols, 3.8 * nrows), squeeze=False)
    by_alg = _by(runs)
    look = lookup(style_of, by_alg)
    for ax, g in zip(axes.ravel(), gs):
        for alg, per in sorted(by_alg.items()):
            if all(c in per for c in g.contexts):
                ax.step(grid, aggregated_ecdf({c: per[c] for c in g.contexts}, dims, grid),
                        where="post", **look[alg].mpl(), label=alg)
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(f"{g.name} ({len(g.contexts)} problem(s))", fontsize=9)
        ax.set_xlabel("evaluations / D (log scale)")
        ax.set_ylabel("share of (run, target) pairs")
        ax.grid(True, which="major", alpha=0.3)
    for ax in axes.ravel()[len(gs):]:
        ax.set_visible(False)
    handles, labels = axes.ravel()[0].get_legend_handles_labels()
    # one legend for every panel, beside them: every line's colour, dashes and marker
    fig.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.0, 0.95), fontsize=8,
               handlelength=3.4, title="optimizer", title_fontsize=8)
    fig.suptitle("Runtime ECDFs aggregated over problems and targets (rel_gap 1 … 1e-6), "
                 "each problem weighing the same", fontsize=10)
    fig.tight_layout()
    return save(fig, path)


def family_lookup(registry: Any) -> Callable[[str], str]:
    """``problem name -> family`` from the registry's problem classes (``""`` when unknown)."""
    problems = getattr(registry, "problems", {}) or {}

    def family(name: str) -> str:
        value = getattr(problems.get(name), "family", "")
        return value if isinstance(value, str) and len(value) <= 60 else ""
    return family


#: The budget ladder: evaluations per dimension at which fixed-budget results are read off
#: the runs' traces (log-spaced, as COCO's budgets of 10·D, 100·D, ...).
LADDER: tuple[int, ...] = (10, 100, 1000, 10000)
LADDER_HEADERS = ["group", "algorithm", *[f"solved_at_{k}D" for k in LADDER]]


def ladder_rows(runs: Sequence[RunHits], facts: Mapping[str, tuple[str, int]]) -> list[list[Any]]:
    """Per optimizer that ran every context, the aggregated ECDF at each rung of
    :data:`LADDER` (``nan`` beyond some context's budget)."""
    budgets = _budgets(runs)
    dims = {c: max(facts[c][1], 1) for c in budgets}
    beyond = [any(k * dims[c] > budgets[c] for c in budgets) for k in LADDER]
    return [["all problems", alg, *[math.nan if b else float(v) for v, b in zip(
                aggregated_ecdf(per, dims, np.asarray(LADDER, float)), beyond, strict=True)]]
            for alg, per in sorted(_by(runs).items()) if set(per) == set(budgets)]


#: The headers a reader sees of the scores (the CSV keeps :data:`HEADERS`).
SCORE_SHOWN = ["rank", "optimizer", "score (mean AUC, 0 to 1)", "95 % interval",
               "solved by the end (%)", "runs"]
GROUP_SHOWN = ["group", *SCORE_SHOWN]


def score_table(rows: Sequence[Sequence[Any]], kind: str = "all"
                ) -> tuple[list[str], list[list[Any]]]:
    """The scores of one kind of group as a reader sees them, best first within each group."""
    out: list[list[Any]] = []
    for name in dict.fromkeys(r[1] for r in rows if r[0] == kind):
        ranked = sorted((r for r in rows if r[0] == kind and r[1] == name),
                        key=lambda r: (-float(r[5]), r[2]))
        for k, r in enumerate(ranked, 1):  # three decimals (as text), solved in whole percent
            group = f"{r[1]} ({r[3]} problem{'s' if r[3] != 1 else ''})"
            out.append(([] if kind == "all" else [group]) + [
                k, r[2], f"{float(r[5]):.3f}", f"[{r[6]:.3f}, {r[7]:.3f}]",
                round(100 * float(r[8])), r[4]])
    return (SCORE_SHOWN if kind == "all" else GROUP_SHOWN), out


def ladder_table(ladder: Sequence[Sequence[Any]], rows: Sequence[Sequence[Any]]
                 ) -> tuple[list[str], list[list[Any]]]:
    """The budget ladder as a reader sees it: a column per rung some run reached, in whole
    percent, the optimizers by their suite score."""
    keep = [k for k in range(len(LADDER)) if any(math.isfinite(r[2 + k]) for r in ladder)]
    score = {r[2]: float(r[5]) for r in rows if r[0] == "all"}
    order = sorted(ladder, key=lambda r: (-score.get(r[1], -math.inf), r[1]))
    headers = ["optimizer", *[f"solved by {LADDER[k]:,}·D (%)" for k in keep]]
    return headers, [[r[1], *[round(100 * r[2 + k]) if math.isfinite(r[2 + k]) else None
                              for k in keep]] for r in order]
