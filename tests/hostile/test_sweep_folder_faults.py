"""The sweep's own folder under attack: something planted in the lock file's place, and a
job folder aimed outside the sweep. Each is one ``error:`` line naming the key, exit 2, and
nothing written outside."""

from __future__ import annotations

import os

import pytest
from hostile_helpers import error_lines, main_in_process

TINY = ["-m", "optimizer=random", "runs=1", "problem.iterations=1", "progress=false",
        "report=false"]


@pytest.mark.parametrize("plant", ["folder", "dangling link", "link to a file"])
def test_a_thing_in_the_locks_place_is_one_line(tmp_path, capsys, monkeypatch, plant):
    monkeypatch.chdir(tmp_path)
    sweep = tmp_path / "sw"
    sweep.mkdir()
    lock = sweep / ".vpid-bench.lock"
    if plant == "folder":
        lock.mkdir()
    elif plant == "dangling link":
        lock.symlink_to(tmp_path / "nowhere")
    else:
        (tmp_path / "target.txt").write_text("keep me")
        lock.symlink_to(tmp_path / "target.txt")
    code, err = main_in_process([*TINY, f"hydra.sweep.dir={sweep}"], capsys)
    lines = error_lines(err)
    assert code == 2 and len(lines) == 1 and "Traceback" not in err
    assert "hydra.sweep.dir" in lines[0] and "lock file" in lines[0]
    assert not list(sweep.glob("optimizer=*"))
    if plant == "link to a file":
        assert (tmp_path / "target.txt").read_text() == "keep me"


@pytest.mark.parametrize("subdir", ["../../escaped_job", "/tmp/vpid_abs_job", "a/../../b"])
def test_a_job_folder_outside_the_sweep_is_refused(tmp_path, capsys, monkeypatch, subdir):
    monkeypatch.chdir(tmp_path)
    code, err = main_in_process([*TINY, "hydra.sweep.dir=sw/inner",
                                 f"hydra.sweep.subdir={subdir}"], capsys)
    lines = error_lines(err)
    assert code == 2 and len(lines) == 1 and "hydra.sweep.subdir" in lines[0]
    assert not os.path.exists("escaped_job") and not os.path.exists("/tmp/vpid_abs_job")
    assert not (tmp_path / "sw").exists() or not list((tmp_path / "sw").rglob("job.json"))
