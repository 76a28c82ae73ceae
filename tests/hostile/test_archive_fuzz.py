"""Issue 35, "Also": a property-based fuzz of the archive loader. Hostile content goes into
the manifest, the record lines and the optimum lines of a real small archive, and the
manifest's checksums are made to match (as a forger would). Whatever the content:

* :func:`~vpid_bench.store.archive_records.read_archive` returns an archive or raises
  :class:`~vpid_bench.store.archive.ArchiveError` (one line), never anything else;
* what it returns holds each run once, and every record passes the type check and the
  plausibility check (:mod:`vpid_bench.store.plausible`);
* the report computed beside a sweep's own runs does not fail, and its terminal text holds
  no control character.
"""

from __future__ import annotations

import copy
import gzip
import hashlib
import json
import shutil
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from test_untrusted_archive import SETTINGS  # noqa: E402

from vpid_bench.experiment import run_from_config  # noqa: E402
from vpid_bench.store import archive as arch  # noqa: E402
from vpid_bench.store.archive_records import read_archive  # noqa: E402
from vpid_bench.store.plausible import implausible  # noqa: E402
from vpid_bench.store.record_check import check_record  # noqa: E402

#: Hostile leaves: non-finite and huge numbers, wrong types, control characters, long text.
LEAF = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-2**70, max_value=2**70),
    st.sampled_from([float("nan"), float("inf"), float("-inf"), 1e308, -1e308, 0.0, -0.0,
                     1e-320, 10**400]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["nan", "inf", "-inf", "", "\x1b]0;x\x07", "a\nb", "../../x", "x" * 300,
                     "ok", "failed", "vpid-bench/run-record/2",
                     "vpid-bench/instance-optimum/1", "vpid-bench/archive/1"]),
    st.text(max_size=12),
)
JSON = st.recursive(LEAF, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=4)),
    max_leaves=12)


def _paths(obj, prefix=()):
    """Every path to a node of ``obj`` (keys and list indices)."""
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:3]):
            yield from _paths(v, (*prefix, i))


def _put(obj, path, value):
    """``obj`` with the node at ``path`` replaced by ``value`` (``...``: deleted)."""
    if not path:
        return obj if value is ... else value
    node = obj
    for key in path[:-1]:
        node = node[key]
    if value is ...:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return obj


@pytest.fixture(scope="module")
def base(tmp_path_factory, compose_config, registry) -> dict:
    """A small real archive (random and centre, 2 runs each) and a sweep of de1 beside it."""
    from vpid_bench.report.pack import pack

    root = tmp_path_factory.mktemp("fuzz")
    for opt in ("random", "centre"):
        run_from_config(compose_config([*SETTINGS, f"optimizer={opt}", "runs=2"]),
                        root / "base" / opt, registry, optima_dir=root / "base" / "optima")
    pack(root / "base", "smoke", root / "archive", command="t", commit="c",
         made_at="2026-01-01T00:00:00+00:00")
    run_from_config(compose_config([*SETTINGS, "optimizer=de1", "runs=2"]),
                    root / "mine" / "de1", registry, optima_dir=root / "mine" / "optima")
    folder = root / "archive"
    return {
        "folder": folder, "mine": root / "mine", "work": root / "work",
        "manifest": json.loads((folder / arch.MANIFEST).read_text()),
        "records": [json.loads(line) for line in
                    gzip.decompress((folder / arch.RECORDS).read_bytes()).decode().splitlines()],
        "optima": [json.loads(line) for line in
                   (folder / arch.OPTIMA).read_text().splitlines()],
    }


def _mutation(kind: str):
    """A strategy of edits of one file: (line index, path index, value, duplicate?)."""
    return st.tuples(st.integers(0, 10), st.integers(0, 400),
                     st.one_of(JSON, st.just(...)), st.booleans(),
                     st.sampled_from(["edit", "edit", "junk-line", "blank-lines"]))


def _apply(lines: list, edits, junk) -> list[str]:
    out = [copy.deepcopy(x) for x in lines]
    extra: list[str] = []
    for i, p, value, dup, how in edits:
        if not out:
            break
        i %= len(out)
        if how == "junk-line":
            extra.append(junk)
            continue
        if how == "blank-lines":
            extra.append("\n" * (p % 50))
            continue
        paths = list(_paths(out[i]))
        out[i] = _put(out[i], paths[p % len(paths)], value)
        if dup:
            out.append(copy.deepcopy(out[i]))
    text = [json.dumps(x) + "\n" for x in out]
    return text + extra


def _write(base: dict, target: Path, records: list[str], optima: list[str], manifest_edit):
    shutil.rmtree(target, ignore_errors=True)
    shutil.copytree(base["folder"], target)
    (target / arch.RECORDS).write_bytes(gzip.compress("".join(records).encode(), mtime=0))
    (target / arch.OPTIMA).write_text("".join(optima), encoding="utf-8")
    manifest = copy.deepcopy(base["manifest"])
    for name in (arch.RECORDS, arch.OPTIMA):  # the forger's checksums match
        data = (target / name).read_bytes()
        manifest["files"][name] = {"sha256": hashlib.sha256(data).hexdigest(),
                                   "bytes": len(data)}
    if manifest_edit is not None:
        p, value = manifest_edit
        paths = list(_paths(manifest))
        path = paths[p % len(paths)]
        if path[:1] != ("files",) or value is not ...:  # keep a checksum list to check
            manifest = _put(manifest, path, value)
    (target / arch.MANIFEST).write_text(json.dumps(manifest), encoding="utf-8")


@settings(max_examples=80, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                 HealthCheck.data_too_large])
@given(records=st.lists(_mutation("records"), max_size=4),
       optima=st.lists(_mutation("optima"), max_size=3),
       manifest=st.one_of(st.none(), st.tuples(st.integers(0, 400),
                                                st.one_of(JSON, st.just(...)))),
       junk=st.one_of(st.text(max_size=30), st.sampled_from(["{}", "[]", "null", "1e999",
                                                             "[" * 5000, '{"schema": 2}'])))
def test_hostile_archive_content_is_refused_or_checked(base, records, optima, manifest, junk):
    from vpid_bench.report.compute import compute
    from vpid_bench.report.first_screen import results, terminal_text

    target = base["work"] / "smoke"
    _write(base, target, _apply(base["records"], records, junk),
           _apply(base["optima"], optima, junk), manifest)
    try:
        archive = read_archive(target)
    except arch.ArchiveError as exc:
        hypothesis.event("refused")
        assert "\n" not in str(exc) and str(exc).startswith("archive ")
        return
    hypothesis.event(f"read, {archive.skipped} bad line(s)")
    ids = [r["run_id"] for r in archive.records]
    assert len(ids) == len(set(ids))
    for r in archive.records:
        assert check_record(r) is None and implausible(r) is None, r["_file"]
    data = compute([base["mine"]], True, 0.05, "random", archive=base["work"])
    text = terminal_text(results(data))
    assert all(line.isprintable() for line in text.splitlines())
    assert all(n.isprintable() for n in data.archive_notes)
