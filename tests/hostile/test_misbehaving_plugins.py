"""Optimizer plugins that misbehave outside ask/tell, installed from outside the repository as
a third party's would be: a close() or a constructor that sleeps past run_timeout_s, an
os.chdir() in ask, a non-daemon thread left running, an exception in the plugin's own thread.
Each costs its own run or job at most; the sweep finishes, writes where it was told, and
the command ends."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from extras import limit

BIN = Path(sys.executable).parent

PYPROJECT = """\
[build-system]
requires = ["setuptools>=68"]
build-backend = "setuptools.build_meta"

[project]
name = "naughty-optimizers"
version = "0.1"

[project.entry-points.vpid_bench]
naughty = "naughty_optimizers"
"""

MODULE = '''\
import os
import threading
import time

import numpy as np

from vpid_bench import Optimizer, OptimizerParams, hookimpl


class Base(Optimizer):
    Params = OptimizerParams

    def ask(self):
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X, f):
        pass


class SlowClose(Base):
    def close(self):
        time.sleep(30)


class SlowBuild(Base):
    def __init__(self, *args, **kwargs):
        time.sleep(30)
        super().__init__(*args, **kwargs)


class Wanderer(Base):
    def ask(self):
        os.makedirs(os.environ["NAUGHTY_ELSEWHERE"], exist_ok=True)
        os.chdir(os.environ["NAUGHTY_ELSEWHERE"])
        return super().ask()


class Lingerer(Base):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        threading.Thread(target=time.sleep, args=(3600,), name="lingerer").start()


class Thrower(Base):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)

        def boom():
            raise ValueError("from the plugin's own thread")

        t = threading.Thread(target=boom, name="thrower", daemon=True)
        t.start()
        t.join()


class Interrupter(Base):
    def tell(self, X, f):
        raise KeyboardInterrupt


class Swapper(Base):
    def tell(self, X, f):
        import glob
        import shutil

        for job in glob.glob("sweep/optimizer=swapper*"):
            records = os.path.join(job, "records")
            if not os.path.islink(records):
                if os.path.exists(records):
                    shutil.move(records, records + "-moved")
                os.makedirs(os.environ["NAUGHTY_ELSEWHERE"], exist_ok=True)
                os.symlink(os.environ["NAUGHTY_ELSEWHERE"], records)


class Exiter(Base):
    def ask(self):
        os._exit(3)


class Aborter(Base):
    def ask(self):
        import resource

        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # no core file in the test folder
        os.abort()


class Crasher(Base):
    def ask(self):
        import ctypes

        ctypes.string_at(0)  # reads address 0: SIGSEGV


class Deaf(Base):
    def ask(self):
        import signal

        signal.signal(signal.SIGALRM, signal.SIG_IGN)  # defeats the in-process limit
        time.sleep(30)
        return super().ask()


class DeafBuild(Base):
    def __init__(self, *args, **kwargs):
        import signal

        signal.signal(signal.SIGALRM, signal.SIG_IGN)
        time.sleep(60)
        super().__init__(*args, **kwargs)


class Renamer(Base):
    def tell(self, X, f):
        if os.path.isdir("sweep") and not os.path.exists("sweep-moved"):
            os.rename("sweep", "sweep-moved")


@hookimpl
def vpid_bench_register_optimizers(register):
    for cls in (SlowClose, SlowBuild, Wanderer, Lingerer, Thrower, Interrupter, Swapper, Exiter,
                Aborter, Crasher, Deaf, DeafBuild, Renamer):
        register(cls.__name__.lower(), cls)
'''


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    src = tmp_path_factory.mktemp("src")
    (src / "pyproject.toml").write_text(PYPROJECT)
    (src / "naughty_optimizers.py").write_text(textwrap.dedent(MODULE))
    target = tmp_path_factory.mktemp("site")
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps",
                    "--no-build-isolation", "--target", str(target), str(src)],
                   check=True, capture_output=True, text=True)
    return target


def _sweep(site: Path, cwd: Path, optimizer: str, *extra: str, timeout: float = 90):
    env = {**os.environ, "PYTHONPATH": str(site), "MPLBACKEND": "Agg",
           "NAUGHTY_ELSEWHERE": str(cwd / "elsewhere")}
    env.pop("VPID_BENCH_DEBUG", None)
    return subprocess.run([str(BIN / "vpid-bench"), "-m", f"optimizer={optimizer},random",
                           "problem=functions",  # the optimizer misbehaves: any problem will do
                           "runs=2", "problem.iterations=2", "progress=false", "report=false",
                           "hydra.sweep.dir=sweep", *extra], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=limit(timeout))


def _records(cwd: Path, optimizer: str) -> list[Path]:
    return sorted((cwd / "sweep").glob(f"optimizer={optimizer},*/records/run-*.json"))


@pytest.mark.parametrize("optimizer", ["slowclose", "slowbuild"])
def test_sleeping_outside_ask_and_tell_is_bounded_by_the_run_limit(site, tmp_path, optimizer):
    """A 30 s sleep in close() or the constructor, run_timeout_s=2: the command ends well
    before the sleeps would add up, random's runs are recorded, the culprit's job fails."""
    import time

    t0 = time.monotonic()
    out = _sweep(site, tmp_path, optimizer, "run_timeout_s=2")
    assert time.monotonic() - t0 < 25  # one 30 s sleep alone would exceed it
    assert out.returncode == 1, out.stderr[-2000:]
    assert len(_records(tmp_path, "random")) == 2
    assert "run_timeout_s=2" in out.stderr or "longer than" in out.stderr


def test_a_plugin_that_changes_folder_does_not_move_the_sweep(site, tmp_path):
    out = _sweep(site, tmp_path, "wanderer")
    assert out.returncode == 0, out.stderr[-2000:]
    assert len(_records(tmp_path, "wanderer")) == 2 and len(_records(tmp_path, "random")) == 2
    assert not list((tmp_path / "elsewhere").rglob("*.json"))


@pytest.mark.parametrize("isolation", ["process", "none"])
def test_a_thread_left_running_does_not_keep_the_command_alive(site, tmp_path, isolation):
    """In a worker process the thread ends with its worker; in the command's own process
    (isolation=none) the exit watchdog names it and ends the command grace_s after the end."""
    out = _sweep(site, tmp_path, "lingerer", f"isolation={isolation}", "grace_s=2", timeout=90)
    assert out.returncode == 0, out.stderr[-2000:]
    said = [ln for ln in out.stderr.splitlines() if ln.startswith("warning: thread(s)")]
    assert bool(said) == (isolation == "none"), out.stderr[-2000:]
    assert all("lingerer" in ln and "still run 2 s after the end" in ln for ln in said)
    assert len(_records(tmp_path, "lingerer")) == 2


def test_an_exception_in_a_plugins_thread_is_one_line(site, tmp_path):
    out = _sweep(site, tmp_path, "thrower")
    assert out.returncode == 0, out.stderr[-2000:]
    assert "Traceback" not in out.stderr
    lines = [ln for ln in out.stderr.splitlines() if "thread thrower raised ValueError" in ln]
    # one line per construction (the job's up-front check, a warm-up in each of the two worker
    # processes, each run), no traceback
    assert 1 <= len(lines) <= 5


def test_a_keyboardinterrupt_raised_by_a_plugin_fails_its_runs_not_the_sweep(site, tmp_path):
    """Not the user's Ctrl-C (no SIGINT): the interrupter's runs fail with the reason, random
    runs after it, exit 1 (not 130), and a resume does not stop again."""
    import json

    out = _sweep(site, tmp_path, "interrupter")
    assert out.returncode == 1, out.stderr[-2000:]
    assert "interrupted: every completed run is recorded" not in out.stderr
    assert len(_records(tmp_path, "random")) == 2
    failed = [json.loads(p.read_text()) for p in _records(tmp_path, "interrupter")]
    assert len(failed) == 2 and all(r["status"] == "failed" for r in failed)
    assert all("not the user's Ctrl-C" in r["error"]["message"] for r in failed)


def test_records_are_not_written_through_a_folder_swapped_for_a_link(site, tmp_path):
    out = _sweep(site, tmp_path, "swapper")
    assert out.returncode == 1, out.stderr[-2000:]
    assert "became a symbolic link" in out.stderr and "Traceback" not in out.stderr
    assert not list((tmp_path / "elsewhere").glob("*.json"))
    assert len(_records(tmp_path, "random")) == 2


#: Optimizers that end their process in ask(), and how the record says it ended.
ENDERS = [("exiter", "exit code 3"), ("aborter", "signal SIGABRT"), ("crasher", "signal SIGSEGV")]


@pytest.fixture(scope="module")
def ended_sweep(site, tmp_path_factory):
    """One sweep of the three (then random) and its resume, shared by their tests: each
    command costs seconds, and one after the other they also show that a fresh worker takes
    each next job."""
    cwd = tmp_path_factory.mktemp("enders")
    names = ",".join(name for name, _ in ENDERS)
    return cwd, _sweep(site, cwd, names), _sweep(site, cwd, names, "--resume")


@pytest.mark.parametrize(("optimizer", "ended"), ENDERS)
def test_a_plugin_that_ends_its_process_costs_its_runs_only(ended_sweep, optimizer, ended):
    """os._exit, os.abort, a segfault in ask(): in a worker process (isolation=process, the
    command's default) each ends its worker, not the sweep: its runs are recorded as failed
    with how the process ended, random runs after it, and a resume does not crash again."""
    import json

    cwd, out, again = ended_sweep
    assert out.returncode == 1, out.stderr[-2000:]
    assert len(_records(cwd, "random")) == 2
    failed = [json.loads(p.read_text()) for p in _records(cwd, optimizer)]
    assert len(failed) == 2 and all(r["status"] == "failed" for r in failed)
    assert all(ended in r["error"]["message"] for r in failed), failed[0]["error"]
    assert again.returncode == 1 and "sweep:" in again.stderr, again.stderr[-2000:]


def test_a_run_deaf_to_the_alarm_is_killed_with_its_worker(site, tmp_path):
    """SIGALRM ignored, then a 30 s sleep: the in-process limit cannot stop it; the
    supervisor kills the worker grace_s after run_timeout_s and records a timeout (grace_s=2
    here; the default's 10 s: the constructor's test below)."""
    import json
    import time

    t0 = time.monotonic()
    out = _sweep(site, tmp_path, "deaf", "run_timeout_s=1", "grace_s=2", timeout=120)
    assert time.monotonic() - t0 < 2 * (30 + 5)  # two unkilled sleeps would take 60 s
    assert out.returncode == 1, out.stderr[-2000:]
    assert len(_records(tmp_path, "random")) == 2
    failed = [json.loads(p.read_text()) for p in _records(tmp_path, "deaf")]
    assert [r["error"]["type"] for r in failed] == ["WorkerKilledError"] * 2
    assert "within grace_s=2 s more" in failed[0]["error"]["message"]


def test_a_constructor_deaf_to_the_alarm_fails_its_job_at_the_limit(site, tmp_path):
    """A constructor that ignores SIGALRM and sleeps 60 s: the job's up-front build, in a
    worker, is killed grace_s (here 2 s; its default: test_hostile_isolation) after
    run_timeout_s; every run of the job is recorded as failed with that reason at once
    (issue 35, failure 18: the job once failed whole, no record), random runs."""
    import json
    import time

    t0 = time.monotonic()
    out = _sweep(site, tmp_path, "deafbuild", "run_timeout_s=1", "grace_s=2", timeout=120)
    assert time.monotonic() - t0 < 50  # the sleep alone would take 60 s
    assert out.returncode == 1, out.stderr[-2000:]
    assert len(_records(tmp_path, "random")) == 2
    assert "constructor did not return within 3 s" in out.stderr, out.stderr[-2000:]
    failed = [json.loads(p.read_text()) for p in _records(tmp_path, "deafbuild")]
    assert [r["error"]["type"] for r in failed] == ["WorkerKilledError"] * 2


def test_a_sweep_folder_renamed_mid_sweep_is_said_not_split(site, tmp_path):
    """The sweep folder renamed while the sweep runs: the next job is not run into a
    re-created, unlocked folder of the old name; it fails in one line naming what happened."""
    out = _sweep(site, tmp_path, "renamer")
    assert out.returncode == 1, out.stderr[-2000:]
    assert "Traceback" not in out.stderr
    assert "was moved, renamed or removed while the command ran" in out.stderr
    assert not list((tmp_path / "sweep").rglob("run-*.json"))  # nothing re-created there
