"""The progress of a whole ``-m`` sweep: after each job, one line with the jobs and runs done,
the time spent and an estimate of the time left (jobs in the command's process)."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any, TextIO

from ..progress import duration


class SweepProgress:
    """Counts a sweep's jobs and runs as they end (``jobs``, ``runs``: its totals); the time
    left is the time per run this command ran so far times the runs still to do."""

    def __init__(self, jobs: int, runs: int, clock: Callable[[], float] = time.monotonic,
                 stream: TextIO | None = None) -> None:
        self.jobs, self.runs = jobs, runs
        self.clock = clock
        self.stream = stream
        self.start = clock()
        self.jobs_done = 0
        self.runs_done = 0  # runs accounted for: run now, found recorded, or of a failed job
        self.runs_run = 0  # runs this command ran (what the estimate is made from)

    def job_done(self, ran: int, skipped: int, not_run: int = 0) -> str:
        """Count one job (runs run, found recorded, not run: it failed); print, return its line."""
        self.jobs_done += 1
        self.runs_done += ran + skipped + not_run
        self.runs_run += ran
        line = self.line()
        print(line, file=self.stream or sys.stderr, flush=True)
        return line

    def left_s(self) -> float:
        """Estimated seconds left (NaN before any run was run, 0 at the end)."""
        remaining = max(0, self.runs - self.runs_done)
        if remaining == 0:
            return 0.0
        if self.runs_run == 0:
            return math.nan
        return (self.clock() - self.start) / self.runs_run * remaining

    def line(self) -> str:
        left = self.left_s()
        eta = ("done" if left == 0 else "time left unknown yet" if math.isnan(left)
               else f"about {duration(left)} left")
        return (f"sweep: {self.jobs_done}/{self.jobs} jobs, {self.runs_done}/{self.runs} runs "
                f"done, {duration(self.clock() - self.start)} elapsed, {eta}")


#: Above this estimate (s) the first line points to quicker first steps (docs/plugins.md).
QUICK_PATH_S = 600.0


def first_line(jobs: Sequence[Any], per_evaluation: Mapping[str, float]) -> str:
    """The sweep's line before any work: its jobs and runs and about how long they take
    (each run's budget times ``per_evaluation`` of its problem, from the archives' builds)."""
    runs = sum(j.spec.runs for j in jobs)
    timed = [j for j in jobs if j.problem_name in per_evaluation]
    seconds = sum(j.spec.runs * j.budget * per_evaluation[j.problem_name] for j in timed)
    head = f"sweep: {len(jobs)} job(s), {runs} run(s)"
    if not timed:
        return f"{head}; time left known once the first job ends"
    rest = (f" for the {len(timed)} job(s) on problems the archives timed; the others "
            "known once they run") if len(timed) < len(jobs) else ""
    line = (f"{head}: about {duration(seconds)}{rest} (each run's budget at the time per "
            "evaluation of its problem in the archives' builds; an optimizer's own cost per "
            "candidate adds to it, a run stopped at its target costs less)")
    if seconds > QUICK_PATH_S:
        line += ("\n  placing a new optimizer? a first place in minutes: -m suite=smoke "
                 "optimizer=<yours>; then suite=vpid1 runs=5 (docs/plugins.md, \"Placing a new "
                 "optimizer\")")
    return line
