"""Run records: every field, determinism, atomic writes, corrupt files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vpid_bench.build import run_rng
from vpid_bench.experiment import run_from_config
from vpid_bench.fileio import _umask
from vpid_bench.store import records as rec

FAST = ["problem=functions", "optimizer=random", "runs=3", "problem.iterations=4",
        "progress=false"]


@pytest.fixture(scope="module")
def job(tmp_path_factory, compose_config):
    """One small job: 3 runs of random search on the 10-D sphere."""
    out = tmp_path_factory.mktemp("job")
    summary = run_from_config(compose_config(FAST), out)
    return out, summary


def _records(job_dir: Path) -> list[dict]:
    return [rec.read_record(p) for p in rec.iter_record_files([job_dir])]


def test_one_record_per_run_with_every_field(job):
    job_dir, summary = job
    records = _records(job_dir)
    assert len(records) == 3 == summary.ran
    r = records[0]
    for key in rec.REQUIRED_KEYS:
        assert key in r
    assert r["schema"] == rec.SCHEMA and r["status"] == "ok" and r["error"] is None
    assert r["problem"]["name"] == "functions" and r["optimizer"]["name"] == "random"
    # Each setting once: the protocol in the problem's config, the seed in seeds.
    assert r["optimizer"]["params"] == {}
    assert (r["problem"]["config"]["ps"], r["problem"]["config"]["iterations"]) == (20, 4)
    assert r["seeds"] == {"seed": 0, "spawn_key": [0]}
    assert r["problem"]["plugin"]["distribution"] == "vpid-bench"
    assert r["optimizer"]["plugin"]["plugin"] == "baselines" or r["optimizer"]["plugin"][
        "distribution"]
    assert "numpy" in r["problem"]["plugin"]["requires"]
    assert r["budget"] == 20 * 5
    assert r["parameters"]["names"][:2] == ["x1", "x2"] and len(r["parameters"]["units"]) == 10
    res = r["result"]
    assert res["evaluations"] == 100 and len(res["x_best"]) == 10
    assert res["f_best"] == pytest.approx(float(np.sum(np.square(res["x_best"]))))
    assert r["trace"]["evaluations"] == [20, 40, 60, 80, 100]
    assert r["trace"]["best"][-1] == res["f_best"]
    assert all(a >= b for a, b in zip(r["trace"]["best"], r["trace"]["best"][1:]))
    assert "config" not in r  # schema 2: no second copy of the settings
    assert {"python", "numpy", "vpid-bench"} <= set(r["versions"])
    assert r["timing"]["wall_time_s"] > 0


def test_relative_errors_where_true_values_exist(tmp_path, compose_config):
    cfg = compose_config(FAST[:-1] + ["problem.function=rosenbrock", "runs=1"])
    run_from_config(cfg, tmp_path)
    (r,) = _records(tmp_path)
    x = np.asarray(r["result"]["x_best"])
    eps = 100 * (x - 1.0) / 1.0
    np.testing.assert_allclose(r["result"]["rel_error_percent"], eps, rtol=1e-12)
    # The functions problem reports no metrics: the norm of eps is the vehicle's business.
    assert r["result"]["metrics"] == {} and "nore" not in r["result"]


def test_same_config_and_seed_give_identical_records(job, tmp_path, compose_config):
    job_dir, _ = job
    run_from_config(compose_config(FAST), tmp_path)
    a = [rec.fingerprint(r) for r in _records(job_dir)]
    b = [rec.fingerprint(r) for r in _records(tmp_path)]
    assert a == b
    names_a = sorted(p.name for p in rec.iter_record_files([job_dir]))
    names_b = sorted(p.name for p in rec.iter_record_files([tmp_path]))
    assert names_a == names_b  # deterministic run ids


def test_different_seeds_and_runs_differ(job, tmp_path, compose_config):
    job_dir, _ = job
    run_from_config(compose_config(FAST + ["seed=1"]), tmp_path)
    x0 = [r["result"]["x_best"] for r in _records(job_dir)]
    x1 = [r["result"]["x_best"] for r in _records(tmp_path)]
    assert x0[0] != x0[1] != x0[2]
    assert all(a != b for a, b in zip(x0, x1))
    ids0 = {r["run_id"] for r in _records(job_dir)}
    assert ids0.isdisjoint(r["run_id"] for r in _records(tmp_path))


def test_run_streams_are_seedsequence_children():
    child = np.random.SeedSequence(7).spawn(3)[2]
    expected = np.random.default_rng(child).random(4)
    np.testing.assert_array_equal(run_rng(7, 2).random(4), expected)


def test_atomic_write_leaves_no_temporary_file(tmp_path):
    path = rec.write_record(tmp_path / "records" / "run-000-x.json", {"a": np.float64(np.inf)})
    assert json.loads(path.read_text()) == {"a": "inf"}  # strict JSON, the sign kept
    assert [p.name for p in path.parent.iterdir()] == [path.name]
    assert path.stat().st_mode & 0o044 == 0o044 & ~_umask()  # readable by others, per umask


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("{not json", "not a readable JSON"),
        ('{"schema": "other"}', "not a vpid-bench run record"),
        (json.dumps({"schema": rec.SCHEMA, "run_id": "x"}), "missing"),
    ],
)
def test_corrupt_records_are_named(tmp_path, text, fragment):
    path = tmp_path / "run-000-x.json"
    path.write_text(text)
    with pytest.raises(rec.CorruptRecordError, match=fragment) as info:
        rec.read_record(path)
    assert str(path) in str(info.value)


def test_a_record_of_the_previous_schema_is_named_in_one_line(tmp_path, capsys):
    """Schema 1 records (round one) are not misread: the report names them as older, once."""
    from vpid_bench.report.cli import main as report_main

    old = tmp_path / "sweep" / "job" / "records" / "run-000-abc.json"
    old.parent.mkdir(parents=True)
    old.write_text(json.dumps({"schema": "vpid-bench/run-record/1", "run_id": "abc"}))
    with pytest.raises(rec.OldRecordError, match="older vpid-bench"):
        rec.read_record(old)
    code = report_main([str(tmp_path / "sweep"), "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2  # nothing readable: no report
    assert err.count("older vpid-bench (vpid-bench/run-record/1)") == 1, err


@pytest.mark.parametrize(
    "value, expected",
    [
        ([1.0, 2, -0.5], [1.0, 2, -0.5]),  # the fast path: plain finite numbers
        ([1.0, float("-inf"), float("nan")], [1.0, "-inf", "nan"]),
        ((1, True, None, "x"), [1, True, None, "x"]),
        (np.array([[1.0, np.inf], [2.0, -np.inf]]), [[1.0, "inf"], [2.0, "-inf"]]),
        (np.array([3, 4], dtype=np.int32), [3, 4]),
        ([np.float64(1.5), np.int64(2), np.bool_(True)], [1.5, 2, True]),
        ({1: (np.float32(0.5),), "k": {"n": float("inf")}}, {"1": [0.5], "k": {"n": "inf"}}),
    ],
)
def test_records_hold_strict_json_with_the_sign_of_infinities(tmp_path, value, expected):
    """Every container and number type a record may hold, on the fast and the slow path."""
    path = rec.write_record(tmp_path / "r.json", {"v": value})
    text = path.read_text()
    assert json.loads(text) == {"v": expected}
    assert "Infinity" not in text and "NaN" not in text


def test_a_record_name_parses_back_to_its_index_and_id(tmp_path):
    from vpid_bench.store.records import parse_record_name, record_path

    assert parse_record_name(record_path(tmp_path, 7, "ab12cd").name) == (7, "ab12cd")
    assert parse_record_name("run-7.json") is None and parse_record_name("x.json") is None
