"""Cost beside evaluations: sequential batches (rounds of ask/tell) and the run's own seconds
to each target, from the trace and the per-batch times a record keeps, with ERT in each."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
from sweep_helpers import run_cli  # noqa: E402

from vpid_bench.machine import machine_facts  # noqa: E402
from vpid_bench.report.anytime import RunHits, ert, run_hits  # noqa: E402
from vpid_bench.store.records import fingerprint


def _record(rid, ev, best, secs):
    return {"run_id": rid, "status": "ok", "trace": {"evaluations": ev, "best": best},
            "timing": {"trace_s": secs}}


def _row(rid, used, run_time):
    return {"run_id": rid, "status": "ok", "f_opt": 1.0, "evaluations": used, "budget": 100,
            "run_time_s": run_time, "context": "c", "algorithm": "a"}


def test_batches_and_seconds_to_each_target_come_from_the_trace():
    # relative gaps 1.5, 0.5, 0.05, 0.0 after batches 1..4 of 10 evaluations
    rec = _record("r", [10, 20, 30, 40], [2.5, 1.5, 1.05, 1.0], [0.1, 0.2, 0.35, 0.5])
    (h,) = run_hits([rec], [_row("r", 40, 0.6)], targets=(1.0, 0.1, 1e-6))
    assert h.hits == (20.0, 30.0, 40.0)
    assert h.hit_batches == (2.0, 3.0, 4.0)
    assert h.hit_seconds == (0.2, 0.35, 0.5)
    assert (h.used_batches, h.used_seconds) == (4.0, 0.6)


def test_ert_in_each_cost_counts_a_failed_run_whole():
    hit = RunHits("c", "a", 100, 40, (20.0,), (2.0,), (0.2,), 4.0, 0.5)
    miss = RunHits("c", "a", 100, 100, (math.nan,), (math.nan,), (math.nan,), 10.0, 1.5)
    assert ert([hit, miss], 0) == pytest.approx((20 + 100) / 1)
    assert ert([hit, miss], 0, "batches") == pytest.approx((2 + 10) / 1)
    assert ert([hit, miss], 0, "seconds") == pytest.approx((0.2 + 1.5) / 1)


def test_a_record_without_per_batch_times_gives_no_seconds():
    rec = _record("r", [10, 20], [1.5, 1.0], None)
    (h,) = run_hits([rec], [_row("r", 20, 0.3)], targets=(1e-6,))
    assert h.hit_batches == (2.0,) and np.isnan(h.hit_seconds[0])
    assert np.isnan(ert([h], 0, "seconds")) and ert([h], 0, "batches") == 2.0


def test_a_record_names_its_machine_and_per_batch_times(tmp_path):
    """Seconds depend on the machine: a record keeps its CPU, cores and BLAS beside the
    per-batch times (both under timing, which a determinism check leaves out)."""
    facts = machine_facts()
    assert isinstance(facts["cpu"], str) and facts["cpu"]
    assert facts["cores"] >= facts["cores_available"] >= 1
    assert facts["blas"] and all({"api", "version", "threads"} <= set(b) for b in facts["blas"])
    done = run_cli(["problem=functions", "problem.dim=3", "optimizer=de1", "runs=2",
                    "problem.iterations=3", "report=false", f"hydra.run.dir={tmp_path}/a"],
                   cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-1000:]
    recs = [json.loads(p.read_text()) for p in sorted((tmp_path / "a").glob("records/*"))]
    for r in recs:
        assert r["timing"]["machine"]["cpu"] == facts["cpu"]
        times = r["timing"]["trace_s"]
        assert len(times) == len(r["trace"]["evaluations"]) == r["result"]["batches"]
        assert times == sorted(times) and times[-1] <= r["timing"]["run_time_s"] + 1e-9
    again = run_cli(["problem=functions", "problem.dim=3", "optimizer=de1", "runs=2",
                     "problem.iterations=3", "report=false", f"hydra.run.dir={tmp_path}/b"],
                    cwd=tmp_path)
    assert again.returncode == 0
    other = [json.loads(p.read_text()) for p in sorted((tmp_path / "b").glob("records/*"))]
    assert [fingerprint(r) for r in recs] == [fingerprint(r) for r in other]
