"""Issue 13, cases 9, 16 and 17: the report's untrusted input and output folder, two
commands in one folder, non-finite objectives kept with their sign."""

from __future__ import annotations

import contextlib
import json
import math
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from extras import limit
from hostile_helpers import CLI, TINY, cli_env, run_cli

from vpid_bench import hookimpl
from vpid_bench.api import Bounds, Problem, ProblemConfig
from vpid_bench.experiment import run_from_config
from vpid_bench.store import records as rec


@pytest.fixture(scope="module")
def sweep(tmp_path_factory, compose_config, registry) -> Path:
    root = tmp_path_factory.mktemp("records") / "sweep"
    run_from_config(compose_config([*TINY, "runs=3"]), root / "job", registry)
    return root


BAD_FIELDS = [
    ("run_index", "three", "run_index: expected an integer from 0 to 2**63 - 1"),
    ("problem", ["x"], "problem: expected a mapping"),
    ("result.f_best", "small", "result.f_best: expected a number"),
    ("result.x_best", {"a": 1}, "result.x_best: expected a list of numbers"),
    ("trace.best", "x", "trace.best: expected a list of numbers"),
    ("seeds.seed", 1.5, "seeds.seed: expected an integer"),
]


@pytest.mark.parametrize(("field", "value", "line"), BAD_FIELDS, ids=[f for f, _, _ in BAD_FIELDS])
def test_9_a_wrongly_typed_record_is_one_warning_line(field, value, line, sweep, tmp_path,
                                                     capsys):
    """The real ``vpid-bench-report`` for the first field; its in-process twin (the same
    ``main``, seconds of start-up fewer) for the others."""
    copy = tmp_path / "copy"
    for p in rec.iter_record_files([sweep]):
        target = copy / p.relative_to(sweep)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(p.read_text())
    bad = sorted(copy.rglob("run-*.json"))[0]
    data = json.loads(bad.read_text())
    node = data
    *parents, leaf = field.split(".")
    for key in parents:
        node = node[key]
    node[leaf] = value
    bad.write_text(json.dumps(data))
    argv = [str(copy), "-o", str(tmp_path / "out")]
    if field == BAD_FIELDS[0][0]:
        done = run_cli(argv, tmp_path, report=True)
        code, stderr = done.returncode, done.stderr
    else:
        from vpid_bench.report.cli import main

        code, stderr = main(argv), capsys.readouterr().err
    assert "Traceback" not in stderr
    assert code == 1
    (warning,) = [w for w in stderr.splitlines() if bad.name in w]
    assert warning.endswith(line)


@pytest.mark.parametrize("target", ["file", "/dev/null", "read-only"])
def test_9_report_output_that_cannot_be_a_folder_is_refused(target, sweep, tmp_path):
    from hostile_helpers import read_only

    if target == "file":
        out = tmp_path / "afile"
        out.write_text("x")
    elif target == "/dev/null":
        out = Path("/dev/null")
    else:
        out = tmp_path / "ro"
    with read_only(tmp_path / "ro") if target == "read-only" else contextlib.nullcontext():
        done = run_cli([str(sweep), "-o", str(out)], tmp_path, report=True)
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: -o {out} is not allowed: a folder")
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr


def test_16_a_second_command_in_the_same_folder_is_refused(tmp_path):
    """Two real processes: the second is refused in one line (exit 2) while the first runs;
    the first finishes with every record. The first command's first job is short (its
    records say the command is under way) and its second one longer (about a second); the
    first command is stopped (SIGSTOP, its lock held) while the second runs, so the second
    meets it running however loaded the machine is, and continued after."""
    import signal

    args = ["-m", "problem=functions", "optimizer=de1", "problem.iterations=5,3000", "runs=4",
            "problem.dim=6", "progress=false", "report=false", "hydra.sweep.dir=shared"]
    first = subprocess.Popen([*CLI, *args], cwd=tmp_path, env=cli_env(),
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not list(tmp_path.rglob("records/run-*.json")) and time.monotonic() < deadline:
            assert first.poll() is None, first.stderr.read()
            time.sleep(0.02)
        first.send_signal(signal.SIGSTOP)
        try:
            assert first.poll() is None, "the first command should still be running"
            second = run_cli(args, tmp_path)
        finally:
            first.send_signal(signal.SIGCONT)
    finally:
        _, err = first.communicate(timeout=limit(120))
    assert second.returncode == 2
    assert second.stderr.splitlines() == [
        "error: hydra.sweep.dir='shared' is not allowed: a folder no other running vpid-bench "
        "command is using (another one is running there)"]
    assert first.returncode == 0, err
    assert sum(1 for _ in tmp_path.rglob("records/run-*.json")) == 8


# ---- 17: -inf kept with its sign ----


class _MinusInf(Problem):
    """f = -inf for a point in the lower-left quarter of the box, else the sphere."""

    Config = ProblemConfig

    @property
    def bounds(self) -> Bounds:
        return Bounds(np.full(2, -1.0), np.full(2, 1.0), ("a", "b"))

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        f = np.sum(X**2, axis=1)
        return np.where(np.all(X < -0.5, axis=1), -np.inf, f)


class _Plugin:
    @hookimpl
    def vpid_bench_register_problems(self, register):
        register("minus_inf", _MinusInf)


def test_17_minus_inf_from_a_problem_fails_its_run_and_the_report_says_so(tmp_path,
                                                                           registry_of):
    """A problem's -inf was once stored and ranked best; it is a broken problem (issue 24):
    each run fails with the reason, and the report is still written."""
    import vpid_baselines.plugin as baselines

    from vpid_bench.report.build import build_report

    registry = registry_of(("baselines", baselines), ("minus", _Plugin()))
    summary = run_from_config(
        {"problem": {"name": "minus_inf", "ps": 20, "iterations": 5},
         "optimizer": {"name": "random"}, "runs": 2, "progress": False},
        tmp_path / "sweep" / "job", registry)
    assert summary.failed == [0, 1]
    raw = json.loads(summary.record_paths[0].read_text())
    assert raw["status"] == "failed" and "returned -inf" in raw["error"]["message"]
    report = build_report([tmp_path / "sweep"], tmp_path / "out", short=True)
    assert report.report_md.is_file()


def test_17_old_records_with_null_still_read_as_inf():
    from vpid_bench.report.load import _num
    from vpid_bench.store.records import decode_numbers

    assert _num(None) == math.inf and _num("-inf") == -math.inf and math.isnan(_num("nan"))
    assert decode_numbers({"result": {"f_best": "nan", "x_best": ["inf", 1.0],
                                          "metrics": {"m": "-inf"}}})["result"]["metrics"] == {
        "m": -math.inf}


def test_json_nested_past_the_recursion_limit_is_a_corrupt_record(tmp_path):
    """A record (or optima, status) file holding [[[[...]]]] once gave a RecursionError
    traceback: every reader goes through fileio.loads_json, which makes it bad JSON."""
    import json as _json

    from vpid_bench.fileio import loads_json
    from vpid_bench.store.records import CorruptRecordError, read_record

    deep = "[" * 100_000 + "]" * 100_000
    with pytest.raises(_json.JSONDecodeError, match="nested too deeply"):
        loads_json(deep)
    path = tmp_path / "run-000-deadbeef.json"
    path.write_text('{"schema": 2, "deep": ' + deep + "}")
    with pytest.raises(CorruptRecordError, match="nested too deeply"):
        read_record(path)


@pytest.mark.parametrize("value", [10**400, -1, 2**63, True, "3"])
def test_a_run_index_out_of_range_is_a_wrongly_typed_record(value):
    """run_index = 10**400 once overflowed the report's float conversion (a traceback)."""
    from vpid_bench.report.load import check_record

    record = {"run_id": "r", "run_index": value, "status": "ok"}
    assert check_record(record).startswith("run_index: expected an integer from 0")
