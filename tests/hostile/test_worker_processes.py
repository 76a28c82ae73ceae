"""Issue 35, failures 1-5, 13 and 18: processes a plugin starts, a pipe it closes, problem code
the sweep once ran in its own process, more workers than a job can use, and a job whose every
run times out. The plugins (process_plugins.py) are planted as a third party's distribution;
each sweep runs as the user runs it, and every process a plugin starts notes its id, so each
test checks that none outlives the sweep and that the sweep did not wait for it."""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import time
from pathlib import Path

import psutil
import pytest
from extras import limit
from hostile_helpers import CLI, cli_env, error_lines
from process_plugins import CHILD_S, PIDS_ENV, Base, Crashy, left_running

HERE = Path(__file__).parent
BASE = ["problem.iterations=2", "progress=false", "report=false", "hydra.sweep.dir=sweep"]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """A folder holding the distribution metadata of ``process_plugins`` (its module stays
    in tests/hostile, on the same path)."""
    folder = tmp_path_factory.mktemp("site")
    info = folder / "vpid_process_plugins-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: vpid_process_plugins\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text("[vpid_bench]\nprocess_plugins = process_plugins\n")
    return folder


def _env(site: Path, pids: Path) -> dict[str, str]:
    pids.mkdir(exist_ok=True)
    return cli_env({"PYTHONPATH": os.pathsep.join([str(site), str(HERE)]),
                    PIDS_ENV: str(pids)})


def _started(pids: Path, kind: str) -> dict[int, float]:
    """The processes of ``kind`` the plugins started: id -> start time (time.time())."""
    return {int(p.name.rsplit("-", 1)[1]): float(p.read_text())
            for p in pids.glob(f"{kind}-*")}


def _records(cwd: Path, pattern: str) -> list[dict]:
    return [json.loads(p.read_text()) for p in
            sorted((cwd / "sweep").glob(f"{pattern}/records/run-*.json"))]


# ---- failures 1 and 2: a fork that outlives its worker; a daemon holding the streams ----


@pytest.fixture(scope="module")
def piped(site, tmp_path_factory):
    """``vpid-bench -m optimizer=random,forkexit,orphan ... | tail``, as a user pipes it, with
    no run_timeout_s: (its folder, its pids folder, the command's exit status, what tail
    printed, when the pipeline ended)."""
    cwd = tmp_path_factory.mktemp("piped")
    pids = cwd.parent / f"{cwd.name}-pids"
    command = shlex.join([*CLI, "-m", "optimizer=random,forkexit,orphan", "problem=functions",
                          "runs=2", *BASE])
    done = subprocess.run(["bash", "-c", f"{command} 2>&1 | tail -n 30; exit "
                           "${PIPESTATUS[0]}"], cwd=cwd, env=_env(site, pids),
                          capture_output=True, text=True, timeout=limit(300), check=False)
    return cwd, pids, done.returncode, done.stdout, time.time()


def test_a_fork_that_outlives_its_worker_does_not_hold_the_sweep(piped):
    """Failure 1: ask() forks a child that lives 40 s with the worker's pipe, then the worker
    exits. The sweep learns of the death from the process, not the pipe: each run fails with
    how its worker ended (not a time limit: none is set), the sweep ends in seconds, not when
    the children do, the other optimizer's runs are intact, and no child is left."""
    cwd, pids, code, out, ended = piped
    children = _started(pids, "forkexit")
    assert children, out
    assert ended - min(children.values()) < CHILD_S, "the sweep waited for the forked child"
    assert code == 1, out
    failed = _records(cwd, "optimizer=forkexit,*")
    assert [r["status"] for r in failed] == ["failed", "failed"]
    for r in failed:
        assert r["error"]["type"] == "WorkerDiedError", r["error"]
        assert "its worker process ended (exit code 3)" in r["error"]["message"]
    assert [r["status"] for r in _records(cwd, "optimizer=random,*")] == ["ok", "ok"]
    assert "Traceback" not in out
    assert left_running(pids) == []


def test_an_orphan_never_holds_the_commands_streams(piped):
    """Failure 2: a plugin's daemon (double fork, its own session) keeps the standard output
    and error it inherited for 40 s. The pipe to ``tail`` ends with the command: a worker's
    streams are pipes the supervisor reads, never the command's own; and the daemon, found
    among its worker's descendants, does not outlive the task."""
    cwd, pids, _, out, ended = piped
    daemons = _started(pids, "orphan")
    assert daemons, out
    assert ended - min(daemons.values()) < CHILD_S, "tail waited for the orphan"
    assert [r["status"] for r in _records(cwd, "optimizer=orphan,*")] == ["ok", "ok"]
    assert "sweep: 3 job(s), 2 ok, 1 not ok" in out
    assert "left 1 process(es) running" in out
    assert left_running(pids) == []
    assert sorted(p.name for p in cwd.iterdir()) == ["sweep"]


# ---- failures 3 and 4 (and 13): both copies of a fork go on; a plugin closes the pipe ----


@pytest.fixture(scope="module")
def forked(site, tmp_path_factory):
    cwd = tmp_path_factory.mktemp("forked")
    pids = cwd.parent / f"{cwd.name}-pids"
    done = subprocess.run([*CLI, "-m", "optimizer=random,forkboth,closepipe",
                           "problem=functions", "runs=4", "workers=1000", *BASE], cwd=cwd,
                          env=_env(site, pids), capture_output=True, text=True, timeout=limit(300),
                          check=False)
    return cwd, pids, done


def test_a_fork_whose_copies_both_go_on_costs_nothing(forked):
    """Failure 3: ask() forks once and both copies run on. The copy's messages never reach the
    sweep (its pipe is closed at the fork and it sends nothing), so no run is counted twice:
    every run is recorded ok, no internal error, no traceback, and the copy is ended with its
    worker when the task is over."""
    cwd, pids, done = forked
    records = _records(cwd, "optimizer=forkboth,*")
    assert [r["status"] for r in records] == ["ok"] * 4, done.stderr[-3000:]
    assert "Traceback" not in done.stderr and "not in list" not in done.stderr
    assert _started(pids, "forkboth")
    assert left_running(pids) == []


def test_a_plugin_that_closes_its_pipe_fails_its_runs_in_one_line(forked):
    """Failure 4: closing every descriptor above 2 in ask() (the worker's pipe among them):
    the worker ends quietly (no traceback), each run fails with that reason, the sweep goes
    on to the next job."""
    cwd, _, done = forked
    failed = _records(cwd, "optimizer=closepipe,*")
    assert [r["status"] for r in failed] == ["failed"] * 4
    assert all("pipe to the sweep was closed" in r["error"]["message"] for r in failed), failed
    assert done.returncode == 1
    assert "Traceback" not in done.stderr
    assert "sweep: 3 job(s), 2 ok, 1 not ok" in done.stderr
    assert [r["status"] for r in _records(cwd, "optimizer=random,*")] == ["ok"] * 4


def test_more_workers_than_a_job_can_use_are_capped_and_said(forked):
    """Failure 13 (the command): workers=1000 is capped by the machine's memory, said in one
    line once."""
    _, _, done = forked
    notes = [ln for ln in done.stderr.splitlines() if ln.startswith("note: workers=1000")]
    assert len(notes) == 1, done.stderr[-2000:]
    assert "GB of memory available" in notes[0] or "open-file limit" in notes[0]


# ---- failure 5: problem code the command once ran in its own process ----


@pytest.fixture(scope="module")
def crashed(site, tmp_path_factory):
    """A problem that segfaults in metrics(), describe(), the optimum polish (its residual
    groups) or signals(), beside a healthy one; then the same command resumed."""
    cwd = tmp_path_factory.mktemp("crashed")
    pids = cwd.parent / f"{cwd.name}-pids"
    args = [*CLI, "-m", "problem=crashy", "problem.fault_at=none,metrics,describe,polish,"
            "signals", "optimizer=random", "runs=2", *BASE]
    env = _env(site, pids)
    first = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True,
                           timeout=limit(300), check=False)
    again = subprocess.run([*args, "--resume"], cwd=cwd, env=env, capture_output=True,
                           text=True, timeout=limit(300), check=False)
    return cwd, first, again


def _job(cwd: Path, place: str) -> Path:
    (folder,) = (cwd / "sweep").glob(f"*fault_at={place},*")
    return folder


def test_a_segfault_in_problem_code_costs_its_job_or_runs_not_the_sweep(crashed):
    """Failure 5: metrics() and describe() once ran in the command's process (a segfault ended
    the sweep with -11, no record, the next job never ran; every resume the same). Now every
    call into problem code runs in a worker: a crash in metrics() fails its runs with the
    reason, one in describe() fails its job in one line, one in the polish or the signals
    after the runs is a warning; the healthy job runs whole."""
    cwd, first, _ = crashed
    assert first.returncode == 1, first.stderr[-3000:]
    assert "sweep: 5 job(s), 3 ok, 2 not ok" in first.stderr
    assert "Traceback" not in first.stderr
    metrics = _records(cwd, "*fault_at=metrics,*")
    assert [r["status"] for r in metrics] == ["failed", "failed"]
    assert all("signal SIGSEGV" in r["error"]["message"] and "metrics()" in
               r["error"]["message"] for r in metrics), metrics[0]["error"]
    described = [ln for ln in error_lines(first.stderr) if "fault_at=describe" in ln]
    assert len(described) == 1 and "signal SIGSEGV" in described[0], first.stderr[-3000:]
    assert not list(_job(cwd, "describe").glob("records/run-*.json"))
    for place in ("polish", "signals", "none"):
        assert [r["status"] for r in _records(cwd, f"*fault_at={place},*")] == ["ok", "ok"]
    warnings = [ln for ln in first.stderr.splitlines() if ln.startswith("warning:")]
    assert any("analysis failed" in w and "SIGSEGV" in w for w in warnings), warnings
    assert any("signals failed" in w and "SIGSEGV" in w for w in warnings), warnings
    assert not (_job(cwd, "signals") / "best_signals.csv").exists()
    assert (_job(cwd, "none") / "best_signals.csv").is_file()
    assert sorted(p.name for p in cwd.iterdir()) == ["sweep"]


def test_a_resume_after_a_crash_in_problem_code_ends_like_the_first_command(crashed):
    """Failure 5: every resume once died the same way; now it ends with its summary, the ok
    runs kept."""
    _, _, again = crashed
    assert again.returncode == 1, again.stderr[-3000:]
    assert "sweep: 5 job(s), 3 ok, 2 not ok" in again.stderr
    assert "random on crashy: 0 run(s) done, 2 already recorded" in again.stderr


# ---- failure 18: a sweep whose every run times out ----


def test_a_sweep_whose_every_run_times_out_records_each_run_failed(site, tmp_path):
    """Failure 18: a constructor slower than run_timeout_s, so that every run of the sweep
    times out, once failed the job as a whole: no record, and the report had nothing to say.
    Each run is recorded as failed with the reason, at once (the runs are not tried one by one
    to time out alike), and the report lists them with it."""
    t0 = time.monotonic()
    done = subprocess.run([*CLI, "-m", "optimizer=slowbuild", "problem=functions", "runs=2",
                           "run_timeout_s=1", "progress=false", "hydra.sweep.dir=sweep"],
                          cwd=tmp_path, env=_env(site, tmp_path.parent / f"{tmp_path.name}-p"),
                          capture_output=True, text=True, timeout=limit(300), check=False)
    assert time.monotonic() - t0 < 120  # bounded: one constructor stopped after 1 s
    assert done.returncode == 1, done.stderr[-3000:]
    records = _records(tmp_path, "optimizer=slowbuild,*")
    assert [r["status"] for r in records] == ["failed", "failed"]
    assert all(r["error"]["type"] == "RunTimeoutError" and "run_timeout_s=1" in
               r["error"]["message"] for r in records), records[0]["error"]
    report = (tmp_path / "sweep" / "report" / "report.md").read_text()
    assert "2 run(s) on functions (0 ok, 2 failed)" in report
    failed = [ln for ln in report.splitlines() if ln.startswith("- **Failed run** slowbuild")]
    assert len(failed) == 2 and all("RunTimeoutError" in ln for ln in failed), failed


# ---- failure 13, in this process: the worker cap ----


def _job_of(optimizer: type, runs: int, **spec):
    from vpid_bench.spec import Job, JobSpec

    config = Crashy.Config(ps=4, iterations=2)
    params = optimizer.Params(ps=4, iterations=2, budget=12)
    return Job(JobSpec(runs=runs, progress=False, report=False, isolation="process", **spec),
               "crashy", Crashy, config, optimizer.__name__.lower(), optimizer, params, 12)


def test_a_job_never_starts_more_workers_than_it_has_runs(tmp_path, monkeypatch, capsys):
    """Failure 13: workers=1000 once started 1000 processes for 3 runs; a worker set is capped
    by the memory available (one per WORKER_MB), said in one line, and a job starts no more
    workers than it has runs."""
    import vpid_bench.workers as workers
    from vpid_bench.experiment import run_job

    started = []
    real = workers.Workers._start

    def counting(self):
        started.append(1)
        return real(self)

    monkeypatch.setattr(workers.Workers, "_start", counting)
    monkeypatch.setattr(workers, "worker_cap", lambda: (50, "a cap for this test"))
    pool = workers.Workers(1000)
    try:
        assert pool.size == 50
        summary = run_job(_job_of(Base, 3, workers=1000), tmp_path, pool=pool)
    finally:
        pool.close()
    assert summary.ran == 3 and not summary.failed
    assert 1 <= len(started) <= 3
    notes = [ln for ln in capsys.readouterr().err.splitlines() if "workers=1000" in ln]
    assert notes == ["note: workers=1000: at most 50 worker processes on this machine (a cap "
                     "for this test); a job also never starts more than it has runs to give "
                     "them"]


def test_the_worker_cap_follows_the_memory_available(monkeypatch):
    """Failure 13: the cap is one worker per WORKER_MB of the memory available, at least one,
    and says why."""
    import vpid_bench.workers as workers

    for gigabytes, expected in ((0.1, 1), (1.0, 4), (10.0, 40)):
        monkeypatch.setattr(psutil, "virtual_memory", lambda g=gigabytes: type(
            "Memory", (), {"available": int(g * 2**30)})())
        cap, why = workers.worker_cap()
        if "open-file limit" not in why:  # a tiny open-file limit caps first
            assert cap == expected and f"{gigabytes:.1f} GB of memory available" in why
