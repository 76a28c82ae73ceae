"""Issue 35, failure 12: a record edited by hand to a wrong type while it still says ``ok``
once failed its job on every resume (``error: could not convert string to float``). A
resume now sets the file aside in ``records/bad/`` with one warning line naming the field,
and runs that run again; the job and the sweep go on."""

from __future__ import annotations

import json

import pytest
from hostile_helpers import TINY, run_cli

from vpid_bench.experiment import run_from_config
from vpid_bench.store import records as rec
from vpid_bench.store.record_check import check_record

EDITS = {
    "f_best-text": (lambda d: d["result"].update(f_best="small"), "result.f_best"),
    "run_index-text": (lambda d: d.update(run_index="one"), "run_index"),
    "x_best-mapping": (lambda d: d["result"].update(x_best={"a": 1}), "result.x_best"),
    "metrics-list": (lambda d: d["result"].update(metrics=[1, 2]), "result.metrics"),
    "trace-lengths": (lambda d: d["trace"].update(best=d["trace"]["best"][:-1] or [1.0, 2.0]),
                      "trace.best"),
    "not-json": (None, "not a readable JSON run record"),
}


def _edit(path, how) -> None:
    if how is None:
        path.write_text("{not json")
        return
    data = json.loads(path.read_text())
    how(data)
    path.write_text(json.dumps(data))


@pytest.mark.parametrize("edit", list(EDITS))
def test_12_a_badly_typed_ok_record_is_set_aside_and_run_again(edit, tmp_path, compose_config,
                                                               registry, capsys):
    cfg = compose_config([*TINY, "runs=3"])
    first = run_from_config(cfg, tmp_path / "job", registry)
    path = first.record_paths[1]
    good = rec.fingerprint(rec.read_record(path))
    how, words = EDITS[edit]
    _edit(path, how)
    capsys.readouterr()
    again = run_from_config(cfg, tmp_path / "job", registry)
    assert (again.ran, again.skipped, again.failed) == (1, 2, [])
    assert rec.fingerprint(rec.read_record(path)) == good  # the same run, made again
    (aside,) = (tmp_path / "job" / "records" / "bad").iterdir()
    assert aside.name == path.name
    (line,) = [w for w in capsys.readouterr().err.splitlines() if "set aside" in w]
    assert line.startswith(f"warning: record {path} is not a valid record (") and words in line
    third = run_from_config(cfg, tmp_path / "job", registry)  # and the next resume is quiet
    assert (third.ran, third.skipped) == (0, 3)
    assert "set aside" not in capsys.readouterr().err


def test_12_the_command_resumes_past_it_with_exit_0(tmp_path):
    args = [*TINY, "runs=3", "hydra.run.dir=job"]
    assert run_cli(args, tmp_path).returncode == 0
    path = sorted((tmp_path / "job" / "records").glob("run-001-*.json"))[0]
    _edit(path, EDITS["f_best-text"][0])
    for _ in range(2):  # every later resume too
        done = run_cli(args, tmp_path)
        assert done.returncode == 0, done.stderr
        assert "error:" not in done.stderr and "Traceback" not in done.stderr
    assert len(list((tmp_path / "job" / "records" / "bad").iterdir())) == 1
    assert check_record(rec.read_record(path)) is None
