"""Intervals of an identified vector without a truth (vpid_bench/analysis/intervals.py) and
the profile likelihood started from an estimate, against the closed form of ordinary least
squares on a linear Gaussian model."""

from __future__ import annotations

import numpy as np
import pytest

from vpid_bench.analysis.intervals import Z95, group_sigma, jacobian_intervals
from vpid_bench.analysis.profile import ProfileTooSlowError, profile_intervals
from vpid_bench.api import Bounds, Problem


class Linear(Problem):
    """``y = A θ + e`` with no truth told: residuals ``y - A θ`` (groups as given)."""

    name = "linear_no_truth"

    def __init__(self, A, y, lo, hi, groups=None):
        super().__init__(Problem.Config())
        self.A, self.y = A, y
        self.groups = np.zeros(y.size, int) if groups is None else groups
        self._bounds = Bounds(lo, hi, tuple(f"p{j}" for j in range(A.shape[1])))

    @property
    def bounds(self):
        return self._bounds

    def residuals(self, X):
        return self.y[None] - np.atleast_2d(X) @ self.A.T

    def residual_groups(self):
        return self.groups.copy()

    def evaluate(self, X):
        return np.sum(self.residuals(X) ** 2, axis=1)


def _case(seed=0, m=120, sigma=0.3):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, 3)) @ np.diag([1.0, 4.0, 0.3])
    theta = np.array([2.0, -0.5, 7.0])
    y = A @ theta + sigma * rng.standard_normal(m)
    return Linear(A, y, theta - 50, theta + 50), A, y


def test_jacobian_intervals_are_the_ordinary_least_squares_intervals():
    """θ̂ ± 1.96 sqrt(s² (AᵀA)⁻¹_jj) with s² = RSS / (m − d), the textbook form."""
    p, A, y = _case()
    theta_hat = np.linalg.lstsq(A, y, rcond=None)[0]
    rss = float(np.sum((y - A @ theta_hat) ** 2))
    s2 = rss / (y.size - 3)
    half = Z95 * np.sqrt(s2 * np.diag(np.linalg.inv(A.T @ A)))
    out = jacobian_intervals(p, theta_hat)
    np.testing.assert_allclose(out["lower"], theta_hat - half, rtol=0, atol=1e-6 * half.min())
    np.testing.assert_allclose(out["upper"], theta_hat + half, rtol=0, atol=1e-6 * half.min())
    np.testing.assert_allclose(out["sigma"], [np.sqrt(s2)], rtol=1e-12)
    assert out["dof"] == y.size - 3 and out["level"] == 0.95


def test_the_intervals_cover_the_truth_about_95_percent_of_the_time():
    """Over 400 records of the linear model the interval of θ1 holds the truth in 95 % ±
    3.5 sd of a binomial proportion (0.95 ± 0.038)."""
    hits = 0
    for seed in range(400):
        p, A, y = _case(seed)
        theta_hat = np.linalg.lstsq(A, y, rcond=None)[0]
        out = jacobian_intervals(p, theta_hat)
        hits += out["lower"][1] <= -0.5 <= out["upper"][1]
    assert abs(hits / 400 - 0.95) < 3.5 * np.sqrt(0.95 * 0.05 / 400)


def test_sigma_is_estimated_per_group():
    """Two channels with noise 0.1 and 1.0: each group's σ̂ is its own (within 15 %)."""
    rng = np.random.default_rng(1)
    A = rng.standard_normal((2000, 2))
    theta = np.array([1.0, 2.0])
    groups = np.repeat([0, 1], 1000)
    y = A @ theta + np.where(groups == 0, 0.1, 1.0) * rng.standard_normal(2000)
    p = Linear(A, y, theta - 5, theta + 5, groups)
    sigma = group_sigma(p.residuals(theta[None])[0], groups, 2)
    np.testing.assert_allclose(sigma, [0.1, 1.0], rtol=0.15)
    out = jacobian_intervals(p, theta)
    np.testing.assert_allclose(out["sigma"], sigma, rtol=1e-12)


def test_a_parameter_the_record_cannot_see_gets_an_unbounded_interval():
    p, A, y = _case()
    A2 = A.copy()
    A2[:, 1] = A2[:, 0]  # only θ0 + θ1 is seen
    p = Linear(A2, y, np.full(3, -50.0), np.full(3, 50.0))
    out = jacobian_intervals(p, np.array([1.0, 1.0, 7.0]))
    assert out["lower"][0] is None and out["upper"][1] is None and out["se"][0] is None
    assert out["lower"][2] is not None


def test_profile_from_an_estimate_equals_the_jacobian_interval_on_a_linear_model():
    """Started at θ̂ with σ estimated from the residuals, the profile's 95 % interval is the
    Jacobian interval (both use 1.96 / χ²(0.95, 1) = 3.84) to 1e-5 of the half-width."""
    p, A, y = _case()
    theta_hat = np.linalg.lstsq(A, y, rcond=None)[0]
    jac = jacobian_intervals(p, theta_hat)
    out = profile_intervals(p, start=theta_hat, sigma=np.array(jac["sigma"]),
                            rel_sd=np.array(jac["se"]) / np.abs(theta_hat))
    half = np.array(jac["upper"]) - theta_hat
    np.testing.assert_allclose(out["lower"], jac["lower"], rtol=0, atol=1e-5 * half.min())
    np.testing.assert_allclose(out["upper"], jac["upper"], rtol=0, atol=1e-5 * half.min())
    assert out["classification"] == ["identifiable"] * 3


def test_a_profile_that_would_take_too_long_is_refused_before_it_runs():
    p, A, y = _case()
    theta_hat = np.linalg.lstsq(A, y, rcond=None)[0]
    with pytest.raises(ProfileTooSlowError, match="would take about"):
        profile_intervals(p, start=theta_hat, sigma=np.array([0.3]), limit_s=1e-9)
