"""Which structure a record supports (issue 43, item 2): the structure report on a quarter-car
record made by a cubic spring and a bilinear damper ranks that structure first, its residuals
alone white, its values' intervals around the generating ones; and the pure pieces
(:mod:`vpid_bench.analysis.structures`) against analytic results."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from vpid_vehicle.record_file import column_name
from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem
from vpid_vehicle.structure_report import compare_record, record_groups

from vpid_bench.analysis import structures as st

#: The record: a rough road (class D at 60 km/h) long enough that the validation third holds
#: the car's response to more road; body and wheel accelerations.
ROAD = dict(road="iso8608", road_class="D", speed_kmh=60.0, sensors="body_wheel")


def _write_record(path, problem) -> None:
    cols = {"t": problem.t, "h": problem.u[:, 0]}
    for c, (name, _) in enumerate(problem.channels):
        cols[column_name(name)] = problem.measured[c]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(list(cols))
        w.writerows(np.column_stack(list(cols.values())))


def _run(spring: str, damper: str, file: str, x_best: list[float]) -> dict:
    """A run record as the sweep writes it (the fields the section reads)."""
    config = {**ROAD, "reference": {"file": file}, "ps": 20, "iterations": 10}
    if spring != "linear":
        config["spring"] = spring
    if damper != "linear":
        config["damper"] = damper
    return {"status": "ok", "problem": {"name": "ride_quarter", "config": config},
            "instance": {"id": None, "index": 0},
            "result": {"x_best": x_best, "f_best": 1.0}}


@pytest.mark.slow
def test_the_richer_structure_is_the_one_a_cubic_bilinear_record_supports(tmp_path):
    """The done-when of issue 43, item 2, through the report section's own path (runs ->
    groups -> refits). The intervals are 95 % per parameter (six of them hold the truth
    together about 3 times in 4); the record's seed is one where they do, and the fit's
    bias on the same record without noise is within 0.03 % of every value (about a tenth
    of the intervals' half-widths; measured with ``noise_level=0``)."""
    truth_problem = RideQuarterProblem(RideQuarterConfig(
        spring="cubic", damper="bilinear", duration_s=4.0, seed=4, **ROAD))
    path = tmp_path / "record.csv"
    _write_record(path, truth_problem)
    runs = []
    for spring in ("linear", "cubic"):
        for damper in ("linear", "bilinear"):
            box = RideQuarterProblem(RideQuarterConfig(spring=spring, damper=damper,
                                                       duration_s=1.0)).bounds
            runs.append(_run(spring, damper, str(path),
                             list(0.5 * (box.lower + box.upper))))
    groups = record_groups(runs)
    assert len(groups) == 1, "the four structures share one record"
    fits = {f.label: f for f in compare_record(next(iter(groups.values())))}
    rich, plain = fits["spring=cubic damper=bilinear"], fits["spring=linear damper=linear"]
    order = st.ranked(fits.values())
    assert order[0] is rich, [f.label for f in order]
    assert rich.bic == min(f.bic for f in fits.values())
    assert plain.bic - rich.bic > 10  # very strong evidence
    assert rich.white_p >= 0.05 > plain.white_p
    inside = (rich.lower <= truth_problem.x_true) & (truth_problem.x_true <= rich.upper)
    assert np.all(inside), dict(zip(rich.names, zip(rich.lower, truth_problem.x_true,
                                                    rich.upper, strict=True), strict=True))
    text = st.verdict(list(fits.values()))
    assert "supports **spring=cubic damper=bilinear**" in text and "pass the whiteness" in text


def test_information_criteria_are_the_profiled_gaussian_likelihoods():
    rss, n, k = [2.0, 0.5], [100, 50], 3
    m2logl = 100 * math.log(2.0 / 100) + 50 * math.log(0.5 / 50)
    aic, bic = st.information_criteria(rss, n, k)
    assert aic == pytest.approx(m2logl + 6)
    assert bic == pytest.approx(m2logl + 3 * math.log(150))


def test_the_whiteness_test_tells_white_noise_from_a_correlated_series():
    rng = np.random.default_rng(0)
    white = rng.standard_normal(2000)
    ar = np.empty(2000)
    ar[0] = white[0]
    for i in range(1, 2000):
        ar[i] = 0.5 * ar[i - 1] + white[i]
    assert st.ljung_box_p(white) > 0.05
    assert st.ljung_box_p(ar) < 1e-6


def test_the_segments_hold_out_each_channels_last_third():
    groups = np.repeat([0, 1], 9)
    fit, val = st.segments(groups)
    assert [list(i) for i in fit] == [list(range(6)), list(range(9, 15))]
    assert [list(i) for i in val] == [list(range(6, 9)), list(range(15, 18))]


def test_runs_of_one_structure_or_of_other_records_make_no_comparison():
    one = [_run("linear", "linear", "a.csv", [1.0]), _run("linear", "linear", "a.csv", [1.0])]
    assert record_groups(one) == {}
    two_records = [_run("linear", "linear", "a.csv", [1.0]),
                   _run("cubic", "linear", "b.csv", [1.0])]
    assert record_groups(two_records) == {}
    failed = [_run("linear", "linear", "a.csv", [1.0]), {**_run("cubic", "linear", "a.csv",
                                                                 [1.0]), "status": "error"}]
    assert record_groups(failed) == {}
