"""The report as one model, filled in stages by :func:`.build.build_report`: everything its
renderers (terminal, ``report.md``, the HTML site) show, which they only format."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from .sections import HeadlineColumn, Section


@dataclasses.dataclass(frozen=True)
class PlacedSection:
    """A report section with its problem and the plugin that made it (``vpid-bench``)."""

    plugin: str
    problem: str
    section: Section


@dataclasses.dataclass
class SuiteScores:
    """The scores across the suite (:mod:`.suite_scores`), the budget ladder and the figure
    (a PNG path, or why it was not drawn)."""

    rows: list[list[Any]]
    notes: list[str]
    ladder: list[list[Any]]
    figure: Path | str | None
    #: the aggregated ECDF as an interactive figure (:func:`.interactive.suite_ecdf_figure`)
    interactive: Any = None


@dataclasses.dataclass
class ReportModel:
    """What the report says, for every renderer."""

    data: Any  # a compute.ReportData
    results: list[Any]  # first_screen.ContextResult per context
    out_dir: Path
    sections: list[PlacedSection] = dataclasses.field(default_factory=list)
    section_errors: list[str] = dataclasses.field(default_factory=list)
    extra: list[HeadlineColumn] = dataclasses.field(default_factory=list)
    #: the core figures: title -> PNG path, or why it was not drawn
    figs: dict[str, Path | str] = dataclasses.field(default_factory=dict)
    suite: SuiteScores | None = None
    #: the interactive figures per context (:mod:`.interactive`): ``ecdf`` and ``convergence``
    interactive: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    #: the answer first (:class:`.answer.Answer`): which optimizer, budget, estimator
    answer: Any = None

    def problem_of(self) -> dict[str, str]:
        """Each context's problem."""
        return {r["context"]: r["problem"] for r in self.data.rows}

    def contexts_of(self, problem: str) -> list[str]:
        of = self.problem_of()
        return [c for c in self.data.contexts if of.get(c) == problem]
