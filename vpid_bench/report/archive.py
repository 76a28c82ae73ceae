"""The archive: results of the built-in optimizers on a named suite, read beside a sweep's own
runs so a newcomer compares a new optimizer without re-running anyone.

An archive is a folder ``<root>/<suite>/`` (shipped in the package as ``vpid_bench.archive``)::

    manifest.json       what made it (suite, command, vpid-bench version and commit, date),
                        every problem with its plugin version and config, and the SHA-256
                        and size of each file below
    records.jsonl.gz    one run record per line (the records' own schema, plugin
                        dependency lists left out, traces cut to their improvements:
                        :func:`.pack.compact_trace`)
    optima.jsonl        one instance optimum per line (the optimum files' own schema)
    summary.csv         per problem and optimizer: runs, median metric, median relative gap
    ioh.zip             the runs in IOHprofiler's format

:func:`merge` adds to a report's records the archived runs of every problem the report's runs
are on, for the optimizers the report's runs do not include, on the instances they share.
Nothing archived is mixed in unless it was made by the same version of the problem: the same
plugin distribution and version, the same config and budget, and, per shared instance, the
same true parameters and objective at the truth. A problem whose archive fails that check is
refused with one line and left out.

Everything in an archive is untrusted input: files are read through size limits, the
records file must match the manifest's SHA-256, and every record and optimum line passes the
same checks as a file in a results folder.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..store.archive import (  # noqa: F401  (the format's home; names kept here)
    ARCHIVE_DIR_ENV,
    IOH,
    JOB_FILES,
    JOBS,
    MANIFEST,
    MAX_BAD_LINES,
    MAX_FILES,
    MAX_GZ_BYTES,
    MAX_LINE_BYTES,
    MAX_LINES,
    MAX_RECORDS_BYTES,
    MAX_TEXT_BYTES,
    OPTIMA,
    RECORDS,
    SCHEMA,
    SUMMARY,
    ArchiveError,
    _Bad,
    _check_job_files,
    _checked_file,
    _gz_lines,
    _lines,
    _manifest,
    _plain,
    _read_bytes,
    _read_optima,
    _sha256,
    default_root,
    find_archives,
    is_archive,
    optimum_instance,
    runs_installed,
)
from ..store.records import CorruptRecordError, canonical_json, parse_record
from .load import check_record
from .optima import Optimum, _data_settings
from .plausible import first_reasons, implausible

#: Relative tolerance of the per-instance check (true parameters, objective at the truth).
SAME_RTOL = 1e-9
#: Record keys left out of an archive (each run's copy of its plugins' dependency list).
DROPPED = ("requires",)


@dataclasses.dataclass
class Archive:
    """One checked archive: its manifest, records and optima."""

    folder: Path
    suite: str
    manifest: Mapping[str, Any]
    records: list[dict[str, Any]]
    optima: list[Optimum]
    #: One line per skipped record or optimum line: ``"<file>:<line>: <why>"``.
    bad: list[str] = dataclasses.field(default_factory=list)

    @property
    def skipped(self) -> int:
        """How many record or optimum lines were skipped (:attr:`bad` says why)."""
        return len(self.bad)

    @property
    def problems(self) -> set[str]:
        return {r["problem"]["name"] for r in self.records}

    @property
    def made_by(self) -> str:
        """``vpid-bench <version>, commit <sha>`` as the manifest states it (plain text)."""
        m = self.manifest
        version = _plain(m.get("vpid_bench_version"))
        commit = _plain(m.get("commit"))
        return f"vpid-bench {version}" + (f", commit {commit[:12]}" if commit else "")


def _job_folder(folder: Path, manifest: Mapping[str, Any], problem: str) -> Path:
    """Where the report finds a problem's per-job files: ``jobs/<problem>`` when the manifest
    lists files there (each checked against its SHA-256 by :func:`read_archive`), else the
    archive folder (no such files). A name that is not an identifier never becomes a path."""
    if problem.isidentifier() and any(
            str(name).startswith(f"{JOBS}/{problem}/") for name in manifest["files"]):
        return folder / JOBS / problem
    return folder


def _run_identity(rec: Mapping[str, Any]) -> str:
    """What makes a run the run it is (its setting, optimizer, seed and index), whatever
    run id its line claims."""
    optimizer = rec.get("optimizer") or {}
    return canonical_json([_setting(rec), optimizer.get("name"), optimizer.get("params"),
                           (rec.get("seeds") or {}).get("seed"), rec.get("run_index")])


def _optimum_key(problem: str, instance: Any, settings: Any, dim: int) -> str:
    """The instance an optimum or a record belongs to (protocol keys left out)."""
    return canonical_json([problem, instance, _data_settings(settings), dim])


def _read_records(folder: Path, manifest: Mapping[str, Any], optima: Sequence[Optimum],
                  bad: _Bad) -> list[dict[str, Any]]:
    """The record lines that pass every check a record file passes and hold values a run
    gives (:func:`.plausible.implausible`); a run given twice refuses the archive."""
    f_opt = {_optimum_key(o.problem, o.instance, o.settings, len(o.x_opt)): o.f_opt
             for o in optima if o.settings is not None}
    records: list[dict[str, Any]] = []
    seen: dict[str, int] = {}
    data = _checked_file(folder, manifest, RECORDS, MAX_GZ_BYTES)
    for n, obj, unreadable in _lines(_gz_lines(data, folder), folder / RECORDS):
        if unreadable:
            bad.add(RECORDS, n, unreadable)
            continue
        try:
            rec = parse_record(obj, "")
        except CorruptRecordError as exc:
            bad.add(RECORDS, n, str(exc).removeprefix(": "))
            continue
        why = check_record(rec)
        why = f"field {why}" if why else implausible(rec, f_opt.get(_optimum_key(
            rec["problem"]["name"], _instance(rec), rec["problem"].get("config") or {},
            len(rec["parameters"].get("names") or []))))
        if why:
            bad.add(RECORDS, n, why)
            continue
        for key in (f"run id {rec['run_id']}", _run_identity(rec)):
            if key in seen:
                raise ArchiveError(
                    f"archive {folder}: {RECORDS} line {n} repeats the run of line "
                    f"{seen[key]} (an archive holds each run once: a repeated run would count "
                    "as more runs than were made)")
            seen[key] = n
        rec["_file"] = f"{folder / RECORDS}:{n}"
        rec["_job_dir"] = str(_job_folder(folder, manifest, rec["problem"]["name"]))
        rec["_archive"] = manifest["suite"]
        records.append(rec)
    return records


def read_archive(folder: Path, optima_only: bool = False) -> Archive:
    """Read and check the archive in ``folder``; :class:`ArchiveError` says why it cannot be
    used (a changed file, a limit crossed, a run or an optimum given twice, too many bad
    lines). Bad record or optimum lines are skipped and named (:attr:`Archive.bad`).

    ``optima_only``: its optima without its records (what ``target=`` needs), the records
    file checked against its SHA-256 but not read line by line: reading and checking the
    8,265 records of the shipped archives took 6.5 s, once in the pre-flight and once more
    in every job of a ``target=`` sweep."""
    folder = Path(folder)
    manifest = _manifest(folder)
    _check_job_files(folder, manifest)
    bad = _Bad(folder)
    optima = _read_optima(folder, manifest, bad)
    if optima_only:
        if runs_installed(folder):
            _checked_file(folder, manifest, RECORDS, MAX_GZ_BYTES)
        records: list[dict[str, Any]] = []
    else:
        records = _read_records(folder, manifest, optima, bad)
    return Archive(folder, manifest["suite"], manifest, records, optima, bad.lines)


@dataclasses.dataclass
class Merged:
    """What :func:`merge` adds to a report, and its one-line notes."""

    records: list[dict[str, Any]] = dataclasses.field(default_factory=list)
    optima: list[Optimum] = dataclasses.field(default_factory=list)
    used: list[str] = dataclasses.field(default_factory=list)
    refused: list[str] = dataclasses.field(default_factory=list)


def _setting(rec: Mapping[str, Any]) -> str:
    """A record's problem, plugin, config and budget: what must match to compare runs."""
    problem = rec.get("problem") or {}
    plugin = problem.get("plugin") if isinstance(problem.get("plugin"), Mapping) else {}
    return canonical_json({"name": problem.get("name"), "config": problem.get("config"),
                           "budget": rec.get("budget"),
                           "plugin": [plugin.get("distribution"), plugin.get("version")]})


def _instance(rec: Mapping[str, Any]) -> str | None:
    inst = rec.get("instance")
    iid = inst.get("id") if isinstance(inst, Mapping) else None
    return iid if isinstance(iid, str) else None


def _close(a: Any, b: Any) -> bool:
    """Two untrusted numbers (or lists of numbers) equal within :data:`SAME_RTOL`."""
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        a, b = float(a), float(b)
        return a == b or (math.isfinite(a) and math.isfinite(b)
                          and abs(a - b) <= SAME_RTOL * max(abs(a), abs(b)))
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


def _budgets_text(records: Sequence[Mapping[str, Any]]) -> str:
    """The budgets per parameter of ``records`` (``1,000·D``), for a note."""
    return ", ".join(f"{b:,}·D" for b in budgets_per_dim(records)) or "no stated budget"


def _check_problem(arch: Archive, problem: str, mine: Sequence[Mapping[str, Any]]
                   ) -> tuple[list[dict[str, Any]], str | None, str | None]:
    """The archived records that may stand beside ``mine`` (the report's records of
    ``problem``), a refusal line, and a note for when no archive holds runs with the
    report's settings (another budget or config: not a refusal, since another archive of the
    same problem may hold them)."""
    theirs = [r for r in arch.records if r["problem"]["name"] == problem]
    settings = {_setting(r) for r in mine}
    match = [r for r in theirs if _setting(r) in settings]
    if not match:
        mine_plugin = ((mine[0].get("problem") or {}).get("plugin") or {})
        their_plugin = ((theirs[0].get("problem") or {}).get("plugin") or {})
        if [mine_plugin.get(k) for k in ("distribution", "version")] != \
                [their_plugin.get(k) for k in ("distribution", "version")]:
            return [], _refusal(arch, problem, "its plugin version differs"), None
        return [], None, (f"archive {arch.suite}: no archived runs of {problem} with these "
                          f"settings (it holds the problem's defaults at "
                          f"{_budgets_text(theirs)})")
    by_instance = {(_setting(r), _instance(r)): r for r in mine if _instance(r)}
    for r in match:
        other = by_instance.get((_setting(r), _instance(r)))
        why = None if other is None else _same_instance(other, r)
        if why:
            return [], _refusal(arch, problem, f"instance {_plain(_instance(r))}: {why}"), None
    names = {r["optimizer"]["name"] for r in mine}
    wanted = {key for key in by_instance}
    return [r for r in match if r["optimizer"]["name"] not in names
            and (_setting(r), _instance(r)) in wanted], None, None


def merge(records: Sequence[Mapping[str, Any]], archives: Iterable[Archive]) -> Merged:
    """The archived runs that stand beside ``records`` (see the module docstring)."""
    out = Merged()
    by_problem: dict[str, list[Mapping[str, Any]]] = {}
    for r in records:
        if "_archive" not in r:
            by_problem.setdefault(r["problem"]["name"], []).append(r)
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


def load_all(root: Path | None = None, problems: Iterable[str] | None = None,
             optima_only: bool = False) -> tuple[list[Archive], list[str]]:
    """Every readable archive below ``root`` whose manifest lists one of ``problems`` (all
    when ``None``), and one line per such archive that cannot be used (``optima_only``: see
    :func:`read_archive`)."""
    found, bad = [], []
    wanted = None if problems is None else set(problems)
    for folder in find_archives(root):
        try:
            if wanted is not None and not wanted & set(_manifest(folder).get("problems") or ()):
                continue
            found.append(read_archive(folder, optima_only))
        except ArchiveError as exc:
            bad.append(str(exc))
    return found, bad
