"""Issue 35, failures 6, 7 and 8: an archive is an attacker's file, even when its checksums
match (whoever forges the records can re-hash the manifest).

6. A gzip bomb under the size cap (about 500 KB that expand to 512 MB of newlines or of
   ``{}`` lines) once ended in a MemoryError traceback: the records are now read as a stream
   with limits on lines, line length and bytes, and the archive is refused in one line.
7. Duplicated lines once counted as runs (n = 150 for 30 runs, p = 6e-50): a run given twice
   refuses the archive.
8. NaN, infinite, negative or absurd values once still gave a significant verdict: each such
   line is skipped and named.
"""

from __future__ import annotations

import gzip
import hashlib
import json
import resource
import shutil
import subprocess
from pathlib import Path

import pytest
from extras import limit, needs_archive_runs
from hostile_helpers import REPORT_CLI, TINY, cli_env, error_lines

from vpid_bench.experiment import run_from_config
from vpid_bench.report.build import build_report
from vpid_bench.report.pack import pack
from vpid_bench.store import archive as arch
from vpid_bench.store.archive_records import read_archive

SETTINGS = [*TINY, "problem=smoke_quarter"]
#: The address space a report process may use in these tests (bytes): a bomb read whole (512
#: MB, then decoded and split: gigabytes) fails under it; a streamed one never comes near.
MEMORY_LIMIT = 3 * 1024**3


@pytest.fixture(scope="module")
def made(tmp_path_factory, compose_config, registry) -> dict[str, Path]:
    """An archive of random and centre on smoke_quarter (3 runs each) and a sweep of de1
    (3 runs) with the same settings, so the archive stands beside it."""
    root = tmp_path_factory.mktemp("archive")
    for opt in ("random", "centre"):
        run_from_config(compose_config([*SETTINGS, f"optimizer={opt}", "runs=3"]),
                        root / "base" / opt, registry, optima_dir=root / "base" / "optima")
    pack(root / "base", "smoke", root / "archives" / "smoke", command="test", commit="abc",
         made_at="2026-01-01T00:00:00+00:00")
    run_from_config(compose_config([*SETTINGS, "optimizer=de1", "runs=3"]),
                    root / "mine" / "de1", registry, optima_dir=root / "mine" / "optima")
    return {"root": root, "archives": root / "archives", "mine": root / "mine"}


def _copy(made, tmp_path: Path) -> Path:
    out = tmp_path / "archives"
    shutil.copytree(made["archives"], out)
    return out / "smoke"


def _rehash(folder: Path, name: str) -> None:
    """Make the manifest's SHA-256 of ``name`` match its new content (a forger's step)."""
    manifest = json.loads((folder / arch.MANIFEST).read_text())
    data = (folder / name).read_bytes()
    manifest["files"][name] = {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    (folder / arch.MANIFEST).write_text(json.dumps(manifest))


def _records(folder: Path) -> list[dict]:
    text = gzip.decompress((folder / arch.RECORDS).read_bytes()).decode()
    return [json.loads(line) for line in text.splitlines()]


def _write_records(folder: Path, lines: list[str]) -> None:
    (folder / arch.RECORDS).write_bytes(gzip.compress("".join(lines).encode(), mtime=0))
    _rehash(folder, arch.RECORDS)


def _bomb(folder: Path, unit: bytes) -> int:
    """A records file of about 500 KB that expands to 512 MB of ``unit`` lines: one gzip
    member of 16 MB, repeated (a gzip file may hold many members), checksummed."""
    member = gzip.compress(unit * ((16 << 20) // len(unit)), compresslevel=9, mtime=0)
    (folder / arch.RECORDS).write_bytes(member * 32)
    _rehash(folder, arch.RECORDS)
    return (folder / arch.RECORDS).stat().st_size


def _report_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``vpid-bench-report`` with its address space capped at :data:`MEMORY_LIMIT`."""
    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))

    return subprocess.run([*REPORT_CLI, *args], cwd=cwd, env=cli_env(), capture_output=True,
                          text=True, timeout=limit(120), check=False, preexec_fn=cap)


@pytest.mark.parametrize("unit", [b"\n", b"{}\n"], ids=["newlines", "empty-objects"])
def test_6_a_gzip_bomb_given_to_the_report_is_one_error_line(unit, made, tmp_path):
    folder = _copy(made, tmp_path)
    size = _bomb(folder, unit)
    assert size < 1024 * 1024 < arch.MAX_GZ_BYTES  # under the size cap: read, not refused
    done = _report_cli([str(folder), "-o", str(tmp_path / "report")], tmp_path)
    assert "Traceback" not in done.stderr and "MemoryError" not in done.stderr, done.stderr
    assert done.returncode == 2, done.stderr
    (line,) = [x for x in done.stderr.splitlines()  # but the report's progress lines
               if not (x.startswith("report: ") and x.endswith(" elapsed"))]
    assert line == error_lines(done.stderr)[0]
    assert f"archive {folder}:" in line and ("200000 lines" in line or "bad lines" in line)


@pytest.mark.parametrize("unit", [b"\n", b"{}\n"], ids=["newlines", "empty-objects"])
def test_6_a_gzip_bomb_in_archive_dir_is_refused_and_the_report_written(unit, made, tmp_path):
    folder = _copy(made, tmp_path)
    _bomb(folder, unit)
    out = tmp_path / "report"
    done = _report_cli([str(made["mine"]), "-o", str(out), "--short", "--archive-dir",
                        str(folder.parent)], tmp_path)
    assert "Traceback" not in done.stderr and "MemoryError" not in done.stderr, done.stderr
    assert done.returncode == 1, done.stderr  # the report is written; the archive is not used
    (line,) = [w for w in done.stderr.splitlines() if str(folder) in w]
    assert line.startswith(f"warning: archive {folder}:")
    assert (out / "report.md").is_file()
    assert "centre" not in done.stdout  # nothing of the archive was ranked


def test_6_a_line_longer_than_the_limit_is_refused(made, tmp_path, monkeypatch):
    folder = _copy(made, tmp_path)
    _write_records(folder, ["[" + "0," * 5000 + "0]\n"])
    monkeypatch.setattr("vpid_bench.store.archive.MAX_LINE_BYTES", 1000)  # its one home
    with pytest.raises(arch.ArchiveError, match="line 1 is longer than 1000 bytes"):
        read_archive(folder)


@needs_archive_runs
def test_6_the_shipped_archive_is_within_every_limit():
    a = read_archive(arch.default_root() / "smoke")
    assert len(a.records) < arch.MAX_LINES and a.bad == []


@pytest.mark.parametrize("how", ["same-line", "new-run-id"])
def test_7_a_run_given_twice_refuses_the_archive(how, made, tmp_path):
    """Five copies of every line once made n = 150 of 30 runs. Whether a copy keeps its run
    id or claims another, a run (setting, optimizer, seed, index) appears once."""
    folder = _copy(made, tmp_path)
    recs = _records(folder)
    copy = dict(recs[0])
    if how == "new-run-id":
        copy["run_id"] = "0123456789abcdef"
    _write_records(folder, [json.dumps(r) + "\n" for r in [*recs, copy]])
    with pytest.raises(arch.ArchiveError, match=rf"line {len(recs) + 1} repeats the run of "
                                                r"line 1 \(an archive holds each run once"):
        read_archive(folder)
    report = build_report([made["mine"]], tmp_path / "report", short=True,
                          archive=folder.parent)
    assert [r for r in report.loaded.records if "_archive" in r] == []
    (line,) = [f for f in report.failures if "repeats the run" in f]
    assert line.startswith(f"archive {folder}:")


def test_7_an_optimum_given_twice_refuses_the_archive(made, tmp_path):
    folder = _copy(made, tmp_path)
    lines = (folder / arch.OPTIMA).read_text().splitlines(keepends=True)
    first = json.loads(lines[0])
    first["f_opt"] *= 0.5  # a conflicting second optimum of the same instance
    (folder / arch.OPTIMA).write_text("".join(lines) + json.dumps(first) + "\n")
    _rehash(folder, arch.OPTIMA)
    with pytest.raises(arch.ArchiveError, match=r"gives the optimum of the instance of line 1"):
        read_archive(folder)


def _set(record: dict, fields: str, value) -> None:
    """Set each of ``fields`` (``a.b.0``, joined by ``+``) of ``record`` to ``value``."""
    for field in fields.split("+"):
        node = record
        *parents, leaf = field.split(".")
        for key in parents:
            node = node[int(key)] if isinstance(node, list) else node[key]
        node[int(leaf) if isinstance(node, list) else leaf] = value


#: A value no real run gives, where, and the words of the line that names it.
FORGED = [
    ("result.metrics.NoRE", "nan", "result.metrics.NoRE = nan"),
    ("result.metrics.NoRE", -5.0, "result.metrics.NoRE = -5.0: expected an error"),
    ("result.metrics.NoRE", 1e300, "result.metrics.NoRE = 1e+300"),
    ("result.f_best", "-inf", "result.f_best = -inf"),
    ("result.f_best", "inf", "result.f_best = inf"),
    ("result.f_best+trace.best.-1", 0.0, "expected a value not below its instance's optimum"),
    ("result.f_best", 0.0, "trace.best ends at"),  # a forger who left the trace
    ("result.x_best.0", 1e9, "result.x_best[0] = 1000000000.0: expected a value inside"),
    ("result.evaluations", -3, "result.evaluations: expected an integer from 0"),  # a count
    ("result.evaluations", 10**9, "result.evaluations = 1000000000"),
    ("timing.wall_time_s", -1.0, "timing.wall_time_s = -1.0"),
    ("trace.best.0", "nan", "trace.best[0] = nan"),
]


@pytest.mark.parametrize(("field", "value", "words"), FORGED,
                         ids=[f"{f}={v}" for f, v, _ in FORGED])
def test_8_a_value_no_run_gives_is_skipped_and_named(field, value, words, made, tmp_path):
    """Every centre run gets the forged value: none of them is ranked, and the report names
    the lines (checksums match: the forger re-hashed the manifest)."""
    folder = _copy(made, tmp_path)
    recs = _records(folder)
    forged = [r for r in recs if r["optimizer"]["name"] == "centre"]
    for r in forged:
        _set(r, field, value)
    _write_records(folder, [json.dumps(r) + "\n" for r in recs])
    archive = read_archive(folder)
    assert {r["optimizer"]["name"] for r in archive.records} == {"random"}
    assert len(archive.bad) == len(forged) and all(words in b for b in archive.bad), archive.bad
    report = build_report([made["mine"]], tmp_path / "report", short=True,
                          archive=folder.parent)
    assert {r["optimizer"]["name"] for r in report.loaded.records} == {"de1", "random"}
    (note,) = report.archive_notes
    assert f"{len(forged)} bad archive line(s) skipped: records.jsonl.gz:" in note
    assert words in note
    given = build_report([folder], tmp_path / "given", short=True)  # the archive alone
    assert sum(words in f for f in given.failures) == len(forged)


def test_7_packing_jobs_with_optima_of_their_own_keeps_the_lowest_per_instance(made, tmp_path):
    """Jobs run apart (each polishing into its own optima folder) give several optima of one
    instance; the archive made of them holds one, the lowest, and reads back."""
    from vpid_bench.report.optima import load_optima

    base = tmp_path / "base"
    shutil.copytree(made["root"] / "base", base)
    shutil.copytree(base / "optima", base / "random" / "optima")
    own = base / "random" / "optima"
    for path in own.glob("*.json"):  # the same instances, a worse optimum each
        data = json.loads(path.read_text())
        data["f_opt"] *= 1.5
        path.write_text(json.dumps(data))
    found = load_optima([base, base / "random"], []).optima
    pack(base, "smoke", tmp_path / "a" / "smoke", command="t", commit="c",
         made_at="2026-01-01T00:00:00+00:00")
    archive = read_archive(tmp_path / "a" / "smoke")
    assert len(found) == 2 * len(archive.optima)
    best = {arch.optimum_instance(o): o.f_opt for o in sorted(found, key=lambda o: -o.f_opt)}
    assert {arch.optimum_instance(o): o.f_opt for o in archive.optima} == best
