"""Issue 13, cases 1-5: nothing escapes its folder, nothing goes stale.

Records are untrusted input to ``vpid-bench-report``; override values are untrusted input to
job folder names; files in a job folder may be planted links."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from hostile_helpers import TINY, plan_of, run_cli

from vpid_bench.api import Problem
from vpid_bench.experiment import run_from_config
from vpid_bench.shell.callbacks import MAX_JOB_DIR, job_dir_name
from vpid_bench.store import records as rec


def _records(tmp_path: Path, compose_config, registry, runs: int = 3) -> list[Path]:
    cfg = compose_config([*TINY, f"runs={runs}"])
    return run_from_config(cfg, tmp_path / "sweep" / "job", registry).record_paths


def _edit(path: Path, change) -> None:
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def _tree(root: Path) -> set[Path]:
    return set(root.rglob("*"))


def test_1_record_names_write_nothing_outside_the_report_folder(tmp_path, compose_config,
                                                                 registry):
    paths = _records(tmp_path, compose_config, registry)
    for p in paths:
        _edit(p, lambda d: d["problem"].update(name="../../../../x/pwned"))
        _edit(p, lambda d: d["optimizer"].update(name="../../y|<script>"))
    out = tmp_path / "a" / "b" / "out"
    before = _tree(tmp_path)
    done = run_cli([str(tmp_path / "sweep"), "-o", str(out)], tmp_path, report=True)
    assert done.returncode in (0, 1) and "Traceback" not in done.stderr
    new = _tree(tmp_path) - before
    assert new and all(p == out or out in p.parents or p in out.parents for p in new)
    assert not list(tmp_path.rglob("pwned*")) or all(out in p.parents
                                                     for p in tmp_path.rglob("pwned*"))
    md = (out / "report.md").read_text()
    assert "<script>" not in md


def test_2_the_report_reads_no_file_a_record_names_and_builds_no_problem(tmp_path,
                                                                          compose_config,
                                                                          registry):
    secret = tmp_path / "secret.csv"
    secret.write_text("t,z1dd,z2dd\nTOP-SECRET-LINE,1,2\n")
    for p in _records(tmp_path, compose_config, registry):
        _edit(p, lambda d: d["problem"].update(name="vehicle", config={
            "reference": {"file": str(secret)}, "record": {"extra": 1e6}, "ps": 20,
            "iterations": 2}))
    out = tmp_path / "out"
    done = run_cli([str(tmp_path / "sweep"), "-o", str(out)], tmp_path, report=True,
                   timeout=120)
    assert done.returncode in (0, 1) and "Traceback" not in done.stderr
    written = "".join(p.read_text(errors="replace") for p in out.rglob("*")
                      if p.is_file() and p.suffix in (".md", ".csv", ".tex", ".json"))
    assert "TOP-SECRET" not in written + done.stdout + done.stderr


def test_3_override_values_cannot_place_a_job_outside_its_sweep(tmp_path, monkeypatch,
                                                                registry):
    """The issue's ``problem.reference.file=../../../x/ref.csv``: a valid file, so the
    command runs, and its job folder stays one level below the sweep."""
    from vpid_bench.build import build_problem

    (tmp_path / "x").mkdir()
    build_problem(registry, {"name": "vehicle"}).write_artifacts(tmp_path / "x")
    (tmp_path / "x" / "reference.csv").rename(tmp_path / "x" / "ref.csv")
    cwd = tmp_path / "a" / "b" / "c"
    cwd.mkdir(parents=True)
    monkeypatch.chdir(cwd)
    sweep = cwd / "sweep"
    argv = ["-m", "problem=vehicle", "optimizer=random", "runs=1", "problem.iterations=1",
            "progress=false", "report=false", "seed=0,1", f"hydra.sweep.dir={sweep}",
            "problem.reference.file=../../../x/ref.csv"]
    planned = plan_of(argv)
    assert len(planned.job_dirs) == 2
    for d in planned.job_dirs:
        assert d.parent == sweep and d.name not in (".", "..") and "/" not in d.name
    done = run_cli(argv, cwd)
    assert done.returncode == 0, done.stderr
    assert "sweep: 2 job(s), 2 ok" in done.stderr
    assert sorted(p.parent.parent for p in tmp_path.rglob("records/run-*.json")) == sorted(
        planned.job_dirs)
    for text in ("..", ".", "../../x/y", "a" * 5000, "ü/\\\0"):
        name = job_dir_name(text)
        assert "/" not in name and name not in (".", "..") and len(name) <= MAX_JOB_DIR


def test_3_fourteen_long_overrides_give_a_bounded_folder_name(tmp_path):
    long = [f"problem.half_width={1 + i / 7:.15f}" for i in range(2)]
    many = ["optimizer=random", "problem=functions", "problem.dim=3", "problem.ps=7",
            "problem.iterations=2", "seed=3", "budget=20", "runs=1", "progress=false",
            "report=false", "problem.function=sphere", "threads=1", "resume=true",
            "run_timeout_s=100"]
    sweep = tmp_path / "s"
    planned = plan_of(["-m", *many, f"problem.half_width={long[0].split('=')[1]},"
                       f"{long[1].split('=')[1]}", f"hydra.sweep.dir={sweep}"])
    assert len(planned.job_dirs) == 2
    assert all(len(d.name) <= MAX_JOB_DIR for d in planned.job_dirs)
    assert planned.job_dirs[0] != planned.job_dirs[1]


CONTENT_DIGEST_MISSING = not any(
    "content_digest" in vars(cls) for cls in __import__(
        "vpid_vehicle.problem", fromlist=["VehicleProblem"]).VehicleProblem.__mro__
    if cls is not Problem)


@pytest.mark.xfail(CONTENT_DIGEST_MISSING, strict=True,
                   reason="VehicleProblem.content_digest comes with the identify branch")
def test_4_editing_the_reference_file_runs_the_job_again(tmp_path, registry):
    from vpid_bench.build import build_problem

    problem = build_problem(registry, {"name": "vehicle"})
    problem.write_artifacts(tmp_path)
    ref = tmp_path / "measured.csv"
    (tmp_path / "reference.csv").rename(ref)
    job = ["problem=vehicle", "optimizer=random", "runs=1", "problem.iterations=2",
           "progress=false", "report=false", f"problem.reference.file={ref}",
           "hydra.run.dir=job"]
    first = run_cli(job, tmp_path)
    assert first.returncode == 0, first.stderr
    lines = ref.read_text().splitlines()
    cells = lines[5].split(",")
    cells[-1] = repr(float(cells[-1]) * 1.5)
    lines[5] = ",".join(cells)
    ref.write_text("\n".join(lines) + "\n")
    again = run_cli(job, tmp_path)
    assert again.returncode == 0, again.stderr
    assert "1 run(s) done, 0 already recorded" in again.stderr
    # the record made from the old file is set aside, never counted again (issue 24)
    assert "1 record(s) in" in again.stderr and "set aside" in again.stderr
    assert len(list((tmp_path / "job" / "records").glob("run-*.json"))) == 1
    assert len(list((tmp_path / "job" / "records" / "superseded").glob("run-*.json"))) == 1
    report = run_cli([str(tmp_path / "job"), "-o", str(tmp_path / "out")], tmp_path,
                     report=True)
    assert "(1 run records)" in report.stdout, report.stdout + report.stderr


def test_5_a_planted_link_is_replaced_never_followed(tmp_path, registry):
    from vpid_bench.build import build_problem
    from vpid_bench.store.job_status import write_job_status

    outside = tmp_path / "outside"
    outside.mkdir()
    job = tmp_path / "job"
    job.mkdir()
    targets = {}
    for name in ("reference.csv", "job.json"):
        targets[name] = outside / f"target-{name}"
        targets[name].write_text("precious\n")
        os.symlink(targets[name], job / name)
    build_problem(registry, {"name": "vehicle"}).write_artifacts(job)
    write_job_status(job, "ok", "done")
    for name, target in targets.items():
        assert target.read_text() == "precious\n"
        assert not (job / name).is_symlink() and (job / name).stat().st_size > 10
    record_link = rec.record_path(job, 0, "abc")
    record_link.parent.mkdir()
    os.symlink(targets["job.json"], record_link)
    rec.write_record(record_link, {"schema": rec.SCHEMA})
    assert targets["job.json"].read_text() == "precious\n" and not record_link.is_symlink()


def test_a_broken_optimum_lock_is_a_terminal_warning(tmp_path, registry, compose_config,
                                                      capsys):
    """An optimum lock replaced by a folder or a dangling link: the analysis failed with a
    warning only in the job's log; now one warning: line on the terminal, runs recorded."""
    import os

    from vpid_bench.experiment import run_job
    from vpid_bench.spec import parse_job

    job = parse_job(compose_config(["problem=vehicle", "optimizer=random", "runs=2",
                                    "problem.iterations=2", "progress=false", "report=false",
                                    "resume=false"]), registry)
    run_job(job, tmp_path / "job", registry)
    locks = sorted((tmp_path / "job" / "optima").glob("*.lock"))
    assert locks
    for i, lock in enumerate(locks):
        lock.unlink()
        if i % 2:
            lock.mkdir()
        else:
            os.symlink(tmp_path / "nowhere", lock)
    capsys.readouterr()
    again = run_job(job, tmp_path / "job", registry)
    assert again.ran == 2 and not again.failed
    err = capsys.readouterr().err
    warning = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert len(warning) == 1 and "analysis failed" in warning[0], err


def test_links_planted_at_hydra_files_are_not_written_through_on_resume(tmp_path):
    """On resume a symlinked job .hydra/ or sweep multirun.yaml was written through."""
    outside = tmp_path / "outside"
    (outside / "hydra").mkdir(parents=True)
    (outside / "multirun.yaml").write_text("mine\n")
    sweep = ["-m", *TINY, "hydra.sweep.dir=sweep"]
    assert run_cli(sweep, tmp_path).returncode == 0
    (job,) = [p for p in (tmp_path / "sweep").iterdir() if (p / ".hydra").is_dir()]
    shutil.rmtree(job / ".hydra")
    (job / ".hydra").symlink_to(outside / "hydra", target_is_directory=True)
    (tmp_path / "sweep" / "multirun.yaml").unlink()
    (tmp_path / "sweep" / "multirun.yaml").symlink_to(outside / "multirun.yaml")
    again = run_cli([*sweep, "resume=false"], tmp_path)
    assert again.returncode == 0, again.stderr
    assert list((outside / "hydra").iterdir()) == []
    assert (outside / "multirun.yaml").read_text() == "mine\n"
    assert (job / ".hydra" / "config.yaml").is_file() and not (job / ".hydra").is_symlink()


def test_a_report_that_could_not_be_written_makes_the_command_exit_1(tmp_path):
    """The report's folder cannot be made (a file in its place, as a full disk would): the
    report and its status file are both missing; the command once exited 0 all the same."""
    (tmp_path / "sweep").mkdir()
    (tmp_path / "sweep" / "report").write_text("in the way\n")
    done = run_cli(["-m", *[a for a in TINY if a != "report=false"], "hydra.sweep.dir=sweep"],
                   tmp_path)
    assert done.returncode == 1, done.stderr
    assert "warning: the report was not written" in done.stderr
    assert "Traceback" not in done.stderr
