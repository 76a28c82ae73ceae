"""The single job's light report: its numbers against a hand computation and against the
full report's tables, its files, and that it imports no pandas, matplotlib or scipy.stats."""

from __future__ import annotations

import math

import numpy as np
import pytest
from report_synth import OV, PAPER_NAMES, objective_job, record, write_job

from vpid_bench.report import tables
from vpid_bench.report.light import full_report_command, light_report
from vpid_bench.report.load import NoRecordsError, load_records, runs_frame

# Run i moves only m by A[i] (relative): its NoRE is 100 |A[i]| = 1, 2, 4, 10 %.
A = [0.01, 0.02, 0.04, 0.10]
F = [0.5, 0.1, 0.3, 0.2]


def _de4_job(root, with_failed=True):
    recs = []
    for i, (a, f) in enumerate(zip(A, F, strict=True)):
        x = OV.copy()
        x[0] *= 1 + a
        recs.append(record(problem="vehicle", optimizer="de4", ps=20, run_index=i, x=x, f=f,
                           names=PAPER_NAMES, true=OV))
    if with_failed:
        recs.append(record(problem="vehicle", optimizer="de4", ps=20, run_index=4, x=None,
                           f=None, names=PAPER_NAMES, true=OV, status="failed"))
    return write_job(root / "job", recs, status="failed_runs" if with_failed else "ok")


def test_numbers_match_a_hand_computation(tmp_path):
    job = _de4_job(tmp_path)
    rep = light_report(job, job / "report")
    (s,) = rep.summary
    # NoRE per run: 1, 2, 4, 10. numpy's linear quartiles: 1 + 0.75 (2 - 1), 4 + 0.25 (10 - 4).
    assert (s["context"], s["algorithm"], s["metric_name"]) == ("vehicle ps=20", "de4", "NoRE")
    assert (s["n_runs"], s["n_failed"]) == (4, 1)
    assert s["median"] == pytest.approx(3.0)
    assert (s["q1"], s["q3"], s["iqr"]) == pytest.approx((1.75, 5.5, 3.75))
    assert s["mean"] == pytest.approx(4.25)
    # sd: squared deviations 3.25², 2.25², 0.25², 5.75² sum to 48.75; / (4 - 1) = 16.25.
    assert s["sd"] == pytest.approx(math.sqrt(16.25))
    assert (s["best"], s["worst"]) == pytest.approx((1.0, 10.0))
    assert s["f_median"] == pytest.approx(0.25)  # f: 0.1, 0.2, 0.3, 0.5
    # Mean vector: m is off by the mean of A, 4.25 %, every other parameter exact.
    mv = s["mean_vector"]
    assert mv["eps"][0] == pytest.approx(4.25) and np.allclose(mv["eps"][1:], 0.0)
    assert s["meanvec_nore"] == pytest.approx(4.25)
    assert s["paper_nore"] == 1.51  # Table II, DE4
    assert mv["paper"]["eps"][0] == 0.31 and mv["paper"]["table"] == "II"

    head = rep.headline
    for text in ("de4", "NoRE", "[1.75, 5.5]", "4.25 ± 4.031", "1.51", "0.25"):
        assert text in head, text
    header = head.splitlines()[0].split()
    assert header[:4] == ["context", "optimizer", "n", "failed"]
    md = rep.report_md.read_text()
    assert md == (job / "report" / "report.md").read_text()
    assert head.splitlines()[2].split()[:2] == ["vehicle", "ps=20"]
    assert "| m " in md and "4.25" in md and "0.31" in md  # ε of m, ours and the paper's
    assert full_report_command(job) in md and "vpid-bench-report" in md
    assert "**Failed run** de4 on vehicle ps=20, run 4 (seed 0): RuntimeError: boom" in md
    assert not (job / "report" / "figures").exists()
    assert any("failed_runs" in line for line in rep.failures)


def test_numbers_agree_with_the_full_report(tmp_path):
    """The same records through the full report's pandas tables give the same numbers."""
    _de4_job(tmp_path / "a")
    objective_job(tmp_path / "b", "ga", 30, [3.0, 1.0, 2.0, math.inf], problem="toy")
    for job in (tmp_path / "a" / "job", tmp_path / "b"):
        loaded = load_records([job])
        df = runs_frame(loaded.records)
        st = tables.run_stats_table(df, tables.mean_vector_table(df))
        (s,) = light_report(job, tmp_path / "out").summary
        (full,) = st.to_dict("records")
        for key in ("n_runs", "n_failed", "median", "q1", "q3", "iqr", "mean", "sd", "best",
                    "worst", "f_median", "f_best", "f_worst", "meanvec_nore", "paper_nore"):
            assert s[key] == pytest.approx(full[key], nan_ok=True), (job, key)
        assert (s["context"], s["algorithm"], s["metric_name"]) == (
            full["context"], full["algorithm"], full["metric_name"])


def test_objective_only_job_leaves_the_nore_columns_out(tmp_path):
    job = objective_job(tmp_path, "random", 20, [1.0, 3.0])
    rep = light_report(job, job / "report")
    header = rep.headline.splitlines()[0]
    assert "f_best" in rep.headline and "NoRE" not in header and "paper" not in header
    assert "no true parameter values" in rep.report_md.read_text()
    assert rep.failures == []


def test_torn_record_is_named_and_no_record_raises(tmp_path):
    job = objective_job(tmp_path, "random", 20, [1.0, 3.0])
    torn = job / "records" / "run-007-torn.json"
    torn.write_text('{"schema": "vpid')
    rep = light_report(job, job / "report")
    assert rep.n_records == 2
    (line,) = rep.failures
    assert line.startswith(f"unreadable record {torn}: not a readable JSON run record")
    assert "Skipped unreadable record" in rep.report_md.read_text()
    with pytest.raises(NoRecordsError):
        light_report(tmp_path / "empty", tmp_path / "out")


HEAVY = ("pandas", "matplotlib", "seaborn", "scipy.stats", "statsmodels", "scikit_posthocs")


