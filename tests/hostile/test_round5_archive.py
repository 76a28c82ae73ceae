"""Issue 44, round five's archive failures, each named by its id.

N10. A JSON value nested 900 deep in an archive (its manifest, an optimum line, a record
     line) or a results folder parsed, then ran a recursive reader past Python's recursion
     limit: a ``RecursionError`` traceback (a deep manifest was read without a word). Every
     reader parses through :func:`vpid_bench.fileio.loads_json`, which refuses JSON nested
     deeper than :data:`~vpid_bench.fileio.MAX_JSON_DEPTH`: one line naming the file.
N11. An archive whose optimizer name had 200,000 characters ran the report past 300 s at
     3 GB (``--short``: 192 s, 1.2 MB printed). A record's names and its settings' texts
     have a length limit (:mod:`vpid_bench.store.record_check`): such a record is skipped with one
     line naming it, like any record with a bad field.

The archives are packed by this code from a small sweep, then forged and re-hashed as a
forger would (the checksums match).
"""

from __future__ import annotations

import gzip
import hashlib
import json
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from hostile_helpers import TINY, error_lines, main_in_process

from vpid_bench.fileio import MAX_JSON_DEPTH, loads_json
from vpid_bench.store import archive as arch
from vpid_bench.store.record_check import MAX_NAME_CHARS, MAX_TEXT_CHARS, check_record

SETTINGS = [*TINY, "problem=smoke_quarter", "runs=2"]
#: What the attack planted: a value nested 900 deep (parsed by json, past Python's recursion
#: limit for every recursive reader after it).
DEEP = "[" * 900 + "]" * 900
#: The attack's name length.
LONG = 200_000


@pytest.fixture(scope="module")
def packed(tmp_path_factory, compose_config, registry) -> Path:
    """An archive (suite ``smoke``) of random and centre on smoke_quarter, 2 runs each."""
    from vpid_bench.experiment import run_from_config
    from vpid_bench.report.pack import pack

    root = tmp_path_factory.mktemp("round5-archive")
    for opt in ("random", "centre"):
        run_from_config(compose_config([*SETTINGS, f"optimizer={opt}"]), root / "base" / opt,
                        registry, optima_dir=root / "base" / "optima")
    pack(root / "base", "smoke", root / "archives" / "smoke", command="test", commit="abc",
         made_at="2026-01-01T00:00:00+00:00")
    return root / "archives" / "smoke"


def _forge(packed: Path, tmp_path: Path, name: str, edit: Callable[[list[str]], list[str]]
           ) -> Path:
    """A copy of the archive whose file ``name`` has its lines (text, one JSON value each)
    edited by ``edit``, the manifest re-hashed as a forger would."""
    folder = tmp_path / "archives" / "smoke"
    shutil.copytree(packed, folder)
    path = folder / name
    gz = name.endswith(".gz")
    text = gzip.decompress(path.read_bytes()).decode() if gz else path.read_text()
    if name == arch.MANIFEST:  # one JSON value, perhaps on many lines
        text = json.dumps(json.loads(text))
    data = "".join(line + "\n" for line in edit(text.splitlines())).encode()
    path.write_bytes(gzip.compress(data, mtime=0) if gz else data)
    if name != arch.MANIFEST:
        manifest = json.loads((folder / arch.MANIFEST).read_text())
        manifest["files"][name] = {"sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                                   "bytes": path.stat().st_size}
        (folder / arch.MANIFEST).write_text(json.dumps(manifest))
    return folder


def _plant(lines: list[str], where: Callable[[dict], dict], text: str,
           which: Callable[[dict], bool] = lambda obj: True, first_only: bool = True
           ) -> list[str]:
    """``lines`` with ``where(obj)["note"]`` set to the JSON ``text`` in the chosen lines."""
    out, done = [], False
    for line in lines:
        obj = json.loads(line)
        if which(obj) and not (first_only and done):
            node = where(obj)
            node["note"] = None
            line = json.dumps(obj).replace('"note": null', f'"note": {text}')
            done = True
        out.append(line)
    return out


def _report(folder: Path, out: Path, capsys) -> tuple[int, str, str]:
    """``vpid-bench-report <folder> -o <out> --short`` in this process: (status, stdout,
    stderr)."""
    from vpid_bench.report.cli import main

    code = main([str(folder), "-o", str(out), "--short"])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


NESTED_PLACES = {
    "manifest": (arch.MANIFEST, lambda lines: _plant(lines, lambda m: m, DEEP)),
    "optimum-line": (arch.OPTIMA, lambda lines: _plant(lines, lambda o: o["settings"], DEEP)),
    "record-line": (arch.RECORDS, lambda lines: _plant(
        lines, lambda r: r["problem"]["config"], DEEP)),
}


@pytest.mark.parametrize("place", list(NESTED_PLACES))
def test_n10_json_nested_900_deep_in_an_archive_is_one_line_naming_the_file(
        place, packed, tmp_path, capsys):
    """The report of the archive alone: a deep manifest refuses the archive (one ``error:``
    line, status 2); a deep optimum or record line is skipped with one line naming the file
    and the line (status 1, the rest reported). No traceback: once a RecursionError."""
    name, edit = NESTED_PLACES[place]
    folder = _forge(packed, tmp_path, name, edit)
    code, _, err = _report(folder, tmp_path / "report", capsys)
    assert "Traceback" not in err and "RecursionError" not in err
    named = [line for line in err.splitlines() if f"nested too deeply (more than " \
             f"{MAX_JSON_DEPTH} levels)" in line]
    if place == "manifest":
        assert code == 2 and err.splitlines() == named == error_lines(err), err
        assert f"archive {folder}: {arch.MANIFEST} is not readable JSON" in named[0]
    else:
        assert code == 1, err
        (line,) = named
        assert line.startswith(f"warning: unreadable record {folder / name}:1: ")


def test_n10_a_deep_optimum_line_given_to_target_is_named(packed, tmp_path, in_tmp, capsys,
                                                         monkeypatch):
    """``target=`` reads the archive's optima without the report: the deep line is skipped
    and named, the instance it held has no certified optimum: one ``error:`` line, exit 2,
    before any run (once a RecursionError traceback in the pre-flight)."""
    folder = _forge(packed, tmp_path, arch.OPTIMA,
                    lambda lines: _plant(lines, lambda o: o["settings"], DEEP))
    monkeypatch.setenv(arch.ARCHIVE_DIR_ENV, str(folder.parent))
    code, err = main_in_process([*SETTINGS, "optimizer=random", "target=1e-8",
                                 f"hydra.run.dir={in_tmp / 'job'}"], capsys)
    assert code == 2 and "Traceback" not in err, err
    (line,) = err.splitlines()
    assert line == error_lines(err)[0] and "target=1e-08 is not allowed" in line
    assert not list(in_tmp.rglob("records/run-*.json"))


@pytest.mark.parametrize("kind", ["record", "job.json", "optimum"])
def test_n10_json_nested_900_deep_in_a_results_folder_is_bad_json(kind, tmp_path):
    """The files of a results folder: each reader says "nested too deeply" (a record was
    once read, and every recursive reader after it failed)."""
    from vpid_bench.store.job_status import read_job_status
    from vpid_bench.store.optimum import read_optimum_data
    from vpid_bench.store.records import CorruptRecordError, read_record

    path = tmp_path / {"record": "run-000-deadbeef.json", "job.json": "job.json",
                       "optimum": "o.json"}[kind]
    path.write_text('{"schema": "x", "deep": ' + DEEP + "}")
    words = f"nested too deeply (more than {MAX_JSON_DEPTH} levels)"
    if kind == "record":
        with pytest.raises(CorruptRecordError, match=r"nested too deeply \(more than"):
            read_record(path)
    elif kind == "job.json":
        assert read_job_status(tmp_path) is None  # a job without a readable status
    else:
        data, why = read_optimum_data(path)
        assert data is None and why == f"unreadable: {words}"


def test_n10_the_depth_limit_is_exact_and_ignores_brackets_in_texts():
    """64 levels are read, 65 are not; brackets inside a text are no nesting."""
    assert loads_json("[" * MAX_JSON_DEPTH + "]" * MAX_JSON_DEPTH) is not None
    with pytest.raises(json.JSONDecodeError, match="nested too deeply"):
        loads_json("[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1))
    with pytest.raises(json.JSONDecodeError, match="nested too deeply"):
        loads_json('{"a": [1, 2, ' + "{\"b\": " * 70 + "0" + "}" * 70 + "]}")
    text = json.dumps({"a": "[" * 1000, "b": [[1.0] * 10 for _ in range(100)]})
    assert loads_json(text) == json.loads(text)


def _a_record(packed: Path) -> dict:
    text = gzip.decompress((packed / arch.RECORDS).read_bytes()).decode()
    record = json.loads(text.splitlines()[0])
    assert check_record(record) is None
    return record


#: Where a record names something, and how to set it.
NAMES = {
    "problem.name": lambda r, v: r["problem"].update(name=v),
    "optimizer.name": lambda r, v: r["optimizer"].update(name=v),
    "instance.id": lambda r, v: r["instance"].update(id=v),
    "run_id": lambda r, v: r.update(run_id=v),
    "parameters.names": lambda r, v: r["parameters"]["names"].__setitem__(0, v),
    "parameters.units": lambda r, v: r["parameters"]["units"].__setitem__(0, v),
    "result.metrics": lambda r, v: r["result"].update(metrics={v: 1.0}),
    "result.stopped_by": lambda r, v: r["result"].update(stopped_by=v),
    "problem.config": lambda r, v: r["problem"]["config"].update({v: 1}),  # a key
    "optimizer.params": lambda r, v: r["optimizer"]["params"].update({"deep": {v: 1}}),
}


@pytest.mark.parametrize("field", list(NAMES))
def test_n11_a_name_longer_than_the_limit_is_a_bad_field(field, packed):
    """At the limit a name is kept; one character more and the record is refused, naming
    the field and the limit (never the name itself)."""
    record = _a_record(packed)
    NAMES[field](record, "n" * MAX_NAME_CHARS)
    assert check_record(record) is None
    record = _a_record(packed)
    NAMES[field](record, "n" * (MAX_NAME_CHARS + 1))
    why = check_record(record)
    assert why is not None and why.startswith(f"{field}: expected ")
    assert f"at most {MAX_NAME_CHARS} characters" in why and "nnn" not in why


@pytest.mark.parametrize("section", ["problem.config", "optimizer.params"])
def test_n11_a_settings_text_longer_than_a_path_is_a_bad_field(section, packed):
    """A text value of the settings (a tag, a file path) may be as long as a path."""
    first, second = section.split(".")
    for length, ok in ((MAX_TEXT_CHARS, True), (MAX_TEXT_CHARS + 1, False)):
        record = _a_record(packed)
        record[first][second]["tag"] = "t" * length
        why = check_record(record)
        assert (why is None) == ok, why
    assert why.startswith(f"{section}: expected keys of at most {MAX_NAME_CHARS} characters "
                          f"and texts of at most {MAX_TEXT_CHARS}")


#: The attack's long names: the optimizer's name, and a tag that varies between runs (so it
#: is part of every label).
LONG_NAMES = {
    "optimizer.name": lambda r: r["optimizer"].update(name="x" * LONG),
    "optimizer.params": lambda r: r["optimizer"]["params"].update(
        tag=f"{r['run_index']}" + "x" * LONG),
}


@pytest.mark.parametrize("field", list(LONG_NAMES))
def test_n11_an_archive_with_a_200000_character_name_skips_those_records(field, packed,
                                                                          tmp_path, capsys):
    """The report of the archive alone: each forged line is skipped with one warning line
    naming it and the field; the rest is reported, and the name is printed nowhere. Once
    300 s and 3 GB; the output now no longer than the clean archive's."""
    def forge(lines: list[str]) -> list[str]:
        out = []
        for line in lines:
            record = json.loads(line)
            if record["optimizer"]["name"] == "centre":
                LONG_NAMES[field](record)
            out.append(json.dumps(record))
        return out

    folder = _forge(packed, tmp_path, arch.RECORDS, forge)
    code, out, err = _report(folder, tmp_path / "report", capsys)
    assert code == 1 and "Traceback" not in err, err[-2000:]
    assert "x" * 1000 not in out + err
    named = [line for line in err.splitlines() if f"field {field}: expected " in line]
    assert len(named) == 2  # the two centre runs
    assert all(line.startswith(f"warning: unreadable record {folder / arch.RECORDS}:")
               for line in named)
    clean_code, clean_out, _ = _report(packed, tmp_path / "clean", capsys)
    assert clean_code == 0 and len(out) <= len(clean_out)
