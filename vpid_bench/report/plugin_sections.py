"""The problems' report sections: the core's (identifiability, measured vs fitted signals)
and those plugins register through ``vpid_bench_register_report_sections``. A section that
raises, returns something else than a :class:`~.sections.Contribution` or names a file outside
the report folder costs itself only: the report says what went wrong."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..fileio import write_refused
from ..store.paths import UnsafePathError, inside
from . import diagnostics, identifiability, signals
from .model import PlacedSection
from .sections import Contribution, HeadlineColumn, ReportContext, Section

log = logging.getLogger(__name__)


def plugin_sections(registry: Any, data: Any, out_dir: Path, claim: Callable[[Path], Path]
                    ) -> tuple[list[PlacedSection], list[HeadlineColumn], list[str]]:
    """Per problem: the core's sections, then the plugins', their headline columns, failures."""
    by_id = {r["run_id"]: r for r in data.loaded.records}
    sections: list[PlacedSection] = []
    columns: list[HeadlineColumn] = []
    errors: list[str] = []
    for problem in data.problems:
        funcs = [("vpid-bench", identifiability.section), ("vpid-bench", signals.section),
                 ("vpid-bench", diagnostics.section),
                 *getattr(registry, "report_sections", {}).get(problem, [])]
        prows = tuple(r for r in data.rows if r["problem"] == problem)
        ctx = ReportContext(problem=problem, rows=prows,
                            records=tuple(by_id[r["run_id"]] for r in prows),
                            out_dir=out_dir, short=data.short, alpha=data.alpha, _claim=claim)
        for plugin, func in funcs:
            try:
                contrib = func(ctx)
                if contrib is None:
                    continue
                new, bad = _checked(contrib, plugin, out_dir)
                sections += [PlacedSection(plugin, problem, sec) for sec in new]
                errors += bad
                columns += [c for c in contrib.headline if isinstance(c, HeadlineColumn)]
            except Exception as exc:  # a plugin's fault costs its section, not the report
                if write_refused(exc):  # a full disk is the report's failure, not the plugin's
                    raise
                log.debug("report section failed", exc_info=True)
                errors.append(f"report section of plugin {plugin!r} for problem {problem!r} "
                              f"failed: {type(exc).__name__}: {exc}")
    return sections, columns, errors


def _checked(contrib: Any, plugin: str, out_dir: Path) -> tuple[list[Section], list[str]]:
    """The sections of a contribution, each file checked to lie inside the report folder."""
    if not isinstance(contrib, Contribution):
        raise TypeError(f"returned {type(contrib).__name__}, not a Contribution")
    out, errors = [], []
    for sec in contrib.sections:
        if not isinstance(sec, Section):
            raise TypeError(f"a section is a {type(sec).__name__}, not a Section")
        kept = []
        for f in sec.files:
            try:
                kept.append(inside(out_dir, Path(f)))
            except UnsafePathError:
                errors.append(f"report section of plugin {plugin!r}: {Path(f)} is outside the "
                              f"report folder {out_dir}")
        out.append(dataclasses.replace(sec, files=tuple(kept)))
    return out, errors
