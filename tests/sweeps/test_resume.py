"""Resume: a sweep stopped part-way (SIGKILL, SIGTERM or SIGINT, i.e. Ctrl-C) and run again
ends with exactly the records of an uninterrupted sweep (same files, same contents apart from
timing), in bounded time."""

from __future__ import annotations

import os
import shlex
import signal
import subprocess
import time
from pathlib import Path

import pytest
from extras import limit
from sweep_helpers import CLI, cli_env, fingerprints, run_cli

from vpid_bench.store import records as rec

# Two jobs of 8 runs; each run is a few hundred generations, so the sweep takes seconds
# and a kill lands part-way.
SWEEP = ["-m", "problem=functions", "optimizer=random,de1", "runs=8", "problem.iterations=1500",
         "problem.dim=6", "progress=false", "report=false"]
TOTAL = 16


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> dict[str, str]:
    """Fingerprints of the uninterrupted sweep."""
    cwd = tmp_path_factory.mktemp("ref")
    done = run_cli([*SWEEP, "hydra.sweep.dir=ref"], cwd)
    assert done.returncode == 0, done.stderr
    prints = fingerprints(cwd / "ref")
    assert len(prints) == TOTAL
    return prints


def _count_records(root: Path) -> int:
    return sum(1 for _ in root.rglob("records/run-*.json"))


@pytest.mark.parametrize("sig", [
    signal.SIGKILL,
    # SIGTERM ends the command as SIGINT does, with the same records (round five's N2,
    # tests/hostile/test_round5_processes.py, in the default run): its resume re-proves SIGINT's
    pytest.param(signal.SIGTERM, marks=pytest.mark.slow),
    signal.SIGINT,
], ids=["SIGKILL", "SIGTERM", "SIGINT"])
def test_a_stopped_sweep_resumes_to_the_uninterrupted_records(tmp_path, reference, sig):
    proc = subprocess.Popen(
        [*CLI, *SWEEP], cwd=tmp_path, env=cli_env(), stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 90
        while _count_records(tmp_path) < 3 and time.monotonic() < deadline:
            if proc.poll() is not None:
                break
            time.sleep(0.005)
        os.killpg(proc.pid, sig)
    finally:
        _, stderr = proc.communicate(timeout=limit(30))  # bounded: a stopped sweep ends
    if sig == signal.SIGINT:  # Ctrl-C: the command says how to resume, exit 130
        assert proc.returncode == 130, stderr
        assert "Traceback" not in stderr
        hint = [line for line in stderr.splitlines() if line.startswith("interrupted:")]
        assert len(hint) == 1 and ": vpid-bench " in hint[0], stderr
        printed = shlex.split(hint[0].split(": vpid-bench ", 1)[1])  # the exact command
        assert printed[:len(SWEEP)] == SWEEP and printed[-1].startswith("--resume=outputs/")
    elif sig == signal.SIGTERM:  # ends as Ctrl-C does (round five's N2), status 128 + 15
        assert proc.returncode == 143, stderr
        assert "Traceback" not in stderr and "--resume" in stderr, stderr
    else:
        assert proc.returncode == -sig
    killed_with = _count_records(tmp_path)
    assert 0 < killed_with < TOTAL, "the kill should land part-way through the sweep"
    sweeps = list((tmp_path / "outputs" / "multirun").iterdir())
    assert len(sweeps) == 1
    # Whatever the moment of the kill, every record file present is complete.
    for path in rec.iter_record_files([sweeps[0]]):
        rec.read_record(path)

    again = run_cli(printed if sig == signal.SIGINT else ["--resume", *SWEEP], tmp_path)
    assert again.returncode == 0, again.stderr
    assert f"resume: continuing {Path('outputs/multirun') / sweeps[0].name}" in again.stderr
    assert "already recorded" in again.stderr
    assert list((tmp_path / "outputs" / "multirun").iterdir()) == sweeps  # no new sweep
    assert fingerprints(sweeps[0]) == reference  # same names, none duplicated, same contents

    # A third run does nothing new: no job starts, no record is rewritten
    # (tests/sweeps/test_nothing_to_run.py: nothing but the report is written).
    mtimes = {p: p.stat().st_mtime_ns for p in rec.iter_record_files([sweeps[0]])}
    third = run_cli(["--resume", *SWEEP], tmp_path)
    assert third.returncode == 0, third.stderr
    assert "nothing to run: the 2 job(s)' 16 run(s) are all recorded" in third.stderr
    assert "already recorded" not in third.stderr
    assert {p: p.stat().st_mtime_ns for p in rec.iter_record_files([sweeps[0]])} == mtimes


def test_corrupt_and_failed_records_are_run_again(tmp_path, compose_config, registry):
    from vpid_bench.experiment import run_from_config

    cfg = compose_config(["problem=functions", "optimizer=random", "runs=3", "progress=false",
                          "problem.iterations=5"])
    first = run_from_config(cfg, tmp_path, registry)
    assert first.ran == 3
    paths = first.record_paths
    good = {p: rec.fingerprint(rec.read_record(p)) for p in paths}
    paths[0].write_text(paths[0].read_text()[:50])  # a torn file (e.g. copied half-way)
    failed = rec.read_record(paths[1]) | {"status": "failed"}
    rec.write_record(paths[1], failed)
    again = run_from_config(cfg, tmp_path, registry)
    assert (again.ran, again.skipped) == (2, 1)
    assert {p: rec.fingerprint(rec.read_record(p)) for p in paths} == good


def test_resume_flag_with_a_missing_folder_is_refused(tmp_path):
    done = run_cli(["--resume=nowhere", "problem=functions", "optimizer=random", "runs=1"],
                   tmp_path)
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "error: --resume='nowhere' is not allowed: an existing sweep or run folder"
    )


def test_resume_finds_the_matching_single_run(tmp_path):
    """``--resume`` without -m re-uses the newest run folder with the same overrides, and
    ignores one whose overrides differ."""
    job = ["problem=functions", "optimizer=random", "runs=2", "problem.iterations=3",
           "report=false"]
    first = run_cli([*job, "progress=false"], tmp_path)
    other = run_cli([*job, "seed=5", "progress=false"], tmp_path)
    assert first.returncode == other.returncode == 0
    again = run_cli(["--resume", *job, "progress=true"], tmp_path)  # progress may differ
    assert again.returncode == 0, again.stderr
    assert "0 run(s) done, 2 already recorded" in again.stderr
    runs = sorted((tmp_path / "outputs" / "runs").iterdir())
    assert len(runs) == 2  # no third folder
    resumed = [line for line in again.stderr.splitlines() if line.startswith("resume:")]
    assert resumed == [f"resume: continuing {Path('outputs/runs') / runs[0].name}"]
