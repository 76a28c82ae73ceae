"""Issue 35, failure 17: a second sweep into a finished sweep's folder was merged into it
without a word (the terminal said 2 jobs, the report ranked 4 optimizers), and ``--resume``
with nothing to resume started a whole new sweep. Now a folder holding another command's
jobs is refused in one line unless ``--merge`` asks for the merge (then one line says it), a
resume of the same jobs (in any order) or a sweep that adds jobs to them goes on, and
``--resume`` with nothing to resume is one ``error:`` line, exit 2."""

from __future__ import annotations

import shutil

import pytest
from hostile_helpers import error_lines, run_cli

BASE = ["problem=functions", "runs=1", "problem.iterations=2", "progress=false",
        "report=false", "hydra.sweep.dir=S"]


def _jobs(tmp_path) -> set[str]:
    return {p.parent.parent.name.split(",")[0] for p in (tmp_path / "S").glob("*/records/*")}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished sweep folder S (random and centre), made once by the real command."""
    cwd = tmp_path_factory.mktemp("finished")
    first = run_cli(["-m", "optimizer=random,centre", *BASE], cwd)
    assert first.returncode == 0, first.stderr
    return cwd / "S"


@pytest.fixture
def after_first(finished, tmp_path):
    """A copy of the finished sweep folder S in this test's folder, as the command left it."""
    shutil.copytree(finished, tmp_path / "S", symlinks=True)
    return tmp_path


def test_17_a_second_sweep_into_a_sweep_folder_is_refused_without_merge(after_first):
    tmp_path = after_first
    second = run_cli(["-m", "optimizer=de1,ga", *BASE], tmp_path)
    assert second.returncode == 2, second.stderr
    (line,) = second.stderr.splitlines()
    assert line == error_lines(second.stderr)[0]
    assert line.startswith("error: hydra.sweep.dir='S' is not allowed: a folder without "
                           "another command's jobs: it holds 2 job(s) another command ran")
    assert "add --merge" in line
    assert _jobs(tmp_path) == {"optimizer=random", "optimizer=centre"}  # nothing ran


def test_17_merging_is_an_explicit_choice_and_said(after_first):
    tmp_path = after_first
    merged = run_cli(["--merge", "-m", "optimizer=de1", *BASE], tmp_path)
    assert merged.returncode == 0, merged.stderr
    (line,) = [w for w in merged.stderr.splitlines() if w.startswith("merge:")]
    assert line.startswith("merge: S holds 2 job(s) another command ran")
    assert line.endswith("merged, as --merge asks")
    assert _jobs(tmp_path) == {"optimizer=random", "optimizer=centre", "optimizer=de1"}


def test_17_a_resume_or_a_larger_sweep_is_no_merge(after_first):
    tmp_path = after_first
    again = run_cli(["-m", "optimizer=centre,random", *BASE], tmp_path)  # same jobs, reordered
    assert again.returncode == 0, again.stderr
    assert "nothing to run: the 2 job(s)' 2 run(s) are all recorded" in again.stderr
    more = run_cli(["-m", "optimizer=centre,random,de1", *BASE], tmp_path)  # adds a job
    assert more.returncode == 0, more.stderr
    assert "merge:" not in again.stderr + more.stderr
    again = run_cli(["--resume=S", "-m", "optimizer=centre,random,de1", *BASE[:-1]], tmp_path)
    assert again.returncode == 0, again.stderr


def test_17_a_single_run_into_a_sweep_folder_is_refused(after_first):
    tmp_path = after_first
    single = run_cli(["optimizer=centre", *BASE[:-1], "hydra.run.dir=S"], tmp_path)
    assert single.returncode == 2, single.stderr
    assert single.stderr.startswith("error: hydra.run.dir='S' is not allowed: a folder "
                                    "without another command's jobs")


def test_17_resume_with_nothing_to_resume_is_one_error_line(tmp_path):
    done = run_cli(["--resume", "-m", "optimizer=random", *BASE[:-1]], tmp_path)
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        "error: --resume: no earlier sweep under outputs/multirun has these overrides, so "
        "there is nothing to resume; to start a new sweep, run the command without --resume"]
    assert not (tmp_path / "outputs").exists()  # no new sweep was started
