"""An archive's runs, read: each line of ``records.jsonl.gz`` checked as a record file is
(:func:`.record_check.check_record`) and for values a run gives (:mod:`.plausible`), beside the
manifest, job files and optima (:mod:`.archive`). What the report makes of them (which runs
stand beside a user's) is :mod:`vpid_bench.report.archive`."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from . import archive as arc
from .optimum import Optimum, _data_settings
from .plausible import implausible
from .record_check import check_record
from .records import CorruptRecordError, canonical_json, parse_record

#: Replacing sweeps (and optimizers in one) named by :attr:`Archive.made_by`, at most.
MAX_REPLACED = 20


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
        """``vpid-bench <version>, commit <sha>`` as the manifest states it, and each later
        sweep that replaced some optimizers' runs (``; nevergrad's runs remade at commit
        <sha>``), plain text."""
        m = self.manifest
        version = arc._plain(m.get("vpid_bench_version"))
        commit = arc._plain(m.get("commit"))
        out = f"vpid-bench {version}" + (f", commit {commit[:12]}" if commit else "")
        replaced = m.get("replaced")
        for entry in replaced[:MAX_REPLACED] if isinstance(replaced, list) else ():
            names = entry.get("optimizers") if isinstance(entry, Mapping) else None
            names = [arc._plain(n) for n in names if arc._plain(n)] if isinstance(
                names, list) else []
            if names:
                sha = arc._plain(entry.get("commit"))
                out += (f"; {', '.join(names[:MAX_REPLACED])}'s runs remade"
                        + (f" at commit {sha[:12]}" if sha else ""))
        return out


def _job_folder(folder: Path, manifest: Mapping[str, Any], problem: str) -> Path:
    """Where the report finds a problem's per-job files: ``jobs/<problem>`` when the manifest
    lists files there (each checked against its SHA-256 by :func:`read_archive`), else the
    archive folder (no such files). A name that is not an identifier never becomes a path."""
    if problem.isidentifier() and any(
            str(name).startswith(f"{arc.JOBS}/{problem}/") for name in manifest["files"]):
        return folder / arc.JOBS / problem
    return folder


def _run_identity(rec: Mapping[str, Any]) -> str:
    """What makes a run the run it is (setting, optimizer, seed, index), whatever its run id."""
    optimizer = rec.get("optimizer") or {}
    return canonical_json([run_setting(rec), optimizer.get("name"), optimizer.get("params"),
                           (rec.get("seeds") or {}).get("seed"), rec.get("run_index")])


def _optimum_key(problem: str, instance: Any, settings: Any, dim: int) -> str:
    """The instance an optimum or a record belongs to (protocol keys left out)."""
    return canonical_json([problem, instance, _data_settings(settings), dim])


def _read_records(folder: Path, manifest: Mapping[str, Any], optima: Sequence[Optimum],
                  bad: arc._Bad, problems: set[str] | None = None) -> list[dict[str, Any]]:
    """The record lines that pass every check a record file passes and hold values a run
    gives (:func:`.plausible.implausible`); a run given twice refuses the archive.
    ``problems``: only the lines of these problems are checked and kept (the others are not
    used, so their faults cannot reach the caller); a report beside one job's runs read and
    checked every run of the smoke archive, 1 s, to keep a fifth."""
    f_opt = {_optimum_key(o.problem, o.instance, o.settings, len(o.x_opt)): o.f_opt
             for o in optima if o.settings is not None}
    records: list[dict[str, Any]] = []
    seen: dict[str, int] = {}
    data = arc._checked_file(folder, manifest, arc.RECORDS, arc.MAX_GZ_BYTES)
    for n, obj, unreadable in arc._lines(arc._gz_lines(data, folder), folder / arc.RECORDS):
        if unreadable:
            bad.add(arc.RECORDS, n, unreadable)
            continue
        if problems is not None and isinstance(obj, dict) and isinstance(
                obj.get("problem"), dict) and obj["problem"].get("name") not in problems:
            continue
        try:
            rec = parse_record(obj, "")
        except CorruptRecordError as exc:
            bad.add(arc.RECORDS, n, str(exc).removeprefix(": "))
            continue
        why = check_record(rec)
        why = f"field {why}" if why else implausible(rec, f_opt.get(_optimum_key(
            rec["problem"]["name"], instance_id(rec), rec["problem"].get("config") or {},
            len(rec["parameters"].get("names") or []))))
        if why:
            bad.add(arc.RECORDS, n, why)
            continue
        for key in (f"run id {rec['run_id']}", _run_identity(rec)):
            if key in seen:
                raise arc.ArchiveError(
                    f"archive {folder}: {arc.RECORDS} line {n} repeats the run of line "
                    f"{seen[key]} (an archive holds each run once: a repeated run would count "
                    "as more runs than were made)")
            seen[key] = n
        rec["_file"] = f"{folder / arc.RECORDS}:{n}"
        rec["_job_dir"] = str(_job_folder(folder, manifest, rec["problem"]["name"]))
        rec["_archive"] = manifest["suite"]
        records.append(rec)
    return records


def read_archive(folder: Path, optima_only: bool = False,
                 problems: set[str] | None = None) -> Archive:
    """Read and check the archive in ``folder``; :class:`ArchiveError` says why it cannot be
    used (a changed file, a limit crossed, a run or an optimum given twice, too many bad
    lines). Bad record or optimum lines are skipped and named (:attr:`Archive.bad`).

    ``optima_only``: its optima without its records (what ``target=`` needs, in the
    pre-flight and in every job), the records file checked against its SHA-256 but not read
    line by line (which took 6.5 s for the shipped archives). ``problems``: the records of
    these problems only."""
    folder = Path(folder)
    manifest = arc._manifest(folder)
    arc._check_job_files(folder, manifest)
    bad = arc._Bad(folder)
    optima = arc._read_optima(folder, manifest, bad)
    if optima_only:
        if arc.runs_installed(folder):
            arc._checked_file(folder, manifest, arc.RECORDS, arc.MAX_GZ_BYTES)
        records: list[dict[str, Any]] = []
    else:
        records = _read_records(folder, manifest, optima, bad, problems)
    return Archive(folder, manifest["suite"], manifest, records, optima, bad.lines)


def run_setting(rec: Mapping[str, Any]) -> str:
    """A record's problem, plugin, config and budget: what must match to compare runs."""
    problem = rec.get("problem") or {}
    plugin = problem.get("plugin") if isinstance(problem.get("plugin"), Mapping) else {}
    return canonical_json({"name": problem.get("name"), "config": problem.get("config"),
                           "budget": rec.get("budget"),
                           "plugin": [plugin.get("distribution"), plugin.get("version")]})


def instance_id(rec: Mapping[str, Any]) -> str | None:
    """A record's instance id, when it is a text (``None``: all instances identical)."""
    inst = rec.get("instance")
    iid = inst.get("id") if isinstance(inst, Mapping) else None
    return iid if isinstance(iid, str) else None


def load_all(root: Path | None = None, problems: Iterable[str] | None = None,
             optima_only: bool = False) -> tuple[list[Archive], list[str]]:
    """Every readable archive below ``root`` whose manifest lists one of ``problems`` (all
    when ``None``), and one line per such archive that cannot be used."""
    found, bad = [], []
    wanted = None if problems is None else set(problems)
    for folder in arc.find_archives(root):
        try:
            if wanted is not None and not wanted & set(arc._manifest(folder).get("problems") or ()):
                continue
            found.append(read_archive(folder, optima_only, wanted))
        except arc.ArchiveError as exc:
            bad.append(str(exc))
    return found, bad
