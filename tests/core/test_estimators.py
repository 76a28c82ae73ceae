"""The estimator as a choice (``problem.objective``): each objective's value is the stated
function of its own residuals, the bound belongs to the data (the same Cramér–Rao bound under
every objective), and on the paper's problem the likelihood reaches what the data allow where
Eq. 3 does not (the review's finding, measured here on 8 instances)."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.problem import VehicleProblem
from vpid_vehicle.ride.lateral import LateralConfig, LateralProblem
from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

from vpid_bench import ConfigError, estimators
from vpid_bench.analysis.identifiability import cramer_rao
from vpid_bench.analysis.optimum import polish


def _vehicle(objective: str, **noise) -> VehicleProblem:
    cfg = VehicleConfig(objective=objective)
    if noise:
        from dataclasses import replace
        cfg = replace(cfg, noise=replace(cfg.noise, **noise))
    return VehicleProblem(cfg)


PROBLEMS = {
    "vehicle": _vehicle,
    "ride_quarter": lambda o: RideQuarterProblem(RideQuarterConfig(objective=o)),
    "lateral": lambda o: LateralProblem(LateralConfig(objective=o, sensors="yaw_ay_beta")),
}


@pytest.mark.parametrize("name", PROBLEMS)
@pytest.mark.parametrize("objective", estimators.OBJECTIVES)
def test_each_objective_is_the_stated_function_of_its_residuals(name, objective):
    """eq3: the sum of the channel norms of the residuals; ols: their sum of squares; ml:
    half their mean square; the groups are the channels for eq3 and one group otherwise."""
    p = PROBLEMS[name](objective)
    rng = np.random.default_rng(1)
    X = p.bounds.lower + rng.random((5, p.bounds.dim)) * p.bounds.width
    f, R = p.evaluate_with_residuals(X)
    np.testing.assert_allclose(p.evaluate(X), f, rtol=1e-12)
    np.testing.assert_allclose(p.residuals(X), R, rtol=1e-12)
    groups = p.residual_groups()
    channels = [R[:, groups == g] for g in range(groups.max() + 1)]
    if objective == "eq3":
        expected = sum(np.linalg.norm(c, axis=1) for c in channels)
        if name == "vehicle":  # the paper's Eq. 3: one denominator, the sum of the norms
            expected = expected / np.linalg.norm(p.reference, axis=1).sum()
        assert groups.max() + 1 == len(p.signal_units()) if name == "vehicle" else True
    elif objective == "ols":
        expected = np.sum(R**2, axis=1)
        assert np.all(groups == 0)
    else:
        expected = 0.5 * np.mean(R**2, axis=1)
        assert np.all(groups == 0)
    np.testing.assert_allclose(f, expected, rtol=1e-10)


@pytest.mark.parametrize("name", PROBLEMS)
def test_the_bound_belongs_to_the_data_not_to_the_objective(name):
    """The Cramér–Rao bound is computed for the simulated noise in each objective's residual
    units; it is the same under every objective (to the central differences' 1e-5)."""
    bounds = [cramer_rao(PROBLEMS[name](o))["crb_percent"] for o in estimators.OBJECTIVES]
    for other in bounds[1:]:
        np.testing.assert_allclose(other, bounds[0], rtol=1e-5)


def test_ml_weighs_by_the_noise_models_sigma_plugged_in_from_the_record():
    """Multiplicative noise: each residual over level |y_k|, floored at SIGMA_FLOOR x level x
    rms(y_c); at the truth the weighted residuals are about standard normal (their mean
    square over 20 instances 1 within 5 %; its standard error is 1.5 %)."""
    p = _vehicle("ml")
    level = p.config.noise.level
    sigma = estimators.plug_in_sigma(p.reference, level, "multiplicative")
    rms = np.sqrt(np.mean(p.reference**2, axis=1, keepdims=True))
    np.testing.assert_allclose(sigma, np.maximum(level * np.abs(p.reference),
                                                 estimators.SIGMA_FLOOR * level * rms))
    moving = np.abs(p.reference_clean.reshape(-1)) > 0
    r = np.concatenate([p.instance(i).residuals(p.x_true[None])[0][moving] for i in range(20)])
    assert np.mean(r**2) == pytest.approx(1.0, rel=0.05)


def test_bad_objectives_are_refused_naming_the_key():
    with pytest.raises(ConfigError) as err:
        VehicleConfig(objective="mle")
    assert err.value.key == "problem.objective" and "eq3, ols, ml" in str(err.value)
    with pytest.raises(ConfigError) as err:
        RideQuarterConfig(objective="ml", noise_level=0.0)
    assert err.value.key == "problem.objective" and "noise level is 0" in str(err.value)
    assert RideQuarterConfig(objective="ols", noise_level=0.0).objective == "ols"


def test_on_the_papers_problem_the_likelihood_reaches_what_the_data_allow():
    """8 instances of the paper's problem (multiplicative noise, 5 %): the optimum of the
    likelihood lies a median under 3 x the Cramér–Rao norm from the truth, the optimum of
    Eq. 3 over 5 x farther than the likelihood's (measured: about 0.8 % against 27 %)."""
    floors = {}
    for objective in ("eq3", "ml"):
        p = _vehicle(objective)
        nores = [p.instance(i).metrics(polish(p.instance(i), p.x_true)[0])["NoRE"]
                 for i in range(8)]
        floors[objective] = float(np.median(nores))
    crb = cramer_rao(_vehicle("ml"))["crb_norm_percent"]
    assert floors["ml"] < 3 * crb, (floors, crb)
    assert floors["eq3"] > 5 * floors["ml"], floors
