"""Floors per estimator: the job polishes each objective's optimum on its first instances and
writes them (estimators.json); the report reads them as untrusted input, names each floor's
estimator, and the first screen points to a better estimator where the objective limits."""

from __future__ import annotations

import json

import pytest
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.problem import VehicleProblem
from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

from vpid_bench.analysis.estimator_floors import INSTANCES, estimator_floors
from vpid_bench.analysis.optimum import polish
from vpid_bench.experiment import run_from_config
from vpid_bench.params import hydra_node
from vpid_bench.report.build import build_report
from vpid_bench.store.job_checks import read_estimator_floors


def test_each_objectives_optimum_on_the_first_instances():
    """Four floors on min(INSTANCES, runs) instances, each the metric of the polished
    optimum of that objective from the truth (checked against a direct polish)."""
    p = VehicleProblem(VehicleConfig())
    out = estimator_floors(p, runs=3)
    assert out["metric"] == "NoRE" and out["instances"] == 3 and out["chosen"] == "eq3"
    assert set(out["floors"]) == {"eq3", "ols", "ml", "ml_profiled"}
    ml = VehicleProblem(VehicleConfig(objective="ml")).instance(2)
    expected = ml.metrics(polish(ml, ml.x_true)[0])["NoRE"]
    assert out["floors"]["ml"]["values"][2] == pytest.approx(expected, rel=1e-9)
    assert out["floors"]["ml"]["median"] < out["floors"]["eq3"]["median"] / 5
    assert estimator_floors(p, runs=100)["instances"] == INSTANCES


def test_an_objective_the_problem_refuses_is_left_out_and_a_problem_without_choice_has_none():
    quiet = RideQuarterProblem(RideQuarterConfig(noise_level=0.0))
    out = estimator_floors(quiet, runs=2)
    assert set(out["floors"]) == {"eq3", "ols", "ml_profiled"}  # ml needs a noise level

    class NoChoice:
        config = None
        x_true = quiet.x_true

    assert estimator_floors(NoChoice(), runs=2) is None


GOOD = {"metric": "NoRE", "instances": 2, "chosen": "eq3",
        "floors": {"eq3": {"median": 20.0, "values": [10.0, 30.0]},
                   "ml": {"median": 1.0, "values": [1.0, 1.0]}}}


@pytest.mark.parametrize("bad, field", [
    ({**GOOD, "instances": 0}, "instances"),
    ({**GOOD, "instances": True}, "instances"),
    ({**GOOD, "chosen": "mle"}, "chosen"),
    ({**GOOD, "metric": ""}, "metric"),
    ({**GOOD, "floors": {"bogus": {"median": 1.0, "values": [1.0, 1.0]}}}, "floors"),
    ({**GOOD, "floors": {"eq3": {"median": float("nan"), "values": [1.0, 1.0]}}}, "floors"),
    ({**GOOD, "floors": {"eq3": {"median": 1.0, "values": [1.0]}}}, "floors"),
    ({**GOOD, "floors": {"eq3": {"median": -1.0, "values": [1.0, 1.0]}}}, "floors"),
    ({**GOOD, "floors": {}}, "floors"),
])
def test_a_bad_file_is_refused_naming_the_field(tmp_path, bad, field):
    path = tmp_path / "estimators.json"
    path.write_text(json.dumps(bad))
    data, why = read_estimator_floors(path)
    assert data is None and why.startswith(f"field {field}")


def test_unreadable_files_are_refused(tmp_path):
    path = tmp_path / "estimators.json"
    for text in ("not json", "[1, 2]", "x" * 300_000):
        path.write_text(text)
        assert read_estimator_floors(path)[0] is None
    good = tmp_path / "good.json"
    good.write_text(json.dumps(GOOD))
    assert read_estimator_floors(good)[0] == GOOD
    link = tmp_path / "link.json"
    link.symlink_to(good)
    assert read_estimator_floors(link) == (None, "not a regular file")


def test_the_report_names_each_floors_estimator_and_points_to_a_better_one(tmp_path, registry):
    """A job of lsq on the paper's problem under Eq. 3: its first screen says the records
    allow the floor under Eq. 3 and that the likelihood's optimum lies far closer; the
    identifiability section lists the floors of the four estimators."""
    problem = hydra_node(VehicleConfig, "vehicle")
    cfg = {"problem": problem, "optimizer": {"name": "lsq"}, "seed": 0, "runs": 3,
           "progress": False, "report": False}
    run_from_config(cfg, tmp_path / "job", registry)
    assert (tmp_path / "job" / "estimators.json").is_file()
    md = " ".join(build_report([tmp_path / "job"], tmp_path / "report", registry=registry,
                               short=True).report_md.read_text().split())
    assert "under the sum of channel norms of Eq. 3 (objective=eq3)" in md
    assert ("The estimator is the bottleneck: its floor is" in md
            and "problem.objective=ml (the Gaussian likelihood of the stated noise model) has "
                "its optimum a median" in md)
    assert "Floors per estimator: median NoRE of each estimator's optimum on the first 3" in md
