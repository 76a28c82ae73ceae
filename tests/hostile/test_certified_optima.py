"""Issue 35, failures 10 and 14.

10. ``target=`` trusted an archive's optima: a forged ``f_opt`` stopped every run after a few
    evaluations, recorded ``ok``, and optima of two archives that disagree were resolved
    silently (the lowest won). An optimum now carries its point, and the installed problem
    evaluates its objective there (and at the truth) before the optimum is trusted;
    archives that disagree are refused.
14. Bad ``target=`` and ``budget_per_dim=`` values were refused only when their job started
    (exit 1, two lines): the pre-flight now refuses them, one ``error:`` line, exit 2,
    before any job runs.

The archives here are optima-only archives of ``smoke_quarter``'s first instances, packed
from a small sweep by this code, then forged and re-hashed as a forger would.
"""

from __future__ import annotations

import gzip
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from hostile_helpers import error_lines, main_in_process, run_cli

from vpid_bench.store import archive as arch

PROBLEM = "smoke_quarter"
JOB = [f"problem={PROBLEM}", "optimizer=random", "runs=2", "progress=false", "report=false",
       "archive=false"]


@pytest.fixture(scope="module")
def genuine(tmp_path_factory, compose_config, registry) -> list[dict]:
    """The optima of instances 0 and 1, polished by this code (a sweep of 2 runs, packed)."""
    from vpid_bench.experiment import run_from_config
    from vpid_bench.report.pack import pack

    root = tmp_path_factory.mktemp("optima")
    run_from_config(compose_config([*JOB, "problem.iterations=2"]), root / "sweep" / "job",
                    registry, optima_dir=root / "sweep" / "optima")
    pack(root / "sweep", "smoke", root / "packed", command="t", commit=None,
         made_at="2026-01-01T00:00:00+00:00", optima_only=True)
    optima = [json.loads(line) for line in (root / "packed" / arch.OPTIMA).read_text()
              .splitlines()]
    assert [o["instance"] for o in optima] == ["seed=0/0", "seed=0/1"]
    return optima


@pytest.fixture
def optima(genuine) -> list[dict]:
    """A fresh copy to forge."""
    return json.loads(json.dumps(genuine))


def _archive(folder: Path, optima: list[dict]) -> Path:
    """An optima-only archive of ``optima`` in ``folder`` whose checksums match."""
    folder.mkdir(parents=True)
    (folder / arch.RECORDS).write_bytes(gzip.compress(b"", mtime=0))
    (folder / arch.OPTIMA).write_text("".join(json.dumps(o) + "\n" for o in optima))
    files = {name: {"sha256": hashlib.sha256((folder / name).read_bytes()).hexdigest()}
             for name in (arch.RECORDS, arch.OPTIMA)}
    (folder / arch.MANIFEST).write_text(json.dumps({
        "schema": arch.SCHEMA, "suite": folder.name, "files": files,
        "problems": {PROBLEM: {}}, "optima_only": True}))
    return folder


def _instance(index: int):
    from vpid_bench.build import build_problem
    from vpid_bench.plugins import Registry

    return build_problem(Registry(), {"name": PROBLEM}).instance(index)


def _job(tmp_path: Path, root: Path, *extra: str):
    return run_cli([*JOB, "target=1e-8", *extra, f"hydra.run.dir={tmp_path / 'job'}"],
                   tmp_path, env={arch.ARCHIVE_DIR_ENV: str(root)})


def _refusal(in_tmp, capsys, monkeypatch, root: Path, *argv: str) -> tuple[int, str]:
    """The command in this process (a refusal happens in the pre-flight, before any job: the
    command line itself is proved by the control above and test_hostile_refusals.py), with
    ``root`` as the archives: (exit code, stderr)."""
    monkeypatch.setenv(arch.ARCHIVE_DIR_ENV, str(root))
    return main_in_process(list(argv), capsys)


def _job_refused(in_tmp, capsys, monkeypatch, root: Path, *words: str) -> str:
    code, err = _refusal(in_tmp, capsys, monkeypatch, root, *JOB, "target=1e-8",
                         f"hydra.run.dir={in_tmp / 'job'}")
    return _refused(code, err, *words)


def _refused(code: int, err: str, *words: str) -> str:
    assert code == 2, err[-2000:]
    (line,) = err.splitlines()
    assert line == error_lines(err)[0]
    assert line.startswith("error: target=1e-08 is not allowed: optima the installed problem "
                           f"confirms: {PROBLEM} run 0 (instance seed=0/0): ")
    for w in words:
        assert w in line, line
    return line


def test_10_a_genuine_archive_is_confirmed_and_its_runs_stop(tmp_path, optima):
    """The control: genuine optima pass the re-evaluation and the runs stop there."""
    root = tmp_path / "archives"
    _archive(root / "smoke", optima)
    done = _job(tmp_path, root)
    assert done.returncode == 0, done.stderr[-2000:]
    records = [json.loads(p.read_text()) for p in (tmp_path / "job").glob("records/run-*")]
    assert len(records) == 2 and all("target" in r for r in records)


def test_10_a_forged_f_opt_is_refused_before_any_run(in_tmp, optima, capsys, monkeypatch):
    """f_opt raised tenfold: every run would stop at once (after one batch), recorded ok."""
    optima[0]["f_opt"] *= 10
    root = in_tmp / "archives"
    _archive(root / "smoke", optima)
    _job_refused(in_tmp, capsys, monkeypatch, root, "the archive gives f_opt",
                 "the installed problem", "there", "rebuild the archive")
    assert not list(in_tmp.rglob("records/run-*.json"))  # nothing ran


def test_10_a_consistent_forgery_above_the_truth_is_refused(in_tmp, optima, capsys,
                                                              monkeypatch):
    """A forger who evaluates the problem: a point 10 % off the truth with its true value.
    The value checks out there, but it lies above the objective at the truth: no optimum."""
    inst = _instance(0)
    x = np.clip(np.asarray(inst.x_true) * 1.1, inst.bounds.lower, inst.bounds.upper)
    optima[0].update(x_opt=x.tolist(), f_opt=float(inst.evaluate(x[None, :])[0]))
    root = in_tmp / "archives"
    _archive(root / "smoke", optima)
    _job_refused(in_tmp, capsys, monkeypatch, root, "lies above the objective at the truth")


def test_10_a_point_outside_the_box_is_refused(in_tmp, optima, capsys, monkeypatch):
    optima[0]["x_opt"][0] = 1e6
    root = in_tmp / "archives"
    _archive(root / "smoke", optima)
    _job_refused(in_tmp, capsys, monkeypatch, root, "lies outside the search box")


def test_10_archives_that_disagree_are_refused(in_tmp, genuine, optima, capsys, monkeypatch):
    """Two archives certify instance 0 with different values; the lower one once won."""
    optima[0]["f_opt"] *= 1 - 1e-3
    root = in_tmp / "archives"
    _archive(root / "a", genuine)
    _archive(root / "b", optima)
    line = _job_refused(in_tmp, capsys, monkeypatch, root, "the archives disagree on its optimum")
    assert str(root / "a") in line and str(root / "b") in line


@pytest.mark.parametrize(("args", "words"), [
    ([f"problem={PROBLEM}", "budget_per_dim=999999999"],
     "budget_per_dim=999999999 is not allowed: at most 250000000 for a problem of 4"),
    (["problem=functions", "target=1e-8"],
     "target=1e-08 is not allowed: runs whose instance optimum is certified in advance: "
     "functions run 0"),
    (["-m", f"problem={PROBLEM},functions", "target=1e-8"],  # the second job's value
     "target=1e-08 is not allowed: runs whose instance optimum is certified in advance: "
     "functions run 0"),
], ids=["budget_per_dim", "target", "target-in-a-sweep"])
def test_14_the_preflight_refuses_what_only_the_built_problem_tells(args, words, in_tmp,
                                                                     genuine, capsys,
                                                                     monkeypatch):
    root = in_tmp / "archives"  # certifies smoke_quarter's runs: only functions lacks one
    _archive(root / "smoke", genuine)
    code, err = _refusal(in_tmp, capsys, monkeypatch, root, *args, *JOB[1:])
    assert code == 2, err[-2000:]
    (line,) = err.splitlines()
    assert line.startswith(f"error: {words}"), line
    assert not (in_tmp / "outputs").exists()  # refused before any folder was written
    assert not list(in_tmp.rglob("records"))


@pytest.mark.parametrize("fault", ["abort", "exit", "raise"])
def test_14_the_preflight_builds_problems_in_a_supervised_worker(fault):
    """A problem whose constructor aborts (or exits, or raises) costs the pre-flight's check
    nothing: it runs in a worker process, like the jobs' calls into plugin code, and the job
    meets the fault again and says why. This process goes on, in the same folder."""
    import dataclasses
    import os

    from test_fault_matrix import PS, _job

    from vpid_bench.shell.preflight import check_sized_jobs

    here = os.getcwd()
    job = _job(fault, "build")
    job = dataclasses.replace(job, spec=dataclasses.replace(job.spec, budget_per_dim=PS))
    assert check_sized_jobs([job]) is None
    assert os.getcwd() == here


def test_14_each_problem_is_checked_once_whatever_its_optimizers(monkeypatch, compose_config,
                                                                 registry):
    """The check depends on the problem, its runs, budget and target, not on the optimizer:
    the 19 optimizers of an archive build's member were checked 19 times (323 checks, 37 s of
    the build's pre-flight, one after another). Another budget is another check."""
    from vpid_bench import targets
    from vpid_bench.shell.preflight import check_sized_jobs
    from vpid_bench.spec import parse_job

    checked = []
    monkeypatch.setattr(targets, "check_sized",
                        lambda job, problem: checked.append((job.optimizer_name,
                                                             job.spec.budget_per_dim)))
    jobs = [parse_job(compose_config([f"problem={PROBLEM}", f"optimizer={opt}", "runs=2",
                                      f"budget_per_dim={per}", "isolation=none"]), registry)
            for per in (10, 20) for opt in ("random", "de1", "centre")]
    assert check_sized_jobs(jobs) is not None  # checked here (isolation=none)
    assert checked == [("random", 10), ("random", 20)]
