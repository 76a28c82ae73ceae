"""Issue 44, round five's job-folder failures, each named by its id.

N7.   A job folder's ``vpid_bench.log`` that is a symbolic link to a file outside was
      followed on resume (appended to, or created where it pointed), while every other job
      file is replaced, never followed. The log is now opened through
      :func:`vpid_bench.fileio.open_append`: the link is removed (the link only) with one
      ``warning:`` line and a file of the job's own made in its place.
R4-12 (round four's #12). A record whose ``run_index`` contradicts its file name and whose
      ``evaluations`` is -1 was kept on resume, and the report counted that run twice on one
      instance and never on the other. Such a record is now set aside and run again on
      resume, and skipped with one line by the report.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from hostile_helpers import TINY, main_in_process

from vpid_bench.experiment import run_from_config
from vpid_bench.store import records as rec
from vpid_bench.store.record_check import MAX_NAME_CHARS

JOB = [*TINY, "hydra.run.dir=job"]
LOG = "vpid_bench.log"


def _warned_link(err: str, path: Path) -> None:
    (line,) = [w for w in err.splitlines() if "symbolic link" in w]
    assert line == (f"warning: {path} was a symbolic link; removed (the link only) so that "
                    "nothing is written outside the output folder")


@pytest.mark.parametrize("target", ["existing", "dangling"])
def test_n7_a_log_linked_outside_the_job_folder_is_not_followed_on_resume(target, in_tmp,
                                                                          capsys):
    """The resume (the command, in this process) appends to a log file of its own: the
    file outside is neither written nor created, and the link is gone."""
    code, err = main_in_process(JOB, capsys)
    assert code == 0, err
    log = in_tmp / "job" / LOG
    assert log.is_file() and not log.is_symlink()
    outside = in_tmp / "outside" / "precious.log"
    outside.parent.mkdir()
    if target == "existing":
        outside.write_text("precious\n")
    log.unlink()
    log.symlink_to(outside)
    code, err = main_in_process(JOB, capsys)
    assert code == 0, err
    assert (outside.read_text() == "precious\n") if target == "existing" \
        else not outside.exists()
    assert log.is_file() and not log.is_symlink()
    _warned_link(err, log)


def test_n7_open_append_refuses_a_fifo_at_once_and_replaces_a_link(tmp_path, capsys):
    """The one opener: a FIFO planted as the log is refused without blocking (logging's
    own handler waited for a reader for ever); a link is replaced, the file it points to
    untouched; a real file is appended to."""
    from vpid_bench.fileio import open_append

    fifo = tmp_path / "fifo.log"
    os.mkfifo(fifo)
    with pytest.raises(OSError):
        open_append(fifo)
    outside, link = tmp_path / "outside.log", tmp_path / "job.log"
    outside.write_text("precious\n")
    link.symlink_to(outside)
    with open_append(link) as fh:
        fh.write("mine\n")
    with open_append(link) as fh:
        fh.write("more\n")
    assert outside.read_text() == "precious\n" and link.read_text() == "mine\nmore\n"
    _warned_link(capsys.readouterr().err, link)


def _edit(path: Path, **changes) -> None:
    """Set ``changes`` in the record at ``path`` (``result__evaluations``: a nested key)."""
    data = json.loads(path.read_text())
    for key, value in changes.items():
        node = data
        *parents, leaf = key.split("__")
        for part in parents:
            node = node[part]
        node[leaf] = value
    path.write_text(json.dumps(data))


#: The edits a hand (or a forger) makes to run 1's record, and the words of the line.
EDITS = {
    "index-and-evaluations": ({"run_index": 0, "result__evaluations": -1},
                              "instance.index: expected the run's run_index"),
    "index": ({"run_index": 2, "instance__index": 2},
              "run_index: expected 1, the run index its file name"),
    "evaluations": ({"result__evaluations": -1},
                    "result.evaluations: expected an integer from 0"),
    "instance-index": ({"instance__index": 0}, "instance.index: expected the run's run_index"),
    "long-name": ({"optimizer__name": "x" * 200_000},
                  f"optimizer.name: expected a name of at most {MAX_NAME_CHARS} characters"),
}


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, compose_config, registry) -> Path:
    """A job of 3 runs (its records are copied and edited by each test)."""
    job = tmp_path_factory.mktemp("resume") / "job"
    run_from_config(compose_config([*TINY, "runs=3"]), job, registry)
    return job


@pytest.mark.parametrize("edit", list(EDITS))
def test_r4_12_a_record_contradicting_its_run_is_set_aside_and_run_again(
        edit, tmp_path, compose_config, registry, capsys):
    """Resume: the edited record is moved into records/bad/ with one line naming the field,
    and its run made again, identical to the first."""
    cfg = compose_config([*TINY, "runs=3"])
    first = run_from_config(cfg, tmp_path / "job", registry)
    path = first.record_paths[1]
    good = rec.fingerprint(rec.read_record(path))
    changes, words = EDITS[edit]
    _edit(path, **changes)
    capsys.readouterr()
    again = run_from_config(cfg, tmp_path / "job", registry)
    assert (again.ran, again.skipped, again.failed) == (1, 2, [])
    assert rec.fingerprint(rec.read_record(path)) == good
    (aside,) = (tmp_path / "job" / "records" / "bad").iterdir()
    assert aside.name == path.name
    (line,) = [w for w in capsys.readouterr().err.splitlines() if "set aside" in w]
    assert line.startswith(f"warning: record {path} is not a valid record (field ")
    assert words in line and "xxx" not in line


#: Run 1's record made to claim run 0: as the attack did it (and -1 evaluations), and with
#: its instance edited too (only its file name then contradicts it).
CLAIMS = {
    "as-attacked": ({"run_index": 0, "result__evaluations": -1},
                    "field instance.index: expected the run's run_index"),
    "instance-too": ({"run_index": 0, "instance__index": 0},
                     "field run_index: expected 1, the run index its file name"),
}


@pytest.mark.parametrize("claim", list(CLAIMS))
def test_r4_12_the_report_counts_each_run_once_on_its_own_instance(claim, sweep, tmp_path):
    """The report: run 1's record claiming run 0 is skipped, naming the file and the field;
    runs 0 and 2 count once each (once run 0 twice, run 1 never)."""
    from vpid_bench.report.load import load_records, run_rows

    copy = tmp_path / "job"
    (copy / "records").mkdir(parents=True)
    for p in rec.iter_record_files([sweep]):
        (copy / "records" / p.name).write_text(p.read_text())
    bad = sorted((copy / "records").glob("run-001-*.json"))[0]
    changes, words = CLAIMS[claim]
    _edit(bad, **changes)
    loaded = load_records([copy])
    assert [p for p, _ in loaded.skipped] == [bad]
    assert loaded.skipped[0][1].startswith(words)
    assert sorted(r["run_index"] for r in run_rows(loaded.records)) == [0, 2]
    assert any(str(bad) in f and words in f for f in loaded.failures)
