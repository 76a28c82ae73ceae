"""The archive build (``tools/build_archive.py``): one command, resumable, that certifies
each instance's optimum, runs every optimizer with stop at the final target and packs the
archive; run again, it runs nothing that is recorded and packs the same records.

The same build through Ray and submitit's local executor: ``tests/sweeps/test_launchers.py``
(marker ``scaleout``)."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest
from extras import limit
from sweep_helpers import cli_env, fingerprints

ROOT = Path(__file__).resolve().parents[2]
#: A slice: one smoke member, two optimizers, two instances, 20·D per run.
SLICE = ["--suite", "smoke", "--problems", "smoke_quarter", "--optimizers", "random,de1",
         "--runs", "2", "--target", "1e-8", "--budget-per-dim", "20"]


def build(tmp: Path, *extra: str, timeout: float = 600,
          python: str = sys.executable) -> subprocess.CompletedProcess:
    """``build_archive.py`` on :data:`SLICE` into ``tmp`` (sweep ``tmp/b``, archive
    ``tmp/archive``); ``extra``: overrides for its sweeps (e.g. a launcher)."""
    return subprocess.run(
        [python, str(ROOT / "tools" / "build_archive.py"), *SLICE,
         "--sweep", str(tmp / "b"), "--out", str(tmp / "archive"), "--", "progress=false",
         *extra],
        cwd=ROOT, env=cli_env(), capture_output=True, text=True, timeout=limit(timeout),
        check=False)


def archived(folder: Path) -> list[dict]:
    with gzip.open(folder / "records.jsonl.gz", "rt", encoding="utf-8") as fh:
        return [json.loads(line) for line in fh]


def lines(folder: Path) -> dict[str, str]:
    """The archive's record lines by run id, as written."""
    with gzip.open(folder / "records.jsonl.gz", "rt", encoding="utf-8") as fh:
        return {json.loads(line)["run_id"]: line for line in fh}


@pytest.fixture(scope="module")
def first(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("build")
    return tmp, build(tmp)


def test_the_build_certifies_runs_with_the_stop_and_packs(first):
    tmp, done = first
    assert done.returncode == 0, done.stderr[-3000:]
    assert "optimizer=lsq" in done.stdout and "budget_per_dim=100" in done.stdout  # certify
    manifest = json.loads((tmp / "archive" / "manifest.json").read_text())
    assert manifest["runs"] == 4 and manifest["optimizers"] == ["de1", "random"]
    assert "target=1e-08" in manifest["command"]
    records = archived(tmp / "archive")
    assert {r["budget"] for r in records} == {80}  # 20·D, D = 4
    assert all(r["trace"]["batch"][-1] == r["result"]["batches"] for r in records)
    # the runs' sweep started from the certified optima (the same files, never worse), and
    # every run of an instance ended at or above its optimum
    certified = sorted((tmp / "b" / "certify" / "optima").glob("*.json"))
    assert len(certified) == 2
    for path in certified:
        cert = json.loads(path.read_text())
        final = json.loads((tmp / "b" / "runs" / "optima" / path.name).read_text())
        assert final["f_opt"] <= cert["f_opt"]
        assert all(r["result"]["f_best"] >= final["f_opt"] for r in records
                   if r["instance"]["id"] == cert["instance"])
    # and from its per-problem files (bounds, floors per estimator), under the same keys
    shared = sorted((tmp / "b" / "certify" / "optima" / "per-problem").glob("*.json"))
    assert shared
    for path in shared:
        seeded = tmp / "b" / "runs" / "optima" / "per-problem" / path.name
        assert seeded.read_bytes() == path.read_bytes()

@pytest.mark.slow  # three builds: a few minutes on a shared machine
def test_run_again_it_runs_nothing_and_packs_the_same_records(first, tmp_path):
    tmp, done = first
    assert done.returncode == 0, done.stderr[-3000:]
    before = fingerprints(tmp / "b")
    packed = (tmp / "archive" / "records.jsonl.gz").read_bytes()
    again = build(tmp)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "0 run(s) done, 2 already recorded" in again.stdout + again.stderr
    assert (tmp / "archive" / "records.jsonl.gz").read_bytes() == packed
    # a lost record (a build killed mid-way) is run again, alone, and comes back the same
    lost = sorted((tmp / "b" / "runs").glob("*optimizer=random*/records/run-001-*.json"))[0]
    lost.unlink()
    third = build(tmp)
    assert third.returncode == 0, third.stderr[-3000:]
    assert "1 run(s) done, 1 already recorded" in third.stdout + third.stderr
    assert fingerprints(tmp / "b") == before


def test_a_failed_build_is_not_packed(tmp_path):
    done = build(tmp_path, "optimizer.no_such_key=1")
    assert done.returncode != 0
    assert not (tmp_path / "archive").exists()


def test_replace_makes_one_optimizers_runs_again_and_keeps_every_other(first, tmp_path):
    """``--replace random``: the archive's own command with only ``random`` (no certify
    stage, stopped at the archive's optima, its truths not polished again), spliced in: the
    other optimizer's lines byte for byte, ``random``'s the new sweep's, the same runs."""
    import shutil

    tmp, done = first
    assert done.returncode == 0, done.stderr[-3000:]
    shutil.copytree(tmp / "archive", tmp_path / "archive")
    before = lines(tmp_path / "archive")
    old = json.loads((tmp_path / "archive" / "manifest.json").read_text())
    again = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_archive.py"), "--suite", "smoke",
         "--replace", "random", "--sweep", str(tmp_path / "r"), "--out",
         str(tmp_path / "archive"), "--", "progress=false"],
        cwd=ROOT, env=cli_env(), capture_output=True, text=True, timeout=limit(600),
        check=False)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "optimizer=lsq" not in again.stdout and "optimizer=random hydra" in again.stdout
    after = lines(tmp_path / "archive")
    kept = {k: v for k, v in before.items() if '"name": "de1"' in v}
    assert len(kept) == 2 and all(after.get(k) == v for k, v in kept.items())
    made = {json.loads(p.read_text())["run_id"]: json.loads(p.read_text())
            for p in (tmp_path / "r" / "runs").glob("*/records/run-*.json")}
    new = {k: json.loads(v) for k, v in after.items() if k not in kept}
    assert set(new) == set(made) and len(new) == 2
    old_random = sorted((json.loads(v) for v in before.values() if v not in kept.values()),
                        key=lambda r: r["run_index"])
    for was, now in zip(old_random, sorted(new.values(), key=lambda r: r["run_index"]),
                        strict=True):  # the same code: the same runs
        assert now["result"]["f_best"] == was["result"]["f_best"]
        assert now["result"]["evaluations"] == was["result"]["evaluations"]
        assert now["target"] == was["target"]
    manifest = json.loads((tmp_path / "archive" / "manifest.json").read_text())
    assert manifest["command"] == old["command"] and manifest["runs"] == 4
    [entry] = manifest["replaced"]
    assert entry["optimizers"] == ["random"] and "optimizer=random" in entry["command"]
    from vpid_bench.store.archive_records import read_archive

    assert "; random's runs remade at commit" in read_archive(tmp_path / "archive").made_by
    # the sweep's optima started from the archive's, under the keys its jobs look up (a
    # wrong key: the jobs polish each truth again into files of their own)
    names = sorted(p.name for p in (tmp_path / "r" / "runs" / "optima").glob("*.json"))
    assert names == sorted(p.name for p in (tmp / "b" / "runs" / "optima").glob("*.json"))
    assert (tmp_path / "archive" / "optima.jsonl").read_bytes() == (
        tmp / "archive" / "optima.jsonl").read_bytes()


@pytest.mark.parametrize("archive, command", [
    ("missing", None), ("not-an-archive", None), ("no-sweep-command", "rm -rf /"),
    ("no-sweep-command", "vpid-bench -m optimizer=de1 +hydra.callbacks.x._target_=os.system"),
    ("no-sweep-command", "vpid-bench -m optimizer=de1 hydra/launcher=joblib")])
def test_replace_without_a_usable_archive_is_one_line(tmp_path, archive, command):
    """``--replace`` on a folder that is missing, holds no archive, or an archive whose
    (untrusted) manifest names no plain ``vpid-bench -m`` sweep (a Hydra key, a callback that
    would run code): one ``error:`` line, exit 2, nothing run or written."""
    import shutil

    out = tmp_path / "archive"
    if archive != "missing":
        out.mkdir()
    if archive == "no-sweep-command":
        from vpid_bench.store.archive import RUN_FILES, located

        shutil.copytree(ROOT / "archive" / "smoke", out, dirs_exist_ok=True)
        for name in RUN_FILES:  # the shipped runs' data distribution (make install)
            if not located(ROOT / "archive" / "smoke", name).is_file():
                pytest.skip("the archive's runs are not installed (make install)")
            shutil.copyfile(located(ROOT / "archive" / "smoke", name), out / name)
        manifest = json.loads((out / "manifest.json").read_text())
        (out / "manifest.json").write_text(json.dumps({**manifest, "command": command}))
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_archive.py"), "--suite", "smoke",
         "--replace", "random", "--sweep", str(tmp_path / "r"), "--out", str(out)],
        cwd=ROOT, env=cli_env(), capture_output=True, text=True, timeout=limit(120),
        check=False)
    assert done.returncode == 2, done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), done.stderr[-2000:]
    if archive == "no-sweep-command":
        assert f"is not a vpid-bench sweep: {command!r}" in lines[0]
    assert "vpid-bench -m" not in done.stdout and not (tmp_path / "r" / "runs").exists()
