"""A second run of a finished sweep runs nothing and writes nothing but the report (issue 46):
no job folder, record, ``job.json``, ``.hydra/`` file or ``multirun.yaml`` is touched; a sweep
with one run missing or a job that did not end ``ok`` runs as before."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import pytest
from sweep_helpers import run_cli

SWEEP = ["-m", "optimizer=de1,random", "runs=2", "problem.iterations=5", "progress=false"]


def _state(root: Path) -> dict[str, tuple[int, str]]:
    """Every file below ``root``: (modification time in ns, SHA-256)."""
    return {str(p.relative_to(root)): (p.stat().st_mtime_ns,
                                       hashlib.sha256(p.read_bytes()).hexdigest())
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("finished")
    done = run_cli([*SWEEP, "hydra.sweep.dir=sweep"], root)
    assert done.returncode == 0, done.stderr
    return root / "sweep"


def _plan(argv: list[str]):
    from vpid_bench.plugins import Registry
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.callbacks import ensure_job_dir_resolver
    from vpid_bench.shell.config_store import register_configs
    from vpid_bench.shell.preflight import plan

    registry = Registry()
    register_configs(registry)
    ensure_job_dir_resolver()
    return plan(parse_command_line(argv), registry), registry


def test_a_second_run_of_a_finished_sweep_writes_nothing_but_the_report(finished):
    before = _state(finished)
    again = run_cli([*SWEEP, f"hydra.sweep.dir={finished}"], finished.parent)
    assert again.returncode == 0, again.stderr
    assert "nothing to run: the 2 job(s)' 4 run(s) are all recorded" in again.stderr
    assert again.stdout.lstrip().startswith("The answer")
    after = _state(finished)
    changed = {k for k in before.keys() | after.keys() if before.get(k) != after.get(k)}
    assert changed and all(k.startswith("report/") for k in changed), sorted(changed)
    assert "multirun.yaml" in after and any(k.endswith("job.json") for k in after)


def test_a_missing_record_or_a_job_not_ok_is_not_nothing_to_run(
        finished, tmp_path, monkeypatch):
    """The check itself, in this process: the finished sweep has nothing to run; a copy with
    one record gone, or one job's status not ``ok``, has (other settings in the same folder
    are another command's, refused before this check)."""
    import shutil

    from vpid_bench.experiment import recorded_in_full

    def nothing_to_run(folder: Path, *more: str) -> bool:
        monkeypatch.chdir(folder.parent)
        p, registry = _plan([*SWEEP, f"hydra.sweep.dir={folder}", *more])
        return recorded_in_full(p.jobs, p.job_dirs, registry, p.problems)

    assert nothing_to_run(finished)
    gone = tmp_path / "gone"
    shutil.copytree(finished, gone)
    next(next(gone.glob("optimizer=random*")).rglob("run-001-*.json")).unlink()
    assert not nothing_to_run(gone)
    failed = tmp_path / "failed"
    shutil.copytree(finished, failed)
    status = next(failed.glob("optimizer=de1*")) / "job.json"
    status.write_text(json.dumps({**json.loads(status.read_text()), "status": "failed_runs"}))
    assert not nothing_to_run(failed)
