"""Issue 13, cases 6-8: one job that cannot be set up, a plugin that raises SystemExit or
never returns, a registration hook that raises: each is contained, the sweep goes on and ends
with its summary."""

from __future__ import annotations

import errno
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from hostile_helpers import TINY, error_lines, main_in_process, plan_of, read_only, run_cli

from vpid_bench import Optimizer, OptimizerParams, hookimpl
from vpid_bench.experiment import run_from_config
from vpid_bench.plugins import Registry
from vpid_bench.store import records as rec

SWEEP = ["-m", "problem=functions", "optimizer=random,de1,de4", "runs=2",
         "problem.iterations=2", "progress=false", "report=false"]


def _job_dirs(sweep: Path) -> list[Path]:
    return plan_of([*SWEEP, f"hydra.sweep.dir={sweep}"]).job_dirs


def test_the_planned_job_folders_are_the_ones_hydra_uses(tmp_path):
    sweep = tmp_path / "sweep"
    done = run_cli([*SWEEP, f"hydra.sweep.dir={sweep}"], tmp_path)
    assert done.returncode == 0, done.stderr
    made = sorted(p.parent for p in sweep.rglob("job.json"))
    assert made == sorted(_job_dirs(sweep))


def test_a_read_only_job_folder_fails_that_job_only(tmp_path):
    """Case 6: the second of three jobs cannot write its folder (read-only); the first and
    third run, the summary names the second, exit 1, no traceback."""
    sweep = tmp_path / "sweep"
    dirs = _job_dirs(sweep)
    with read_only(dirs[1]):
        done = run_cli([*SWEEP, f"hydra.sweep.dir={sweep}"], tmp_path)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr and "Unable to configure" not in done.stderr
    assert len(list(dirs[0].glob("records/run-*.json"))) == 2
    assert len(list(dirs[2].glob("records/run-*.json"))) == 2
    assert not list(dirs[1].iterdir())
    assert "sweep: 3 job(s), 2 ok, 1 not ok" in done.stderr
    assert f"  error: {dirs[1]}: job.json not written" in done.stderr


def test_a_full_disk_in_one_job_fails_that_job_only(tmp_path, monkeypatch, capsys):
    """Case 6: every write below one job folder fails with ENOSPC (a disk that fills up while
    that job runs); the sweep goes on to the next job and ends with its summary."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("VPID_BENCH_DEBUG", raising=False)
    sweep = tmp_path / "sweep"
    full = _job_dirs(sweep)[1]
    real = tempfile.mkstemp

    def mkstemp(*args, **kwargs):
        if str(kwargs.get("dir", "")).startswith(str(full)):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(*args, **kwargs)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    code, err = main_in_process([*SWEEP, f"hydra.sweep.dir={sweep}"], capsys)
    assert code == 1
    assert "sweep: 3 job(s), 2 ok, 1 not ok" in err
    assert f"  error: {full}: job.json not written" in err
    assert f"error: cannot write the status of {full} (No space left on device)" in err
    assert sum(1 for _ in sweep.rglob("records/run-*.json")) == 4
    assert not list(full.rglob("*.tmp"))  # nothing torn left behind


def test_a_full_disk_leaves_reference_csv_whole(tmp_path, monkeypatch, registry):
    """Case 6: reference.csv is written atomically: a failed rewrite keeps the old file."""
    from vpid_bench.build import build_problem

    problem = build_problem(registry, {"name": "vehicle"})
    problem.write_artifacts(tmp_path)
    path = tmp_path / "reference.csv"
    before = path.read_bytes()

    def no_space(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", no_space)
    with pytest.raises(OSError):
        problem.write_artifacts(tmp_path)
    monkeypatch.undo()
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["reference.csv"]


# ---- plugins that misbehave ----


@pytest.fixture(autouse=True)
def _no_debug(monkeypatch):
    monkeypatch.delenv("VPID_BENCH_DEBUG", raising=False)


class _Exiting(Optimizer):
    """Raises SystemExit(3) from ask() in run 1 (case 7) or sleeps forever (case 8)."""

    Params = OptimizerParams
    mode = "exit"

    def ask(self) -> np.ndarray:
        run = int(self.rng.bit_generator.seed_seq.spawn_key[0])
        if self.mode == "exit" and run == 1:
            raise SystemExit(3)
        if self.mode == "hang":
            while True:
                time.sleep(0.01)
        return self.bounds.sample(self.rng, self.params.ps)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


class _Hanging(_Exiting):
    mode = "hang"


class _Plugin:
    @hookimpl
    def vpid_bench_register_optimizers(self, register):
        register("exiting", _Exiting)
        register("hanging", _Hanging)


@pytest.fixture(scope="module")
def bad_registry(registry_of) -> Registry:
    import vpid_functions.plugin as functions

    return registry_of(("functions", functions), ("bad", _Plugin()))


def _config(name: str, **spec) -> dict:
    return {"problem": {"name": "functions", "ps": 4, "iterations": 2, "dim": 2},
            "optimizer": {"name": name}, "seed": 0, "runs": 3, "progress": False, **spec}


def test_system_exit_in_a_plugin_is_a_failed_run(bad_registry, tmp_path):
    """Case 7: SystemExit(3) in ask() fails run 1 (recorded), runs 0 and 2 are ok."""
    summary = run_from_config(_config("exiting"), tmp_path, bad_registry)
    assert summary.failed == [1] and summary.ran == 3
    records = [rec.read_record(p) for p in summary.record_paths]
    assert [r["status"] for r in records] == ["ok", "failed", "ok"]
    assert records[1]["error"]["type"] == "SystemExit"


def test_a_plugin_that_never_returns_is_stopped_by_run_timeout_s(bad_registry, tmp_path):
    """Case 8: every run of a hanging optimizer is stopped after run_timeout_s and recorded
    as failed; the job ends in bounded time."""
    t0 = time.monotonic()
    summary = run_from_config(_config("hanging", run_timeout_s=0.3, runs=2), tmp_path,
                              bad_registry)
    elapsed = time.monotonic() - t0
    assert summary.failed == [0, 1]
    records = [rec.read_record(p) for p in summary.record_paths]
    assert {r["error"]["type"] for r in records} == {"RunTimeoutError"}
    assert "run_timeout_s=0.3" in records[0]["error"]["message"]
    assert 0.6 <= elapsed < 30  # two runs of 0.3 s (plus a bounded warm-up), never forever


def test_run_timeout_s_is_off_by_default_and_checked():
    from vpid_bench.api import ConfigError
    from vpid_bench.spec import JobSpec

    assert JobSpec().run_timeout_s is None
    for bad in (0.0, -1.0, float("inf")):
        with pytest.raises(ConfigError, match="run_timeout_s"):
            JobSpec(run_timeout_s=bad)


def test_grace_s_is_ten_seconds_by_default_and_checked(tmp_path):
    """grace_s: how long past a limit a worker that has not answered is given before it is
    killed; 0, a negative, NaN or more than an hour is one error line naming the key."""
    from vpid_bench.api import ConfigError
    from vpid_bench.spec import JobSpec

    assert JobSpec().grace_s == 10.0
    for bad in (0.0, -1.0, float("nan"), 3601.0):
        with pytest.raises(ConfigError, match="grace_s"):
            JobSpec(grace_s=bad)
    done = run_cli([*TINY, "grace_s=0"], tmp_path)
    assert done.returncode == 2
    assert done.stderr.splitlines() == [
        "error: grace_s=0.0 is not allowed: a positive number of seconds up to 3600"]


def test_system_exit_while_a_job_sets_up_fails_that_job_only(tmp_path, monkeypatch, capsys):
    """Case 7: SystemExit raised while a job builds its problem (a plugin's constructor):
    that job fails with one line, the next job runs, the command exits 1. In this process
    (isolation=none): the patch below does not reach a worker process, where the problem is
    built by default (the fault matrix plants the same fault there: place "build")."""
    import vpid_functions.plugin as functions

    monkeypatch.chdir(tmp_path)
    real = functions.FunctionsProblem.__init__

    def init(self, config):
        if config.dim == 3:
            raise SystemExit(3)
        real(self, config)

    monkeypatch.setattr(functions.FunctionsProblem, "__init__", init)
    code, err = main_in_process(["-m", *TINY, "problem.dim=3,4", "isolation=none",
                                 "hydra.sweep.dir=s"], capsys)
    assert code == 1
    assert "sweep: 2 job(s), 1 ok, 1 not ok" in err
    assert [line for line in error_lines(err) if "SystemExit" in line]


HOOK_RAISES = """
from vpid_bench import hookimpl

@hookimpl
def vpid_bench_register_optimizers(register):
    raise RuntimeError("hook exploded")
"""


def _fake_distribution(site: Path, name: str, entry: str, module: str, text: str) -> None:
    info = site / f"{name}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[vpid_bench]\n{entry} = {module}\n")
    (site / f"{module}.py").write_text(text)


def test_a_raising_registration_hook_is_skipped_with_one_warning(tmp_path):
    """Case 7: the plugin is skipped with a warning (printed once); --help and jobs work.
    Case 17: a plugin import warning prints once."""
    site = tmp_path / "site"
    _fake_distribution(site, "vpid_hookbad", "hookbad", "vpid_hookbad_mod", HOOK_RAISES)
    _fake_distribution(site, "vpid_broken", "broken", "vpid_broken_mod",
                       "raise ImportError('needs libfoo')\n")
    env = {"PYTHONPATH": str(site)}
    helped = run_cli(["--help"], tmp_path, env=env)
    assert helped.returncode == 0 and "vpid-bench" in helped.stdout
    done = run_cli(TINY, tmp_path, env=env)
    assert done.returncode == 0, done.stderr
    warnings = [line for line in done.stderr.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 2, done.stderr
    assert sum("'hookbad'" in w and "hook exploded" in w for w in warnings) == 1
    assert sum("'broken'" in w and "needs libfoo" in w for w in warnings) == 1
