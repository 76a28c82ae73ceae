"""Supervised worker processes (vpid_bench.workers, ``isolation=process``): records equal to the
in-process path, and a run that ends or blocks its process costs that run only."""

from __future__ import annotations

import pytest

from vpid_bench.experiment import run_job
from vpid_bench.spec import parse_job
from vpid_bench.store import records as rec
from vpid_bench.workers import RemoteError, Workers, describe_exit, portable

FAST_VEHICLE = ["problem=vehicle", "problem.iterations=3", "progress=false", "report=false"]


@pytest.fixture(scope="module")
def pool():
    workers = Workers(2)
    yield workers
    workers.close()


def _prints(summary):
    return [rec.fingerprint(rec.read_record(p)) for p in summary.record_paths]


@pytest.mark.parametrize("optimizer", ["de1", "lsq"])
def test_records_in_workers_are_bit_identical_to_in_process(registry, compose_config, tmp_path,
                                                            pool, optimizer):
    # de1 goes in lockstep groups (split over two workers), lsq one run at a time
    base = [*FAST_VEHICLE, f"optimizer={optimizer}", "runs=5"]
    here = run_job(parse_job(compose_config([*base, "isolation=none"]), registry),
                   tmp_path / "here", registry, pool=pool)
    there = run_job(parse_job(compose_config([*base, "isolation=auto"]), registry),
                    tmp_path / "there", registry, pool=pool)
    assert here.ran == there.ran == 5 and not here.failed and not there.failed
    assert _prints(here) == _prints(there)


def test_isolation_process_starts_its_own_workers(registry, compose_config, tmp_path):
    job = parse_job(compose_config([*FAST_VEHICLE, "optimizer=random", "runs=2",
                                    "isolation=process", "workers=1"]), registry)
    summary = run_job(job, tmp_path, registry)
    assert summary.ran == 2 and not summary.failed


def test_a_bad_isolation_value_names_the_key_and_the_choices(registry, compose_config):
    from vpid_bench.errors import ConfigError

    with pytest.raises(ConfigError, match=r"isolation='thread'.*auto \| process \| none"):
        parse_job(compose_config([*FAST_VEHICLE, "isolation=thread"]), registry)


def test_a_remote_error_keeps_type_message_and_traceback():
    import pickle

    class OddError(Exception):
        def __init__(self, a, b):  # does not unpickle with one argument
            super().__init__(f"{a}/{b}")

    try:
        raise OddError(1, 2)
    except OddError as exc:
        carried = pickle.loads(pickle.dumps(portable(exc)))
    assert isinstance(carried, RemoteError)
    assert (carried.remote_type, str(carried)) == ("OddError", "1/2")
    assert "raise OddError(1, 2)" in carried.remote_traceback
    section = rec.error_section(carried) if hasattr(rec, "error_section") else None
    if section is not None:
        assert section["type"] == "OddError" and "raise OddError" in section["traceback"]


def test_exit_descriptions():
    assert describe_exit(3) == "exit code 3"
    assert describe_exit(-11) == "signal SIGSEGV"
    assert describe_exit(-6) == "signal SIGABRT"


def test_a_bad_workers_value_names_the_key(registry, compose_config):
    from vpid_bench.errors import ConfigError

    with pytest.raises(ConfigError, match=r"workers=0"):
        parse_job(compose_config([*FAST_VEHICLE, "workers=0"]), registry)


def test_lockstep_tasks_are_balanced_over_the_workers():
    from vpid_bench.workers import LOCKSTEP_CHUNK, _tasks

    for runs in range(1, 101):
        for workers in (1, 2, 3):
            tasks = _tasks(list(range(runs)), workers)
            sizes = [len(t) for t in tasks]
            assert [i for t in tasks for i in t] == list(range(runs))  # every run, in order
            assert max(sizes) <= LOCKSTEP_CHUNK and max(sizes) - min(sizes) <= 1
            assert len(tasks) >= min(workers, runs)  # no worker idle while runs wait
    assert sorted(len(t) for t in _tasks(list(range(30)), 2)) == [7, 7, 8, 8]
    assert [len(t) for t in _tasks(list(range(30)), 1)] == [10, 10, 10]


def test_the_analysis_after_the_runs_is_bounded_and_its_failure_said(registry, compose_config,
                                                                       tmp_path, monkeypatch,
                                                                       capsys):
    """An analysis (optimum polish) that never ends once kept the job for ever: it is bounded
    by run_timeout_s x runs and its failure is one warning line on the terminal."""
    import time

    from vpid_bench import experiment

    def endless(*args, **kwargs):
        time.sleep(60)

    monkeypatch.setattr(experiment, "analyse_job", endless)
    job = parse_job(compose_config(["problem=functions", "optimizer=random", "runs=2",
                                    "problem.iterations=2", "progress=false", "report=false",
                                    "run_timeout_s=1", "isolation=none"]), registry)
    assert experiment.analysis_limit_s(job) == 2
    t0 = time.monotonic()
    summary = run_job(job, tmp_path, registry)
    assert time.monotonic() - t0 < 10 and summary.ran == 2 and not summary.failed
    warning = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("warning:")]
    assert len(warning) == 1 and "analysis failed (RunTimeoutError" in warning[0]


def test_the_job_task_sent_to_a_launchers_worker_has_every_attribute():
    """The task Hydra's joblib launcher pickles to its workers once lost an attribute
    (AttributeError in every job there): its state is the fresh task's, minus what cannot go."""
    import pickle

    from vpid_bench.shell.main import JobTask

    fresh = JobTask()
    sent = pickle.loads(pickle.dumps(fresh))
    assert set(vars(sent)) == set(vars(fresh))


def test_a_ctrl_c_while_a_worker_starts_waits_until_it_is_started():
    """A Ctrl-C in the middle of ``Process.start()`` once cut the start-up data the child
    reads, and the child printed Python's traceback: SIGINT is held while a worker starts and
    raised once it is started."""
    import os
    import signal
    import time

    from vpid_bench.workers import _sigint_held

    # Python's own handler, as in a command: pytest-xdist's workers ignore SIGINT
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    reached = False
    try:
        with pytest.raises(KeyboardInterrupt), _sigint_held():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.05)  # a delivered SIGINT would raise here
            reached = True
    finally:
        signal.signal(signal.SIGINT, previous)
    assert reached
