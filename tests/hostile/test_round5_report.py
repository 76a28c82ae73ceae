"""Round five's report failures (issue 44), each named by its id: N16 (the built-in test
functions' first screen called them "a measured record" and reported profile-likelihood
failures on a clean run)."""

from __future__ import annotations

import json

import pytest


@pytest.mark.parametrize("function", ["sphere", "rastrigin"])
def test_n16_test_functions_are_no_measured_record(function, tmp_path, registry):
    """A clean run of a test function whose minimiser has a zero coordinate (no truth is
    offered): no "measured record", no profile likelihood, no intervals and no fit diagnostics
    (there is no record to identify), and the first screen says why there is no truth."""
    from vpid_functions.plugin import FunctionsConfig

    from vpid_bench.experiment import run_from_config
    from vpid_bench.params import hydra_node
    from vpid_bench.report.build import build_report

    cfg = {"problem": hydra_node(FunctionsConfig, "functions") | {
               "function": function, "dim": 3, "iterations": 5, "ps": 8},
           "optimizer": {"name": "de1"}, "seed": 0, "runs": 3, "progress": False,
           "report": False}
    summary = run_from_config(cfg, tmp_path, registry=registry)
    recs = [json.loads(p.read_text()) for p in summary.record_paths]
    assert all(r["status"] == "ok" for r in recs)
    assert all(r["problem"]["info"]["fits_a_record"] is False for r in recs)
    assert all("intervals" not in r["result"] for r in recs)
    assert not (tmp_path / "profile.json").exists()
    assert not (tmp_path / "diagnostics.json").exists()
    build_report([tmp_path], tmp_path / "report", short=True)
    text = " ".join((tmp_path / "report" / "report.md").read_text().split())
    assert "measured record" not in text and "profile likelihood failed" not in text
    assert "No truth is offered by this problem (it fits no record)" in text
    assert "Fit diagnostics" not in text


def test_n16_a_record_fitting_problem_without_truth_keeps_its_wording():
    """The other side: a problem that fits a record (the default) keeps "a measured record"."""
    from vpid_bench.problem import Problem
    from vpid_bench.report.estimates import NO_TRUTH

    assert Problem.fits_a_record is True and "a measured record" in NO_TRUTH
