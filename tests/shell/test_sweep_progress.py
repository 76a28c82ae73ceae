"""The progress line of a whole ``-m`` sweep: jobs and runs done of the total, and the time
left estimated from the runs this command ran."""

from __future__ import annotations

import io
import math
import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench.shell.progress import SweepProgress, duration, first_line  # noqa: E402


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_the_line_counts_jobs_and_runs_and_estimates_the_time_left():
    clock, out = Clock(), io.StringIO()
    p = SweepProgress(jobs=4, runs=40, clock=clock, stream=out)
    # a resumed job: every run found recorded, nothing to estimate from yet
    assert p.job_done(0, 10) == ("sweep: 1/4 jobs, 10/40 runs done, 0 s elapsed, "
                                 "time left unknown yet")
    clock.t += 60.0  # 10 runs in a minute: 6 s a run, 20 runs left -> 120 s
    assert p.job_done(10, 0) == ("sweep: 2/4 jobs, 20/40 runs done, 1 min 00 s elapsed, "
                                 "about 2 min 00 s left")
    clock.t += 30.0  # a job that failed before its runs: they are not waited for
    assert p.left_s() == 90.0 / 10 * 20
    assert p.job_done(0, 0, not_run=10).endswith("30/40 runs done, 1 min 30 s elapsed, "
                                                 "about 1 min 30 s left")
    clock.t += 60.0
    assert p.job_done(10, 0).endswith("4/4 jobs, 40/40 runs done, 2 min 30 s elapsed, done")
    assert out.getvalue().count("\n") == 4 and p.left_s() == 0.0
    assert math.isnan(SweepProgress(1, 5, clock=clock).left_s())


def test_durations_read_as_a_person_writes_them():
    assert [duration(s) for s in (0, 59.4, 60, 185, 3600, 3725, 86400)] == [
        "0 s", "59 s", "1 min 00 s", "3 min 05 s", "1 h 00 min", "1 h 02 min", "24 h 00 min"]


def test_a_sweep_prints_its_progress_after_each_job(tmp_path):
    done = run_cli(["-m", "problem=functions", "optimizer=random,de1", "runs=2",
                    "problem.iterations=5", "problem.dim=2", "report=false",
                    "isolation=none", "hydra.sweep.dir=s"], tmp_path)
    assert done.returncode == 0, done.stderr
    lines = [ln for ln in done.stderr.splitlines() if ln.startswith("sweep: ") and "jobs," in ln]
    assert [re.sub(r" done, .*", " done", ln) for ln in lines] == [
        "sweep: 1/2 jobs, 2/4 runs done", "sweep: 2/2 jobs, 4/4 runs done"]
    assert lines[0].endswith(" left") and lines[1].endswith(", done")


def test_no_line_without_a_plan_of_jobs_or_with_progress_false():
    """The line needs a -m sweep whose jobs the pre-flight planned, with progress on."""
    from types import SimpleNamespace as Ns

    from vpid_bench.shell.main import _sweep_progress

    def plan(multirun=True, progress=(True, True)):
        return Ns(multirun=multirun, jobs=[Ns(spec=Ns(progress=p, runs=3)) for p in progress])

    made = _sweep_progress(plan())
    assert (made.jobs, made.runs) == (2, 6)
    assert _sweep_progress(plan(multirun=False)) is None
    assert _sweep_progress(plan(progress=(True, False))) is None
    assert _sweep_progress(plan(progress=())) is None  # an optimizing sweeper: no plan


class _Spec:
    def __init__(self, runs: int) -> None:
        self.runs = runs


class _Job:
    def __init__(self, problem: str, runs: int, budget: int) -> None:
        self.problem_name, self.spec, self.budget = problem, _Spec(runs), budget


def test_the_first_line_estimates_the_sweep_before_any_work():
    """runs x budget x the archived time per evaluation of each job's problem: 2 jobs of 5
    runs of 400 evaluations at 50 us, one of 10 runs of 900 at 1 ms: 0.2 + 9 s."""
    jobs = [_Job("a", 5, 400), _Job("a", 5, 400), _Job("b", 10, 900)]
    line = first_line(jobs, {"a": 50e-6, "b": 1e-3})
    assert line.startswith("sweep: 3 job(s), 20 run(s): about 9 s (each run's budget at the "
                           "time per evaluation of its problem in the archives' builds")
    assert "placing a new optimizer" not in line  # minutes: no quicker step to point to
    part = first_line([*jobs, _Job("mine", 3, 100)], {"a": 50e-6, "b": 1e-3})
    assert "about 9 s for the 3 job(s) on problems the archives timed; the others known " \
           "once they run" in part
    assert first_line([_Job("mine", 3, 100)], {}) == \
        "sweep: 1 job(s), 3 run(s); time left known once the first job ends"


def test_a_long_estimate_points_to_the_quicker_first_steps():
    line = first_line([_Job("a", 15, 10_000)], {"a": 0.01})  # 25 min
    assert "about 25 min 00 s" in line
    assert line.splitlines()[1].strip().startswith(
        "placing a new optimizer? a first place in minutes: -m suite=smoke optimizer=<yours>")


def test_the_time_per_evaluation_is_read_from_the_archives_summaries(tmp_path):
    """Per problem, the median over optimizers of median run time / median evaluations; the
    box centre's one evaluation and odd rows left out."""
    from vpid_bench.store.archive import SUMMARY, evaluation_seconds

    folder = tmp_path / "suite"
    folder.mkdir()
    (folder / "manifest.json").write_text("{}")
    (folder / SUMMARY).write_text(
        "problem,optimizer,runs,ok,metric,median_metric,median_rel_gap,reached,"
        "median_evaluations,median_run_time_s\n"
        "p,centre,15,15,NoRE,1,1,0,1.0,0.001\n"
        "p,de1,15,15,NoRE,1,1,0,1000,0.1\n"
        "p,de2,15,15,NoRE,1,1,0,1000,0.3\n"
        "p,de3,15,15,NoRE,1,1,0,2000,0.4\n"
        "p,odd,15,15,NoRE,1,1,0,nan,x\n"
        "bad name,de1,15,15,NoRE,1,1,0,1000,0.1\n")
    assert evaluation_seconds(tmp_path) == {"p": pytest.approx(2e-4)}
    assert set(evaluation_seconds()) >= {"smoke_quarter", "vpid1_q_golden_iso_c"}  # shipped
