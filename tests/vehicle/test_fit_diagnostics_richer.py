"""Fit diagnostics and the robust interval on records made by richer models than the fitted
ones (the suite's model-error members, plugins/vpid_vehicle/ride/richer.py): the diagnostics
flag the correlated residuals in one line, the robust (HAC) interval is at least 3x the
white-noise one there, and it covers the pseudo-true value (the fit to the noise-free record)
at >= 80 % for a nominal 95 % (tools/interval_coverage.py prints the full figures)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parents[2] / "tools"))

import interval_coverage  # noqa: E402

from vpid_bench.analysis.diagnostics import problem_diagnostics  # noqa: E402
from vpid_bench.report.diagnostics import plain_line  # noqa: E402


def _member(name: str, i: int = 0):
    from vpid_vehicle.ride.suites import MEMBERS

    cls = {m.name: m for m in MEMBERS}[name]
    return cls(cls.Config()).instance(i)


def test_a_quarter_car_record_from_a_bilinear_damper_is_flagged_in_one_line():
    p = _member("vpid1_q_golden_bilinear")
    x = interval_coverage._fit(p, p.measured, p.x_true)
    d = problem_diagnostics(p, x)
    assert not d["explained"]
    line = plain_line(d)
    assert line.startswith("The residuals are correlated (") and line.count(".") <= 3
    assert "the model misses dynamics the record holds" in line
    assert all(g["correlated"] and g["lag1"] > 0.8 for g in d["groups"])
    assert {g["name"] for g in d["groups"]} == {"zs''", "zu''"}
    iv = d["intervals"]
    ratio = np.array(iv["robust"]["se"]) / np.array(iv["se"])
    assert np.all(ratio >= 3), ratio


def test_a_quarter_car_record_the_model_made_is_not_flagged():
    p = _member("vpid1_q_golden_hump")
    x = interval_coverage._fit(p, p.measured, p.x_true)
    d = problem_diagnostics(p, x)
    assert all(g["rms_over_sigma"] < 1.2 for g in d["groups"])
    iv = d["intervals"]
    ratio = np.array(iv["robust"]["se"]) / np.array(iv["se"])
    assert np.all(ratio < 1.6), ratio


def test_robust_coverage_of_the_pseudo_true_value_on_one_member():
    """The fast twin of the slow test: one member, 4 instances (16 parameter cases)."""
    c = interval_coverage.member_coverage("vpid1_q_golden_bilinear", 4)
    assert c["cases"] == 16 and c["robust"] >= 0.8
    assert c["half_robust"] > 3 * c["half_white"]


@pytest.mark.slow
@pytest.mark.parametrize("member", interval_coverage.MEMBERS)
def test_robust_coverage_of_the_pseudo_true_value_over_15_instances(member):
    c = interval_coverage.member_coverage(member, 15)
    assert c["robust"] >= 0.8, c


def test_the_benchmark_refuses_an_unknown_member(capsys):
    assert interval_coverage.main(["--instances", "1", "vpid1_q_golden_hump"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: member 'vpid1_q_golden_hump'") and err.count("\n") == 1
