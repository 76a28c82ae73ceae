"""Issue 44 (round five), process supervision: N1 a reused process id signalled, N2 SIGTERM
and SIGHUP, N3 a daemon that outlives its worker (and held ``| tail``), N4 a process that
keeps forking and calling ``setsid``; and the contract test that ran a third party's optimizer
in the pytest process. The plugins (round5_plugins.py) are planted as a third party's
distribution, as in test_worker_processes.py."""
# ruff: noqa: N802 - each test is named by its failure's id in the issue (test_N1_...)

from __future__ import annotations

import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hostile_helpers import CLI, cli_env
from process_plugins import CHILD_S, PIDS_ENV, left_running

HERE = Path(__file__).parent
ROOT = HERE.parent.parent
BASE = ["problem=functions", "problem.iterations=2", "progress=false", "report=false",
        "hydra.sweep.dir=sweep"]


def _site(folder: Path, name: str, module: str) -> Path:
    """``folder`` holding the distribution metadata of ``module`` (an entry point ``name``)."""
    info = folder / f"vpid_{name}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: vpid_{name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[vpid_bench]\n{name} = {module}\n")
    return folder


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    return _site(tmp_path_factory.mktemp("site"), "round5", "round5_plugins")


def _env(site: Path, pids: Path, **extra: str) -> dict[str, str]:
    pids.mkdir(parents=True, exist_ok=True)
    return cli_env({"PYTHONPATH": os.pathsep.join([str(site), str(HERE)]), PIDS_ENV: str(pids),
                    **extra})


def _cgroups() -> bool:
    from vpid_bench.cgroups import Cgroup

    group = Cgroup.create(f"vpid-bench-test-{os.getpid()}")
    if group is None:
        return False
    group.remove()
    return True


#: The two ways a worker's tree is found: its cgroup (where one can be made) and the mark in
#: its processes' environment (everywhere; the only way where no cgroup can be made).
WAYS = [pytest.param("cgroup", marks=pytest.mark.skipif(
            not _cgroups(), reason="no cgroup v2 this process may create (not root, or no "
                                   "delegated cgroup): the mark is tested alone")),
        "mark"]


def _ways_env(way: str) -> dict[str, str]:
    return {"VPID_BENCH_CGROUPS": "1" if way == "cgroup" else "0"}


def _records(cwd: Path) -> dict[str, str]:
    """Each run record under ``cwd/sweep``: its path -> its status."""
    return {str(p.relative_to(cwd)): json.loads(p.read_text())["status"]
            for p in sorted((cwd / "sweep").glob("*/records/run-*.json"))}


# ---- N1: a reused process id is never signalled ----


class _Signals:
    """Every signal this process sends by number (``os.kill``, ``os.killpg``) or through a
    pidfd, and whether the kernel delivered it."""

    def __init__(self, monkeypatch) -> None:
        self.by_number: list[tuple[str, int, int]] = []
        self.delivered: list[int] = []
        real = signal.pidfd_send_signal

        def kill(name):
            real_kill = getattr(os, name)

            def send(pid, sig):
                if sig == 0:  # psutil's check that a number is in use: no signal
                    return real_kill(pid, sig)
                self.by_number.append((name, pid, sig))
                return None
            return send

        def pidfd_send(fd, sig, *args):
            real(fd, sig, *args)  # raises ProcessLookupError when nothing got it
            self.delivered.append(sig)

        monkeypatch.setattr(os, "kill", kill("kill"))
        monkeypatch.setattr(os, "killpg", kill("killpg"))
        monkeypatch.setattr(signal, "pidfd_send_signal", pidfd_send)


def test_N1_close_after_a_worker_died_and_was_reaped_signals_nothing(monkeypatch):
    """N1: a worker dies while idle and is reaped (``multiprocessing`` reaps finished children
    whenever another process starts); ``close()`` then once sent SIGKILL to its bare number
    (``os.killpg``). Now it signals nothing: no signal by number, and every pidfd signal finds
    no process."""
    import multiprocessing

    from vpid_bench.workers import Workers

    pool = Workers(1)
    try:
        pool.prestart(1)
        (worker,) = pool._all
        worker.process.kill()  # the test's own signal, before the watch below
        worker.process.join(timeout=60)
        multiprocessing.active_children()  # reaped, as Process.start() reaps
        assert worker.process.exitcode == -signal.SIGKILL
        sent = _Signals(monkeypatch)
        pool.close()
    finally:
        monkeypatch.undo()
        pool.close()
    assert sent.by_number == [] and sent.delivered == []


REUSE = """\
import json, multiprocessing, os, signal, subprocess, sys, time
from vpid_bench.workers import Workers

pool = Workers(1)
pool.prestart(1)
(worker,) = pool._all
pid = worker.process.pid
worker.process.kill()
worker.process.join(timeout=60)
multiprocessing.active_children()  # reaped while idle
with open("/proc/sys/kernel/ns_last_pid", "w") as f:
    f.write(str(pid - 1))
# a group leader with a child of its own
foreign = subprocess.Popen(["sh", "-c", "sleep 60 & wait"], start_new_session=True)
if foreign.pid != pid:
    foreign.kill()
    print(json.dumps({"reused": False, "pid": pid, "foreign": foreign.pid}))
    sys.exit(0)
import psutil
end = time.monotonic() + 30
while not psutil.Process(pid).children() and time.monotonic() < end:
    time.sleep(0.01)
(child,) = psutil.Process(pid).children()
pool.close()
time.sleep(0.3)
alive = foreign.poll() is None and child.status() not in ("zombie", "stopped")
foreign.kill()  # first: with its child killed first, its `wait` returns and it exits 0
code = foreign.wait()
child.kill()
print(json.dumps({"reused": True, "alive": alive, "code": code}))
"""


def test_N1_a_reused_process_id_is_never_signalled(tmp_path):
    """N1, with a forced reuse: in a PID namespace of its own (``unshare``, as root), a worker
    dies and is reaped, the kernel is told to hand its number to the next process
    (``ns_last_pid``), a foreign shell leading its own group, with a child, gets it;
    ``close()`` once SIGKILLed that group; the shell and its child live on, not stopped."""
    unshare = shutil.which("unshare")
    if unshare is None or sys.platform != "linux":
        pytest.skip("needs Linux's unshare to force a PID reuse")
    for how in ([], ["--user", "--map-root-user"]):  # as root; else in a user namespace
        command = [unshare, *how, "--pid", "--fork", "--mount-proc"]
        probe = subprocess.run([*command, "true"], capture_output=True, text=True,
                               check=False)
        if probe.returncode == 0:
            break
    else:
        pytest.skip(f"cannot make a PID namespace here ({probe.stderr.strip()}): a forced "
                    "PID reuse needs one (root, or unprivileged user namespaces)")
    (tmp_path / "reuse.py").write_text(REUSE)
    done = subprocess.run([*command, sys.executable, str(tmp_path / "reuse.py")],
                          cwd=tmp_path, env=cli_env(), capture_output=True, text=True,
                          timeout=300, check=False)
    if done.returncode != 0 and "ns_last_pid" in done.stderr:
        pytest.skip(f"the kernel refuses to set the next PID here: {done.stderr[-300:]}")
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    if not result["reused"]:
        pytest.skip(f"the kernel did not hand the number out again ({result})")
    assert result["alive"], "close() killed the process that got the worker's old number"
    assert result["code"] == -signal.SIGKILL  # ended by this test's own kill above


# ---- N2: SIGTERM and SIGHUP end the command as SIGINT does ----


@pytest.fixture(scope="module")
def interrupted(site, tmp_path_factory):
    """The same sweep (random's job, then one whose worker sleeps in ask() with a child of
    its own) interrupted by SIGINT and by SIGTERM once the sleeping worker noted its child:
    the two commands run at once. Signal name -> (folder, pids folder, status, stderr)."""
    runs = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        cwd = tmp_path_factory.mktemp(sig.name.lower())
        pids = cwd.parent / f"{cwd.name}-pids"
        proc = subprocess.Popen([*CLI, "-m", "optimizer=random,sleeper", "runs=1", "workers=1",
                                 *BASE], cwd=cwd, env=_env(site, pids),
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        runs[sig] = (cwd, pids, proc)
    out = {}
    for sig, (_, pids, proc) in runs.items():
        end = time.monotonic() + 240
        while not list(pids.glob("child-*")) and proc.poll() is None:
            assert time.monotonic() < end, "the sleeping worker never started"
            time.sleep(0.05)
        proc.send_signal(sig)
    for sig, (cwd, pids, proc) in runs.items():
        _, err = proc.communicate(timeout=240)
        out[sig.name] = (cwd, pids, proc.returncode, err)
    return out


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_N2_sigterm_ends_the_command_as_sigint_does(interrupted, name):
    """N2: SIGTERM once ended the command with 143 and nothing printed, its workers and their
    processes left running. SIGTERM now ends it as SIGINT does: the same ``interrupted:``
    line, status 128 + the signal, the same records (random's run, completed; the sleeper's
    was running) and no process left. (SIGHUP takes the same handler: the test below.)"""
    cwd, pids, code, err = interrupted[name]
    assert code == 128 + signal.Signals[name], err[-3000:]
    assert "Traceback" not in err, err[-3000:]
    last = err.strip().splitlines()[-1]
    assert last == interrupted["SIGINT"][3].strip().splitlines()[-1]
    assert last.startswith("interrupted: every completed run is recorded")
    records = _records(cwd)
    assert records == _records(interrupted["SIGINT"][0])
    assert list(records.values()) == ["ok"] and "optimizer=random," in next(iter(records))
    assert {p.name.split("-")[0] for p in pids.iterdir()} == {"child", "worker"}
    assert left_running(pids) == []


def test_N2_sighup_and_sigterm_take_the_handler_of_sigint(monkeypatch):
    """N2, in this process: the command's handler takes SIGTERM and SIGHUP as it takes SIGINT
    (a ``KeyboardInterrupt``: every completed run kept, the workers ended), and the status is
    128 + the first signal seen."""
    from vpid_bench import interrupts

    monkeypatch.setattr(interrupts._Watch, "installed", False)
    monkeypatch.setattr(interrupts._Watch, "signalled", False)
    monkeypatch.setattr(interrupts._Watch, "signum", int(signal.SIGINT))
    saved = {sig: signal.getsignal(sig) for sig in interrupts.SIGNALS}
    try:
        interrupts.install()
        assert {signal.getsignal(sig) for sig in interrupts.SIGNALS} == {interrupts._handler}
        assert interrupts.exit_status() == 130  # none seen: a program's own interrupt
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1)
        interrupts.note(signal.SIGHUP)  # a second one does not change it
        assert interrupts.seen() and interrupts.exit_status() == 143
    finally:
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def test_N2_a_worker_leaves_sigterm_to_the_command_and_its_children_get_the_default():
    """N2: a batch system's SIGTERM to every process of a job once ended the workers before
    the command, and their runs were recorded as failed by the signal. A worker now takes
    SIGTERM and SIGHUP with a handler that does nothing (the command ends it), also while it
    starts (they are held until then: starting multiprocessing's resource tracker once
    released them for the first worker), and a process it forks has their default again (a
    plugin's pool still ends its children with SIGTERM)."""
    from round5_plugins import Sleeper, fork_dispositions

    from vpid_bench.workers import Workers

    pool = Workers(1)
    try:
        pool.prestart(1)  # signalled while it starts (held until its handlers are set)
        (worker,) = pool._all
        for sig in (signal.SIGTERM, signal.SIGHUP):
            signal.pidfd_send_signal(worker.tree.fd, sig)
        in_worker, in_child = pool.call(_job(Sleeper), fork_dispositions, what="a fork",
                                        limit=None)
        assert pool._all == [worker] and not worker.ended(), "SIGTERM or SIGHUP ended it"
        assert not in_worker and in_child
    finally:
        pool.close()


# ---- N3: a daemon whose worker exits ----


def test_N3_a_daemon_whose_worker_exits_neither_holds_tail_nor_outlives_the_sweep(site,
                                                                                 tmp_path):
    """N3: ask() starts a daemon (double fork, ``setsid``) and ends its worker. The daemon
    kept multiprocessing's resource-tracker pipe, the tracker kept the command's stdout, and
    ``vpid-bench ... | tail`` waited for the daemon (40 s); the daemon, gone to init, outlived
    the sweep. Now the pipeline ends with the command, the run fails with how its worker
    ended, and the daemon is ended with its worker."""
    pids = tmp_path.parent / f"{tmp_path.name}-pids"
    command = shlex.join([*CLI, "-m", "optimizer=daemonexit", "runs=1", *BASE])
    done = subprocess.run(["bash", "-c", f"{command} 2>&1 | tail -n 30; exit "
                           "${PIPESTATUS[0]}"], cwd=tmp_path, env=_env(site, pids),
                          capture_output=True, text=True, timeout=300, check=False)
    ended = time.time()
    daemons = [float(p.read_text()) for p in pids.glob("daemon-*")]
    assert daemons, done.stdout[-3000:]
    assert ended - min(daemons) < CHILD_S, "the pipe to tail waited for the daemon"
    assert done.returncode == 1, done.stdout[-3000:]
    assert list(_records(tmp_path).values()) == ["failed"]
    (record,) = (tmp_path / "sweep").glob("*/records/run-*.json")
    assert "its worker process ended (exit code 3)" in json.loads(
        record.read_text())["error"]["message"]
    assert left_running(pids) == []


def _job(optimizer: type, runs: int = 1):
    from process_plugins import Crashy

    from vpid_bench.spec import Job, JobSpec

    config = Crashy.Config(ps=4, iterations=2)
    params = optimizer.Params(ps=4, iterations=2, budget=12)
    return Job(JobSpec(runs=runs, progress=False, report=False, isolation="process"),
               "crashy", Crashy, config, optimizer.__name__.lower(), optimizer, params, 12)


@pytest.mark.parametrize("way", WAYS)
def test_N3_the_daemon_is_found_both_ways(way, tmp_path, monkeypatch):
    """N3, in this process: the daemon of a worker that exited is ended with its worker by
    its cgroup, and by its mark where no cgroup is made."""
    from round5_plugins import DaemonExit

    from vpid_bench.experiment import run_job
    from vpid_bench.workers import Workers

    pids = tmp_path / "pids"
    pids.mkdir()
    monkeypatch.setenv(PIDS_ENV, str(pids))
    for key, value in _ways_env(way).items():
        monkeypatch.setenv(key, value)
    pool = Workers(1)
    try:
        summary = run_job(_job(DaemonExit), tmp_path / "job", pool=pool)
    finally:
        pool.close()
    assert summary.failed == [0]
    assert list(pids.glob("daemon-*"))
    assert left_running(pids, grace=2.0) == []


# ---- N4: a process that keeps forking and calling setsid ----


def _still_forking(beat: Path, wait: float = 1.0) -> bool:
    """Whether the chain writing ``beat`` still runs: its generation changes within ``wait``
    seconds (no listing of processes catches its one living process, which changes every few
    milliseconds)."""
    before = beat.read_bytes() if beat.exists() else b""
    time.sleep(wait)
    return beat.exists() and beat.read_bytes() != before


@pytest.mark.parametrize("way", WAYS)
def test_N4_a_process_that_keeps_forking_and_calling_setsid_is_ended(way, tmp_path,
                                                                      monkeypatch):
    """N4: a plugin process forks again and again, each copy in a session of its own and its
    parent gone at once, while its worker lives; the tree kill listed the worker's
    descendants and killed them, and the newest copy, born in between, escaped (2 processes
    left). Its cgroup ends it whole; without one, its mark finds each copy, stopped round
    after round until none is new, then killed: none is left."""
    from round5_plugins import CHAIN_ENV, Chain

    from vpid_bench.experiment import run_job
    from vpid_bench.workers import Workers

    beat = tmp_path / "beat"
    monkeypatch.setenv(CHAIN_ENV, str(beat))
    for key, value in _ways_env(way).items():
        monkeypatch.setenv(key, value)
    pool = Workers(1)
    try:
        summary = run_job(_job(Chain, runs=2), tmp_path / "job", pool=pool)
    finally:
        pool.close()
    assert summary.ran == 2 and not summary.failed
    assert beat.exists(), "the chain never started"
    assert not _still_forking(beat)


def test_N4_what_cannot_be_ended_is_named_in_one_warning_line(tmp_path, monkeypatch, capsys):
    """N4, the least: a process of a worker's tree that cannot be ended (here: one the tree
    kill is made unable to signal) is named, with its number and name, in one ``warning:``
    line when its worker is ended."""
    from vpid_bench import worker_tree
    from vpid_bench.workers import Workers

    pool = Workers(1)
    pool.prestart(1)
    (worker,) = pool._all
    sleeper = subprocess.Popen(["sleep", "60"], env={**os.environ,
                                                      worker_tree.MARK: worker.tree.token})
    real = worker_tree._Held.signal
    monkeypatch.setattr(worker_tree, "WAIT_S", 1.0)  # how long it waits for the unkillable
    monkeypatch.setattr(worker_tree._Held, "signal", lambda self, sig: None if
                        self.pid == sleeper.pid else real(self, sig))
    try:
        pool.close()
    finally:
        sleeper.kill()
        sleeper.wait()
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(lines) == 1, lines
    assert f"pid {sleeper.pid} (sleep)" in lines[0] and "left running" in lines[0]


# ---- Also: the contract test runs a third party's optimizer in a subprocess ----


EXITING = """\
import os

import numpy as np

from vpid_bench import Optimizer, OptimizerParams, hookimpl


class Exiting(Optimizer):
    Params = OptimizerParams

    def ask(self):
        os._exit(7)

    def tell(self, X, f):
        pass


@hookimpl
def vpid_bench_register_optimizers(register):
    register("osexit", Exiting)
"""


def test_also_the_contract_test_survives_a_third_party_optimizer_that_calls_os_exit(tmp_path):
    """Also: the contract test ran every installed optimizer in the pytest process, and an
    installed plugin whose ask() calls ``os._exit`` ended ``make test`` with its exit code and
    no message. A third party's optimizer now runs in a subprocess there: its test fails,
    named, with how its process ended, and pytest reports it."""
    site = _site(tmp_path / "site", "osexit", "vpid_osexit_plugin")
    (site / "vpid_osexit_plugin.py").write_text(EXITING)
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:randomly", "-p", "no:cacheprovider",
         "-n", "0", "-q", "--no-header", "-k", "test_contract and osexit",
         str(ROOT / "tests" / "optimizers" / "test_optimizer_contract.py")],
        cwd=tmp_path, env=cli_env({"PYTHONPATH": str(site)}), capture_output=True, text=True,
        timeout=300, check=False)
    out = done.stdout + done.stderr
    assert done.returncode == 1, out[-3000:]
    assert "1 failed" in out and "test_contract[osexit]" in out, out[-3000:]
    assert "exit code 7" in out, out[-3000:]


def test_also_the_contract_test_runs_the_projects_own_optimizers_in_process():
    """Also: the project's own optimizers (distribution vpid-bench) stay in the pytest
    process (fast, and their faults show with a traceback); only third parties' go out."""
    sys.path.insert(0, str(ROOT / "tests" / "optimizers"))
    try:
        import test_optimizer_contract as contract
    finally:
        sys.path.remove(str(ROOT / "tests" / "optimizers"))
    from vpid_bench.plugins import Registry

    registry = Registry()
    assert not contract.third_party(registry, "de1") and not contract.third_party(
        registry, "random")
