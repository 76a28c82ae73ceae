"""Cramér–Rao bounds against a linear model, where they are known in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from vpid_bench.analysis.identifiability import cramer_rao
from vpid_bench.api import Bounds, Problem


class LinearModel(Problem):
    """``y = A θ + e``, e ~ N(0, σ_g²) in residual group g; the residuals are ``y - A θ``."""

    name = "linear"

    def __init__(self, A: np.ndarray, theta: np.ndarray, groups: np.ndarray,
                 sigma: np.ndarray, rng: np.random.Generator) -> None:
        super().__init__(Problem.Config())
        self.A, self.theta = A, theta
        self.groups, self.sigma = groups, sigma
        self.y = A @ theta + sigma[groups] * rng.standard_normal(A.shape[0])
        self._bounds = Bounds(theta - 2 * np.abs(theta), theta + 2 * np.abs(theta),
                              tuple(f"p{j}" for j in range(theta.size)))

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    @property
    def x_true(self) -> np.ndarray:
        return self.theta.copy()

    def residuals(self, X: np.ndarray) -> np.ndarray:
        return self.y[None] - np.atleast_2d(X) @ self.A.T

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return np.sum(self.residuals(X) ** 2, axis=1)

    def residual_groups(self) -> np.ndarray:
        return self.groups.copy()

    def residual_sigma(self) -> np.ndarray:
        return self.sigma.copy()


def _model(sigma: tuple[float, ...]) -> LinearModel:
    rng = np.random.default_rng(11)
    m, d = 60, 4
    A = rng.standard_normal((m, d)) @ np.diag([1.0, 3.0, 0.2, 10.0])
    theta = np.array([2.0, -0.5, 7.0, 0.03])
    groups = np.arange(m) * len(sigma) // m
    return LinearModel(A, theta, groups, np.asarray(sigma, float), rng)


@pytest.mark.parametrize("sigma", [(0.3,), (0.1, 2.5)])
def test_crb_is_sigma2_inverse_gram_for_a_linear_model(sigma):
    """cov = (Aᵀ Σ⁻¹ A)⁻¹ (= σ² (AᵀA)⁻¹ for one σ); the bounds in percent of |θ|, their norm,
    and the singular values of Σ^-1/2 A diag(θ), to 1e-6 relative (the central differences
    of a linear map are exact up to rounding, about 1e-9 relative here)."""
    p = _model(sigma)
    out = cramer_rao(p)
    W = p.A / p.sigma[p.groups][:, None]
    cov = np.linalg.inv(W.T @ W)
    if len(sigma) == 1:
        np.testing.assert_allclose(cov, sigma[0] ** 2 * np.linalg.inv(p.A.T @ p.A), rtol=1e-12)
    expected = 100 * np.sqrt(np.diag(cov)) / np.abs(p.theta)
    np.testing.assert_allclose(out["crb_percent"], expected, rtol=1e-6)
    assert out["crb_norm_percent"] == pytest.approx(np.linalg.norm(expected), rel=1e-6)
    s = np.linalg.svd(W * p.theta, compute_uv=False)
    np.testing.assert_allclose(out["singular_values"], s, rtol=1e-6)
    assert out["condition_number"] == pytest.approx(s[0] / s[-1], rel=1e-6)
    assert out["names"] == ["p0", "p1", "p2", "p3"] and out["sigma"] == list(sigma)


def test_the_bound_is_the_spread_of_least_squares_estimates():
    """An independent check of the convention: the relative spread of the least-squares
    estimates over 2000 noise draws matches the bound (within 8 %, the sampling error of a
    standard deviation over 2000 draws is about 1.6 %)."""
    p = _model((0.1, 2.5))
    bound = np.asarray(cramer_rao(p)["crb_percent"])
    rng = np.random.default_rng(5)
    W = p.A / p.sigma[p.groups][:, None]
    clean = p.A @ p.theta
    est = []
    for _ in range(2000):
        y = clean + p.sigma[p.groups] * rng.standard_normal(clean.size)
        est.append(np.linalg.lstsq(W, y / p.sigma[p.groups], rcond=None)[0])
    spread = 100 * np.std(est, axis=0) / np.abs(p.theta)
    np.testing.assert_allclose(spread, bound, rtol=0.08)


def test_no_bound_without_truth_or_noise():
    p = _model((0.3,))
    p.residual_sigma = lambda: None  # a measured record: the noise is unknown
    assert cramer_rao(p) is None
    q = _model((0.0,))
    assert cramer_rao(q) is None


class PerEntryModel(LinearModel):
    """The linear model with a sigma per entry (noise whose size varies along the record)."""

    def __init__(self, sigma_entries: np.ndarray) -> None:
        rng = np.random.default_rng(4)
        m, d = 80, 3
        A = rng.standard_normal((m, d))
        super().__init__(A, np.array([1.5, -2.0, 0.7]), np.arange(m) * 2 // m,
                         np.ones(2), rng)
        self.entry_sigma = np.asarray(sigma_entries, float)

    def residual_sigma(self) -> np.ndarray:
        return self.entry_sigma.copy()


def _bound(A: np.ndarray, sigma: np.ndarray, theta: np.ndarray) -> np.ndarray:
    W = A / sigma[:, None]
    return 100 * np.sqrt(np.diag(np.linalg.inv(W.T @ W))) / np.abs(theta)


def test_rounding_level_entries_are_left_out():
    """An entry whose sigma is at most 1e-12 of its group's largest (here 1e-16 of it: the
    noise of a value that is zero in exact arithmetic) is left out, like an entry with sigma
    0; kept, it would dominate the information (the trace of the Fisher information grows by
    more than 1e20: the check has teeth)."""
    sigma = np.linspace(0.5, 2.0, 80)
    sigma[5], sigma[60] = 1e-16, 0.0
    p = PerEntryModel(sigma)
    out = cramer_rao(p)
    keep = np.ones(80, bool)
    keep[[5, 60]] = False
    np.testing.assert_allclose(out["crb_percent"], _bound(p.A[keep], sigma[keep], p.theta),
                               rtol=1e-6)
    assert out["excluded_entries"] == 2
    without = np.sum((p.A[keep] / sigma[keep][:, None]) ** 2)
    keep[5] = True
    assert np.sum((p.A[keep] / sigma[keep][:, None]) ** 2) > 1e20 * without


def test_the_bounds_sensitivity_to_a_sigma_floor():
    """Where sigma varies along a group, the bound again with each sigma floored at 0, 1e-3
    and 1e-2 of its group's rms sigma (computed here directly); the floor raises it. Absent
    where sigma is one per group (it cannot change the bound)."""
    sigma = np.tile(np.geomspace(1e-5, 1.0, 40), 2)
    p = PerEntryModel(sigma)
    out = cramer_rao(p)
    groups = p.groups
    rms = np.array([np.sqrt(np.mean(sigma[groups == g] ** 2)) for g in (0, 1)])[groups]
    found = out["sigma_floor_sensitivity"]
    assert [s["fraction"] for s in found] == [0.0, 1e-3, 1e-2]
    for s in found:
        expected = _bound(p.A, np.maximum(sigma, s["fraction"] * rms), p.theta)
        np.testing.assert_allclose(s["crb_percent"], expected, rtol=1e-6)
        assert s["crb_norm_percent"] == pytest.approx(np.linalg.norm(expected), rel=1e-6)
    norms = [s["crb_norm_percent"] for s in found]
    assert norms[0] == pytest.approx(out["crb_norm_percent"]) and norms[0] < norms[1] < norms[2]
    assert "sigma_floor_sensitivity" not in cramer_rao(_model((0.1, 2.5)))
