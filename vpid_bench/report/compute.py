"""The report's first stage: everything it says, computed from the records as data
(:class:`ReportData`) the later stages only read; short mode imports no pandas, scipy.stats."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..progress import Stages
from . import anytime, diagnostics, estimates, load, rankings, stats, tables, ties
from .forked import run_forked
from .identifiability import crb_norm_by_context, crb_norms_by_instance, estimator_floors_by_context
from .load import LoadedRecords, NoRecordsError, by_context, load_records, reason, run_rows
from .optima import add_optimum_columns, load_optima, opt_column_names


@dataclasses.dataclass
class Tests:
    """The significance tests of a full report (pandas DataFrames and Friedman results)."""

    df: Any
    kw: Any
    pairs: Any
    fr: Any
    spairs: Any
    by_inst: dict[str, dict[str, Any]]


@dataclasses.dataclass
class ReportData:
    """What the report says, before it is written anywhere."""

    paths: list[Path]
    short: bool
    alpha: float
    baseline: str
    loaded: LoadedRecords
    rows: list[dict[str, Any]]
    summary: list[dict[str, Any]]  # by the problem's metric, per context and optimizer
    search: list[dict[str, Any]]  # by search quality, where each instance's optimum is known
    hits: list[Any]
    optima_errors: list[str]
    bounds: dict[str, float]  # per context: the norm of the Cramér–Rao bounds (%)
    centred: dict[str, bool]  # per context: is the search box centred on the truth?
    baseline_verdicts: list[str]
    tests: Tests | None = None
    #: per context: the floors of each estimator its job wrote (``estimators.json``)
    estimator_floors: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    #: one line per problem whose archived runs stand beside these (or were refused)
    archive_notes: list[str] = dataclasses.field(default_factory=list)
    #: per context: True when its problem has no truth (:mod:`.estimates`)
    no_truth: dict[str, bool] = dataclasses.field(default_factory=dict)
    #: per context without a truth: the identified values with their intervals
    identified: dict[str, Any] = dataclasses.field(default_factory=dict)
    #: per context: the problem's fixed comparison rows (never truths)
    comparisons: dict[str, list[dict[str, Any]]] = dataclasses.field(default_factory=dict)
    #: per context: each instance's own bound norm (%), keyed as the rows' ``instance``
    instance_bounds: dict[str, dict[Any, float]] = dataclasses.field(default_factory=dict)
    #: per context: the fit diagnostics at its optimum (:mod:`.diagnostics`)
    diagnostics: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)

    @property
    def contexts(self) -> list[str]:
        """The contexts, in report order."""
        return sorted({s["context"] for s in self.summary})

    @property
    def problems(self) -> list[str]:
        return sorted({r["problem"] for r in self.rows})

    def metric_rows(self, context: str) -> list[dict[str, Any]]:
        return [s for s in self.summary if s["context"] == context]

    def search_rows(self, context: str) -> list[dict[str, Any]]:
        return [s for s in self.search if s["context"] == context]

    def unit(self, context: str) -> str:
        """The unit of the context's headline metric (``""`` when the problem gave none)."""
        units = {r.get("metric_unit", "") for r in self.rows if r["context"] == context}
        return units.pop() if len(units) == 1 else ""

    def records_of(self, context: str) -> list[dict[str, Any]]:
        """The records of the context's runs."""
        ids = {r["run_id"] for r in self.rows if r["context"] == context}
        return [rec for rec in self.loaded.records if rec["run_id"] in ids]

    def estimator(self, context: str) -> str | None:
        """The objective (``problem.objective``) the context's runs share, else ``None``."""
        found = set()
        for rec in self.records_of(context):
            config = (rec.get("problem") or {}).get("config")
            found.add(config.get("objective") if isinstance(config, dict) else None)
        value = found.pop() if len(found) == 1 else None
        return value if isinstance(value, str) and value.isidentifier() and len(value) <= 32 \
            else None

    def floors(self, context: str) -> dict[Any, float]:
        """Per instance with a known optimum: its floor (the optimum's headline metric)."""
        rows = [r for r in self.rows if r["context"] == context]
        column, _ = opt_column_names(rows)
        out: dict[Any, float] = {}
        for r in rows if column else []:
            v = float(r.get(column, math.nan))
            if math.isfinite(v):
                out.setdefault(r.get("instance"), v)
        return out

    def groups(self, which: str, context: str) -> dict[str, str] | None:
        """Rank-group letters of the ``"metric"`` or ``"search"`` ranking (``None``: untested)."""
        if self.tests is None:
            return None
        items = self.metric_rows(context) if which == "metric" else self.search_rows(context)
        return {s["algorithm"]: s.get("group", "") for s in items}

    def test_name(self, which: str, context: str) -> str | None:
        if self.tests is None:
            return None
        pairs = self.tests.pairs if which == "metric" else self.tests.spairs
        return rankings.test_name(pairs, context)


def compute(paths: Sequence[str | Path], short: bool, alpha: float, baseline: str,
            archive: bool | Path = False, progress: Stages | None = None,
            keep: Callable[[dict[str, Any]], bool] | None = None) -> ReportData:
    """Load the records below ``paths`` and compute everything the report shows (raises
    :class:`~.load.NoRecordsError` without a readable record); ``archive``: add the
    archived built-ins' runs (``True``: the shipped archives; or a folder of archives);
    ``keep``: only the records it keeps (an archive's runs with some optimizers' left out)."""
    paths = [Path(p) for p in paths]
    if progress is not None:
        progress.stage("reading the records")
    loaded, given_optima = _load(paths)
    if keep is not None:
        loaded.records[:] = [r for r in loaded.records if keep(r)]
    if not loaded.records:
        extra = ""
        if loaded.skipped:  # say why, from the first one: e.g. records of an older version
            first, why = loaded.skipped[0]
            extra = (f" ({len(loaded.skipped)} unreadable; {first}: "
                     f"{' '.join(reason(first, why).split())})")
        raise NoRecordsError(
            f"no run records (records/run-*.json) below {', '.join(map(str, paths))}{extra}")
    extra_optima, notes = _add_archive(loaded, archive) if archive else ([], [])
    rows = run_rows(loaded.records)
    optima = load_optima(paths, loaded.records)
    optima.optima += given_optima + extra_optima
    optima_errors = [f"bad optimum file {p}: {why}" for p, why in optima.skipped]
    optima_errors += add_optimum_columns(rows, loaded.records, optima)
    ties.snap_ties(rows, loaded.records)  # runs at one optimum: one metric value
    summary = tables.summarize(rows)
    search = rankings.search_summary(rows)
    hits = anytime.run_hits(loaded.records, rows)
    ties.rank_with_ties(summary, anytime.costs_to_optimum(hits))
    aucs = anytime.auc_table(hits)
    for s in search:
        s["auc"] = aucs.get((s["context"], s["algorithm"]), math.nan)
    if progress is not None and not short:
        progress.stage(f"tests over {len(loaded.records):,} runs")
    tests = None if short else _tests(rows, search, alpha)
    if tests is not None:
        _set_groups(summary, tests.pairs)
        _set_groups(search, tests.spairs)
    verdicts = tables.baseline_verdicts(summary, None if tests is None else tests.pairs, baseline)
    for s, v in zip(summary, verdicts, strict=True):
        s[f"vs_{baseline}"] = v
    truthless = estimates.no_truth(loaded.records, rows)
    return ReportData(paths, short, alpha, baseline, loaded, rows, summary, search, hits,
                      optima_errors, crb_norm_by_context(loaded.records, rows),
                      rankings.box_centred(loaded.records, rows), verdicts, tests,
                      estimator_floors_by_context(loaded.records, rows), notes, truthless,
                      estimates.identified_by_context(loaded.records, rows, truthless),
                      estimates.comparisons_by_context(loaded.records, rows),
                      crb_norms_by_instance(loaded.records, rows),
                      diagnostics.by_context(loaded.records, rows))


def _load(paths: Sequence[Path]) -> tuple[LoadedRecords, list[Any]]:
    """The records below ``paths``; an archive folder among them gives its runs and optima."""
    from ..store.archive import ArchiveError, is_archive
    from ..store.archive_records import read_archive

    folders = [p for p in paths if is_archive(p)]
    rest = [p for p in paths if p not in folders]
    loaded = load_records(rest) if rest else LoadedRecords([], [], 0, {})
    optima: list[Any] = []
    for folder in folders:
        try:
            archive = read_archive(folder)
        except ArchiveError as exc:
            loaded.skipped.append((folder, str(exc)))
            continue
        seen = {r["run_id"] for r in loaded.records}
        loaded.records.extend(r for r in archive.records if r["run_id"] not in seen)
        optima += archive.optima
        for line in archive.bad:  # each skipped line named: "records.jsonl.gz:12: why"
            where, _, why = line.partition(": ")
            loaded.skipped.append((folder / where, why))
    return loaded, optima


def _add_archive(loaded: LoadedRecords, archive: bool | Path) -> tuple[list[Any], list[str]]:
    """Add the archived runs that stand beside ``loaded`` (in place): their optima, notes."""
    from ..store.archive_records import load_all
    from .archive import merge

    # only runs of one's own stand beside archived ones (an archive given as a folder to
    # report is complete in itself: :func:`.archive.merge` adds nothing to its runs)
    own = {r["problem"]["name"] for r in loaded.records if "_archive" not in r}
    if not own:
        return [], []
    archives, bad = load_all(None if archive is True else Path(archive), own)
    merged = merge(loaded.records, archives)
    loaded.records.extend(merged.records)
    # an archive that cannot be used at all (damaged, a limit crossed) is a failure of the
    # report, named once; a problem's archive refused for another version is a note
    loaded.skipped += [(Path(line.split(": ", 1)[0].removeprefix("archive ")), line)
                       for line in bad]
    return merged.optima, merged.refused + merged.used


def _tests(rows: list[dict[str, Any]], search: list[dict[str, Any]], alpha: float) -> Tests:
    df = load.runs_frame(rows)
    sdf = rankings.search_test_frame(df)
    sdf = sdf[sdf["context"].isin({s["context"] for s in search})]
    # two families of tests, each a few seconds over an archive: side by side (.forked)
    (kw, pairs, fr, by_metric), (spairs, by_gap) = run_forked([
        lambda: (stats.kruskal_by_context(df), stats.pairwise_by_context(df, alpha),
                 stats.friedman_across_blocks(df, alpha), stats.friedman_by_instances(df, alpha)),
        lambda: (stats.pairwise_by_context(sdf, alpha, "rel_gap_test"),
                 stats.friedman_by_instances(sdf, alpha, "rel_gap_test"))])
    return Tests(df=df, kw=kw, pairs=pairs, fr=fr, spairs=spairs,
                 by_inst={"metric": by_metric, "rel_gap": by_gap})


def _set_groups(items: list[dict[str, Any]], pairs: Any) -> None:
    """Each row's rank group (compact letters from the Holm-corrected pairwise tests)."""
    for context, g in by_context(items).items():
        n = "n_runs" if "n_runs" in g[0] else "n"
        order = [s["algorithm"] for s in sorted((s for s in g if s.get(n)),
                                                key=lambda s: s["rank"])]
        letters = stats.rank_groups(pairs, context, order) if order else {}
        for s in g:
            s["group"] = letters.get(s["algorithm"], "—")

