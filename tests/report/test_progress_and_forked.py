"""Progress lines of long commands (vpid_bench/progress.py) and the report's pieces computed
side by side in forked processes (vpid_bench/report/forked.py): the same results as one
after another, an error raised as here, a dead process costing only speed."""

from __future__ import annotations

import io
import os
from pathlib import Path

import psutil
import pytest
from archive_slice import slice_archive
from extras import every_core, needs_archive_runs

from vpid_bench.progress import Stages, duration
from vpid_bench.report.forked import run_forked

ARCHIVES = Path(__file__).parents[2] / "archive"


class _Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_stages_say_each_stage_and_the_time_left_at_the_stages_pace():
    clock, out = _Clock(), io.StringIO()
    s = Stages("report", stream=out, clock=clock, every_s=5.0)
    assert s.stage("reading the records") == "report: reading the records, 0 s elapsed"
    clock.t += 10
    assert s.stage("figures", 40) == "report: figures (40), 10 s elapsed"
    clock.t += 2
    assert s.step(1) is None  # within every_s of the stage's start: quiet
    clock.t += 8  # 10 s for 10 of 40 figures: 30 s left at that pace
    assert s.step(10) == "report: figures 10/40, about 30 s left, 20 s elapsed"
    clock.t += 1
    assert s.step(11) is None
    clock.t += 1
    assert s.step(40) == "report: figures 40/40, 22 s elapsed"  # the last step: always
    assert out.getvalue().count("\n") == 4


def test_no_time_left_from_a_pace_of_too_few_steps():
    clock = _Clock()
    s = Stages("report", stream=io.StringIO(), clock=clock, every_s=0.0)
    s.stage("figures", 69)
    clock.t += 19  # the first figure (the convergence panels) takes long
    assert s.step(1) == "report: figures 1/69, 19 s elapsed"


def test_duration_in_words():
    assert [duration(s) for s in (0.4, 59, 61, 3599, 3661)] == \
        ["0 s", "59 s", "1 min 01 s", "59 min 59 s", "1 h 01 min"]


def test_run_forked_gives_the_results_in_order_with_unpicklable_calls():
    local = {"k": 3}  # a closure over local data: inherited by fork, never pickled
    calls = [lambda i=i: (i, os.getpid(), local["k"] * i) for i in range(6)]
    seen: list[int] = []
    with every_core():  # a test process has one core of its own (tests/conftest.py)
        out = run_forked(calls, seen.append)
    assert [(i, v) for i, _, v in out] == [(i, 3 * i) for i in range(6)]
    assert seen == list(range(1, 7))
    if (os.cpu_count() or 1) > 1 and len(os.sched_getaffinity(0)) > 1:
        assert os.getpid() not in {pid for _, pid, _ in out}  # computed elsewhere


def test_run_forked_raises_a_calls_error_here():
    def bad():
        raise ValueError("the call's own error")

    with pytest.raises(ValueError, match="the call's own error"):
        run_forked([lambda: 1, bad])


def test_a_forked_process_that_dies_costs_only_speed():
    """The calls run here again, and the pool's other process is ended, not left behind."""
    parent = os.getpid()

    def dies_elsewhere():
        if os.getpid() != parent:
            os._exit(3)  # a crash in a library, in the forked process only
        return "here"

    before = {c.pid for c in psutil.Process().children()}
    with every_core():  # a test process has one core of its own (tests/conftest.py)
        assert run_forked([lambda: 1, dies_elsewhere]) == [1, "here"]
    assert not {c.pid for c in psutil.Process().children()} - before


@needs_archive_runs
def test_the_report_over_an_archive_says_each_stage_on_stderr(tmp_path, capsys):
    """``vpid-bench-report <archive>``: a line as each stage starts and the figures counted
    (stderr), the answer first on stdout."""
    from vpid_bench.report.cli import main

    archive = slice_archive(ARCHIVES / "vpid1", tmp_path / "vpid1",
                            ("vpid1_q_golden_iso_c",), instances=2)
    assert main([str(archive), "-o", str(tmp_path / "report")]) == 0
    out, err = capsys.readouterr()
    stages = [line.split(",")[0] for line in err.splitlines() if line.startswith("report: ")]
    assert stages[:2] == ["report: reading the records", "report: tests over 38 runs"]
    assert stages[2].startswith("report: figures (") and stages[-1] == \
        "report: writing report.md and the site"
    total = stages[2].removeprefix("report: figures (").rstrip(")")
    assert f"report: figures {total}/{total}" in stages
    assert out.startswith("The answer")


def test_an_interrupted_run_forked_ends_its_processes_at_once():
    """A Ctrl-C (or SIGTERM) while the calls run: raised at once, and every process the pool
    forked is ended, not waited for (a call here would sleep 30 s) nor left behind."""
    import time

    def interrupt(n: int) -> None:
        raise KeyboardInterrupt

    before = {c.pid for c in psutil.Process().children()}
    calls = [lambda: 1, lambda: time.sleep(30) or 2, lambda: 3]
    t0 = time.monotonic()
    with every_core(), pytest.raises(KeyboardInterrupt):
        run_forked(calls, interrupt)
    assert time.monotonic() - t0 < 10
    assert not {c.pid for c in psutil.Process().children()} - before
