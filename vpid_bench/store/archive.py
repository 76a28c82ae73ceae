"""An archive folder's format: its manifest, the files it lists (each checked against its
SHA-256, each read through its size cap), its JSON-lines files and its optima (what each file
of ``<root>/<suite>/`` holds: docs/protocol.md, the archive). Written by :mod:`.archive_pack`,
its runs (or its optima alone, for ``target=``) read by :mod:`.archive_records`. Everything
in an archive is untrusted.
"""

from __future__ import annotations

import csv
import gzip
import hashlib
import importlib.util
import io
import os
import zlib
from collections.abc import Iterable, Iterator, Mapping
from importlib.resources import files
from pathlib import Path
from typing import Any

from ..errors import VpidBenchError
from ..fileio import json_fault, loads_json, read_text_limited
from .job_files import ESTIMATORS, IDENTIFIABILITY
from .optimum import Optimum, optimum_from_data
from .records import canonical_json

SCHEMA = "vpid-bench/archive/1"
MANIFEST = "manifest.json"
RECORDS = "records.jsonl.gz"
OPTIMA = "optima.jsonl"
SUMMARY = "summary.csv"
IOH = "ioh.zip"
#: Per problem, the files a job writes once for all its runs (the report's bounds and floors
#: per estimator), shipped as ``jobs/<problem>/<name>``.
JOB_FILES = (IDENTIFIABILITY, ESTIMATORS)
JOBS = "jobs"
#: Largest manifest and optima file read (bytes).
MAX_TEXT_BYTES = 4 * 1024 * 1024
#: Largest compressed records file read, and the most its lines may hold uncompressed (bytes):
#: ten times the shipped smoke archive's 12 MB; read line by line, so a gzip bomb (500 KB
#: that expand to 500 MB) stops at the first limit it meets, in memory and in time.
MAX_GZ_BYTES = 64 * 1024 * 1024
MAX_RECORDS_BYTES = 128 * 1024 * 1024
#: The most lines a records or optima file may hold, blank ones included (the smoke archive
#: holds 2,850), and the longest line (bytes; a record with a long trace is a few hundred KB).
MAX_LINES = 200_000
MAX_LINE_BYTES = 16 * 1024 * 1024
#: An archive with more bad lines than this is refused as a whole.
MAX_BAD_LINES = 1_000
#: The most files a manifest may list.
MAX_FILES = 1_000


class ArchiveError(VpidBenchError):
    """An archive folder that cannot be used (named, with why, in one line)."""


#: An environment variable naming a folder of archives to read instead of the shipped ones
#: (a lab's own archive, or a test's).
ARCHIVE_DIR_ENV = "VPID_BENCH_ARCHIVE_DIR"


def default_root() -> Path:
    """The archives shipped with the package, or the folder ``$VPID_BENCH_ARCHIVE_DIR``."""
    chosen = os.environ.get(ARCHIVE_DIR_ENV)
    return Path(chosen) if chosen else Path(str(files("vpid_bench.archive")))


def _plain(value: Any, limit: int = 80) -> str:
    """A short printable text from an untrusted value (``""`` for anything else)."""
    return value if isinstance(value, str) and len(value) <= limit and value.isprintable() else ""


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


#: An environment variable naming a folder of the shipped archives' runs (``<suite>/``
#: ``records.jsonl.gz`` and ``ioh.zip``) to read instead of the installed data distribution.
RUNS_DIR_ENV = "VPID_BENCH_ARCHIVE_RUNS_DIR"
#: The files of a shipped archive that its data distribution holds (``archive-runs/`` of the
#: repository, ``vpid-archive-runs``: ``make install`` installs it); the wheel keeps the rest.
RUN_FILES = (RECORDS, IOH)


def runs_root() -> Path | None:
    """Where the shipped archives' runs are: ``$VPID_BENCH_ARCHIVE_RUNS_DIR``, else the
    installed package ``vpid_archive_runs``, else ``None`` (not installed)."""
    chosen = os.environ.get(RUNS_DIR_ENV)
    if chosen:
        return Path(chosen)
    if importlib.util.find_spec("vpid_archive_runs") is None:
        return None
    return Path(str(files("vpid_archive_runs")))


def located(folder: Path, name: str) -> Path:
    """The file ``name`` of the archive in ``folder``: beside its manifest when there, else,
    for a run file of a shipped archive, in the runs' data distribution (:func:`runs_root`)."""
    path = folder / name
    if name not in RUN_FILES or path.exists() or path.is_symlink():
        return path
    runs = runs_root()
    shipped = Path(str(files("vpid_bench.archive"))).resolve()
    if runs is not None and folder.resolve().parent == shipped:
        return runs / folder.name / name
    return path


def runs_installed(folder: Path) -> bool:
    """Whether the runs file of the archive in ``folder`` can be found (:func:`located`)."""
    return located(folder, RECORDS).is_file()


def _manifest(folder: Path) -> dict[str, Any]:
    try:
        data = loads_json(read_text_limited(folder / MANIFEST, MAX_TEXT_BYTES))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ArchiveError(f"archive {folder}: {MANIFEST} is not readable JSON "
                           f"({json_fault(exc)})") from None
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        raise ArchiveError(f"archive {folder}: {MANIFEST} is not a vpid-bench archive "
                           f"(schema != {SCHEMA!r})")
    if not _plain(data.get("suite")) or not isinstance(data.get("files"), dict):
        raise ArchiveError(f"archive {folder}: {MANIFEST} lacks its suite or file list")
    if len(data["files"]) > MAX_FILES:
        raise ArchiveError(f"archive {folder}: {MANIFEST} lists more than {MAX_FILES} files")
    return data


def _checked_file(folder: Path, manifest: Mapping[str, Any], name: str, limit: int) -> bytes:
    """The bytes of ``name``, which the manifest must list with the same SHA-256."""
    entry = manifest["files"].get(name)
    want = entry.get("sha256") if isinstance(entry, Mapping) else None
    path = located(folder, name)
    if path.is_symlink() or not path.is_file():
        hint = (" (the archive's runs are a data distribution: make install, or pip install "
                "./archive-runs)") if path.name in RUN_FILES else ""
        raise ArchiveError(f"archive {path.parent}: {path.name} is missing or not a regular "
                           f"file{hint}")
    if path.stat().st_size > limit:
        raise ArchiveError(f"archive {path.parent}: {path.name} is larger than {limit} bytes")
    data = path.read_bytes()
    if not isinstance(want, str) or _sha256(data) != want:
        raise ArchiveError(f"archive {folder}: {name} does not match the SHA-256 in its "
                           f"{MANIFEST} (changed or damaged)")
    return data


def _gz_lines(data: bytes, folder: Path) -> Iterator[bytes]:
    """The lines of the gzip ``data``, decompressed one at a time (a line longer than
    :data:`MAX_LINE_BYTES` comes in pieces, which :func:`_lines` refuses), at most
    :data:`MAX_RECORDS_BYTES` in all."""
    total = 0
    try:
        with gzip.GzipFile(fileobj=io.BytesIO(data)) as fh:
            while line := fh.readline(MAX_LINE_BYTES + 1):
                total += len(line)
                if total > MAX_RECORDS_BYTES:
                    raise ArchiveError(f"archive {folder}: {RECORDS} holds more than "
                                       f"{MAX_RECORDS_BYTES} bytes")
                yield line
    except (OSError, EOFError, zlib.error) as exc:
        raise ArchiveError(f"archive {folder}: {RECORDS} is not gzip data "
                           f"({type(exc).__name__})") from None


def _lines(lines: Iterable[bytes], where: Path) -> Iterator[tuple[int, Any, str | None]]:
    """``(line number, parsed JSON, None)`` of each non-blank line, or ``(line number, None,
    why)`` for one that is not JSON, within :data:`MAX_LINES` and :data:`MAX_LINE_BYTES`
    (``where``: the file, for the error)."""
    for n, line in enumerate(lines, 1):
        if n > MAX_LINES:
            raise ArchiveError(f"archive {where.parent}: {where.name} holds more than "
                               f"{MAX_LINES} lines")
        if len(line) > MAX_LINE_BYTES:
            raise ArchiveError(f"archive {where.parent}: {where.name} line {n} is longer "
                               f"than {MAX_LINE_BYTES} bytes")
        text = line.decode("utf-8", errors="replace")
        if text.strip():
            try:
                yield n, loads_json(text), None
            except ValueError as exc:
                yield n, None, f"not readable JSON ({json_fault(exc)})"


def _check_job_files(folder: Path, manifest: Mapping[str, Any]) -> None:
    """Every ``jobs/<problem>/<file>`` the manifest lists: a known file name under an
    identifier, matching its SHA-256 (a changed one refuses the archive)."""
    for name in manifest["files"]:
        parts = str(name).split("/")
        if parts[0] != JOBS:
            continue
        if len(parts) != 3 or not parts[1].isidentifier() or parts[2] not in JOB_FILES:
            raise ArchiveError(f"archive {folder}: {MANIFEST} lists an unexpected file "
                               f"{_plain(str(name)) or '(unprintable)'}")
        _checked_file(folder, manifest, str(name), MAX_TEXT_BYTES)


class _Bad:
    """The skipped lines of one archive, refused as a whole past :data:`MAX_BAD_LINES`."""

    def __init__(self, folder: Path) -> None:
        self.folder, self.lines = folder, []

    def add(self, name: str, n: int, why: str) -> None:
        self.lines.append(f"{name}:{n}: {why}")
        if len(self.lines) > MAX_BAD_LINES:
            raise ArchiveError(f"archive {self.folder}: more than {MAX_BAD_LINES} bad lines "
                               f"(the first: {self.lines[0]})")


def _read_optima(folder: Path, manifest: Mapping[str, Any], bad: _Bad) -> list[Optimum]:
    """The optimum lines; an instance given twice refuses the archive (which counts?)."""
    optima, seen = [], {}
    data = _checked_file(folder, manifest, OPTIMA, MAX_TEXT_BYTES)
    for n, obj, why in _lines(data.splitlines(keepends=True), folder / OPTIMA):
        opt, why = (None, why) if why else optimum_from_data(obj, Path(f"{folder / OPTIMA}:{n}"))
        if opt is None:
            bad.add(OPTIMA, n, why or "not an optimum")
            continue
        key = optimum_instance(opt)
        if key in seen:
            raise ArchiveError(f"archive {folder}: {OPTIMA} line {n} gives the optimum of the "
                               f"instance of line {seen[key]} again (an instance has one)")
        seen[key] = n
        optima.append(opt)
    return optima


def optimum_instance(opt: Optimum) -> str:
    """The instance an optimum is of (problem, instance id, settings), canonical: an archive
    holds one optimum per instance (:func:`.archive_pack.write_archive` keeps the lowest)."""
    return canonical_json([opt.problem, opt.instance, opt.settings])


def is_archive(path: Path) -> bool:
    """Whether ``path`` is an archive folder (it holds a ``manifest.json``)."""
    path = Path(path)
    return path.is_dir() and (path / MANIFEST).is_file()


def find_archives(root: Path | None = None) -> list[Path]:
    """The archive folders below ``root`` (default: :func:`default_root`)."""
    root = default_root() if root is None else Path(root)
    if not root.is_dir():
        return []
    return sorted(p.parent for p in root.glob(f"*/{MANIFEST}") if not p.parent.is_symlink())


#: Largest summary.csv read for the time per evaluation (bytes).
MAX_SUMMARY_BYTES = 1_000_000


def evaluation_seconds(root: Path | None = None) -> dict[str, float]:
    """Per problem of the archives below ``root``, the seconds one evaluation took in their
    builds (median over optimizers of median run time / median evaluations, ``summary.csv``):
    a sweep's first estimate of its time. Unreadable files, odd rows and single evaluations
    (the box centre's) are left out."""
    per: dict[str, list[float]] = {}
    for folder in find_archives(root):
        try:
            text = read_text_limited(folder / SUMMARY, MAX_SUMMARY_BYTES)
        except (OSError, UnicodeDecodeError):
            continue
        for row in csv.DictReader(io.StringIO(text)):
            try:
                evals, secs = float(row["median_evaluations"]), float(row["median_run_time_s"])
            except (KeyError, TypeError, ValueError):
                continue
            problem = row.get("problem") or ""
            if problem.isidentifier() and 1 < evals < 1e12 and 0 < secs < 1e7:
                per.setdefault(problem, []).append(secs / evals)
    return {p: sorted(v)[len(v) // 2] for p, v in per.items()}
