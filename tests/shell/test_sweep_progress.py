"""The progress line of a whole ``-m`` sweep: jobs and runs done of the total, and the time
left estimated from the runs this command ran."""

from __future__ import annotations

import io
import math
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench.shell.progress import SweepProgress, duration  # noqa: E402


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
