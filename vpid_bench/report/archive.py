"""The archived runs of the built-in optimizers that stand beside a report's own (read through
:mod:`vpid_bench.store.archive_records`): :func:`merge` adds, per problem of the report, the
optimizers it did not run, on the instances it shares, only where the same version of the
problem made them (plugin distribution and version, config and budget, and per instance the
truth and the objective at it); a problem whose archive fails is refused with one line."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from ..store.archive import _plain
from ..store.archive_records import Archive, instance_id, run_setting
from ..store.optimum import Optimum
from .load import grouped
from .ties import same

#: Relative tolerance of the per-instance check (true parameters, objective at the truth).
SAME_RTOL = 1e-9


@dataclasses.dataclass
class Merged:
    """What :func:`merge` adds to a report, and its one-line notes."""

    records: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    optima: list[Optimum] = dataclasses.field(default_factory=list)
    used: list[str] = dataclasses.field(default_factory=list)
    refused: list[str] = dataclasses.field(default_factory=list)


def _close(a: Any, b: Any) -> bool:
    """Two untrusted numbers (or lists of numbers) equal within :data:`SAME_RTOL`."""
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return same(float(a), float(b), SAME_RTOL)
    return a is None and b is None


def _same_instance(mine: Mapping[str, Any], theirs: Mapping[str, Any]) -> str | None:
    """Why two records of one instance id do not hold the same data (``None``: they do)."""
    if not _close((mine.get("parameters") or {}).get("true"),
                  (theirs.get("parameters") or {}).get("true")):
        return "its true parameters differ"
    info_a = (mine.get("problem") or {}).get("info") or {}
    info_b = (theirs.get("problem") or {}).get("info") or {}
    if not _close(info_a.get("f_at_true"), info_b.get("f_at_true")):
        return "its objective at the truth differs"
    return None


def _refusal(arch: Archive, problem: str, why: str) -> str:
    return (f"archive {arch.suite}: {problem} not used: {why}; the archive was made by "
            f"{arch.made_by} with another version of the problem, and is never mixed in "
            "(re-run the built-ins, docs/protocol.md, or set archive=false)")


def budgets_per_dim(records: Iterable[Mapping[str, Any]]) -> list[int]:
    """The distinct budgets per parameter of ``records`` (1,000 for 4,000 evaluations on four
    parameters; the dimension is the length of ``parameters.names``), sorted."""
    per_dim = set()
    for r in records:
        dim = len((r.get("parameters") or {}).get("names") or ()) or 1
        budget = r.get("budget")
        if isinstance(budget, (int, float)) and math.isfinite(budget):
            per_dim.add(round(budget / dim))
    return sorted(per_dim)


def _check_problem(arch: Archive, problem: str, mine: Sequence[Mapping[str, Any]]
                   ) -> tuple[list[dict[str, Any]], str | None, str | None]:
    """The archived records that may stand beside ``mine`` (the report's records of
    ``problem``), a refusal line, and a note for when no archive holds runs with the
    report's settings (another budget or config: not a refusal, since another archive of the
    same problem may hold them)."""
    theirs = [r for r in arch.records if r["problem"]["name"] == problem]
    settings = {run_setting(r) for r in mine}
    match = [r for r in theirs if run_setting(r) in settings]
    if not match:
        mine_plugin = ((mine[0].get("problem") or {}).get("plugin") or {})
        their_plugin = ((theirs[0].get("problem") or {}).get("plugin") or {})
        held = ", ".join(f"{b:,}·D" for b in budgets_per_dim(theirs)) or "no stated budget"
        if [mine_plugin.get(k) for k in ("distribution", "version")] != \
                [their_plugin.get(k) for k in ("distribution", "version")]:
            return [], _refusal(arch, problem, "its plugin version differs"), None
        return [], None, (f"archive {arch.suite}: no archived runs of {problem} with these "
                          f"settings (it holds the problem's defaults at "
                          f"{held})")
    by_instance = {(run_setting(r), instance_id(r)): r for r in mine if instance_id(r)}
    for r in match:
        other = by_instance.get((run_setting(r), instance_id(r)))
        why = None if other is None else _same_instance(other, r)
        if why:
            return [], _refusal(arch, problem, f"instance {_plain(instance_id(r))}: {why}"), None
    names = {r["optimizer"]["name"] for r in mine}
    wanted = {key for key in by_instance}
    return [r for r in match if r["optimizer"]["name"] not in names
            and (run_setting(r), instance_id(r)) in wanted], None, None


def merge(records: Sequence[Mapping[str, Any]], archives: Iterable[Archive]) -> Merged:
    """The archived runs that stand beside ``records`` (see the module docstring)."""
    out = Merged()
    by_problem = grouped((r for r in records if "_archive" not in r),
                         lambda r: r["problem"]["name"])
    other_settings: dict[str, list[str]] = {}
    matched: set[str] = set()
    for arch in archives:
        for problem in sorted(set(by_problem) & arch.problems):
            if not problem.isidentifier():  # a registered name is one; never print another
                continue
            added, refusal, other = _check_problem(arch, problem, by_problem[problem])
            if refusal:
                out.refused.append(refusal)
                continue
            if other:
                other_settings.setdefault(problem, []).append(other)
                continue
            matched.add(problem)
            if not added:
                continue
            out.records += added
            out.optima += [o for o in arch.optima if o.problem == problem]
            optimizers = sorted({r["optimizer"]["name"] for r in added})
            out.used.append(f"{problem}: {', '.join(optimizers)} from the archive of suite "
                            f"{arch.suite} ({arch.made_by}; {len(added)} runs on this "
                            "report's instances, not run again"
                            + (f"; {arch.skipped} bad archive line(s) skipped: "
                               + first_reasons(arch.bad) if arch.bad else "") + ")")
    for problem, notes in other_settings.items():
        if problem not in matched:  # say so only when no archive holds these settings
            out.refused += notes
    return out


def first_reasons(reasons: Sequence[str], limit: int = 3) -> str:
    """``reasons`` joined for one line: the first ``limit`` and how many more."""
    shown = "; ".join(reasons[:limit])
    more = len(reasons) - limit
    return shown + (f"; and {more} more" if more > 0 else "")
