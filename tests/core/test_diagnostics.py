"""Fit diagnostics (vpid_bench/analysis/diagnostics.py) and the HAC interval beside the
Jacobian one (vpid_bench/analysis/intervals.py), against independent references: statsmodels'
Ljung-Box and Newey-West, closed forms of an AR(1), and Monte Carlo coverage on a linear
model with correlated errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vpid_bench.analysis.diagnostics import (
    Z99,
    acf,
    ccf,
    fit_diagnostics,
    ljung_box,
    second_difference_sigma,
)
from vpid_bench.analysis.intervals import (
    Z95,
    andrews_lags,
    hac_covariance,
    jacobian_intervals,
)
from vpid_bench.api import Bounds, Problem


def _ar1(rng, n, rho, sigma=1.0):
    e = rng.standard_normal(n) * sigma * math.sqrt(1 - rho**2)
    out = np.empty(n)
    out[0] = rng.standard_normal() * sigma
    for t in range(1, n):
        out[t] = rho * out[t - 1] + e[t]
    return out


def test_ljung_box_is_statsmodels():
    sm = pytest.importorskip("statsmodels.stats.diagnostic")
    r = _ar1(np.random.default_rng(1), 400, 0.3)
    q, p = ljung_box(r, 10)
    ref = sm.acorr_ljungbox(r, lags=[10])
    assert q == pytest.approx(float(ref["lb_stat"].iloc[0]), rel=1e-10)
    assert p == pytest.approx(float(ref["lb_pvalue"].iloc[0]), rel=1e-8)


def test_acf_and_ccf_are_statsmodels():
    st = pytest.importorskip("statsmodels.tsa.stattools")
    rng = np.random.default_rng(2)
    r, u = _ar1(rng, 300, 0.5), rng.standard_normal(300)
    np.testing.assert_allclose(acf(r, 12), st.acf(r, nlags=12, fft=False), atol=1e-12)
    # statsmodels' ccf(x, y)[k] = corr(x_{t+k}, y_t): ours at lag +k (r_t against u_{t-k})
    c = ccf(r, u, 5)
    np.testing.assert_allclose(c[5:], st.ccf(r, u, adjusted=False, fft=False)[:6], atol=1e-12)


def test_white_residuals_are_not_flagged_and_the_stated_sigma_is_read():
    rng = np.random.default_rng(3)
    n = 2000
    signal = np.sin(np.linspace(0, 20, n)) * 5
    r = 0.2 * rng.standard_normal(n)
    out = fit_diagnostics(r, np.zeros(n, int), measured=signal, sigma=[0.2],
                          inputs={"u": signal}, names=["y"])
    g = out["groups"][0]
    assert out["explained"] and not g["correlated"] and not g["input_correlated"]
    assert g["name"] == "y" and g["sigma_source"] == "stated"
    assert g["rms_over_sigma"] == pytest.approx(1.0, abs=0.05)
    assert g["rms_over_signal"] == pytest.approx(0.2 / (5 / math.sqrt(2)), rel=0.06)
    assert abs(g["lag1"]) < Z99 / math.sqrt(n) and g["band99"] == pytest.approx(Z99 / math.sqrt(n))
    json.dumps(out)  # JSON-able


def test_correlated_residuals_are_flagged_with_their_lag1_and_a_misfit_beyond_the_noise():
    """An AR(1) misfit (ρ = 0.95) on white noise: lag 1 near its closed form
    ρ var_ar / (var_ar + σ²), the whiteness test rejects, and the noise sigma estimated from
    second differences finds the white part (the misfit is smooth at the sampling scale)."""
    rng = np.random.default_rng(4)
    n = 5000
    misfit, noise = _ar1(rng, n, 0.95, 1.0), 0.1 * rng.standard_normal(n)
    out = fit_diagnostics(misfit + noise, np.zeros(n, int))
    g = out["groups"][0]
    assert not out["explained"] and g["correlated"] and g["ljung_box_p"] < 1e-10
    assert g["lag1"] == pytest.approx(0.95 / 1.01, abs=0.02)
    assert g["sigma_source"] == "estimated" and g["misfit"]
    # var(Δ² ar1) = 6 - 8ρ + 2ρ² (unit variance), var(Δ² white) = 6 σ²: the estimate is
    # sqrt of their sum over 6, 0.21, against the residual's rms of ~1
    rho, s2 = 0.95, 0.01
    assert g["sigma"] == pytest.approx(math.sqrt((6 - 8 * rho + 2 * rho**2 + 6 * s2) / 6),
                                       rel=0.1)
    assert g["rms_over_sigma"] > 4


def test_second_difference_sigma_of_white_noise():
    r = np.random.default_rng(5).standard_normal(20000) * 0.3
    assert second_difference_sigma(r) == pytest.approx(0.3, rel=0.02)


def test_residuals_that_follow_an_input_are_flagged_by_the_cross_correlation():
    """Residuals holding 0.5 u_{t-3} of a white input: the cross-correlation peaks at lag 3
    outside the band; a smooth input with white residuals stays inside its (Bartlett) band."""
    rng = np.random.default_rng(6)
    n = 3000
    u = rng.standard_normal(n)
    r = 0.5 * np.r_[np.zeros(3), u[:-3]] + rng.standard_normal(n)
    c = fit_diagnostics(r, np.zeros(n, int), inputs={"u": u})["groups"][0]["cross"]["u"]
    assert c["lag_at_max"] == 3 and c["max_abs"] > c["band99"]
    smooth = np.cumsum(rng.standard_normal(n))
    hits = [fit_diagnostics(rng.standard_normal(n), np.zeros(n, int), inputs={"u": smooth})
            ["groups"][0]["input_correlated"] for _ in range(20)]
    assert sum(hits) <= 2  # at 99 % per lag and a 10 % share, rarely


def test_groups_are_diagnosed_apart_and_held_out_error_beside_the_naive_one():
    rng = np.random.default_rng(7)
    r = np.r_[rng.standard_normal(500), _ar1(rng, 500, 0.9)]
    out = fit_diagnostics(r, np.repeat([0, 1], 500), names=["a", "b"],
                          held_out={"error": 1.0, "naive": 4.0})
    assert [g["name"] for g in out["groups"]] == ["a", "b"]
    assert not out["groups"][0]["correlated"] and out["groups"][1]["correlated"]
    assert out["held_out"] == {"error": 1.0, "naive": 4.0, "ratio": 0.25, "unit": ""}
    with pytest.raises(ValueError, match="shape"):
        fit_diagnostics(r, np.zeros(3, int))


def test_hac_covariance_is_statsmodels_newey_west():
    """The meat of a sandwich at a fixed lag count is statsmodels' HAC estimate (Bartlett
    kernel, no small-sample correction, not demeaned): ``S_hac_simple``."""
    sw = pytest.importorskip("statsmodels.stats.sandwich_covariance")
    rng = np.random.default_rng(8)
    n = 600
    scores = np.c_[_ar1(rng, n, 0.7), _ar1(rng, n, 0.3)]
    B, lags = hac_covariance(scores, np.zeros(n, int), lags=9, prewhiten=False)
    ref = sw.S_hac_simple(scores, nlags=9)
    assert lags == 9
    np.testing.assert_allclose(B, ref, rtol=1e-9)


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.9, 0.95])
def test_the_prewhitened_hac_recovers_an_ar1s_long_run_variance(rho):
    """The long-run variance of an AR(1) of unit variance is ``(1 + rho) / (1 - rho)`` per
    point: the prewhitened estimate (VAR(1), then Bartlett with Andrews' bandwidth,
    recoloured) recovers it within 8 % on average over 20 series of 10,000 points; the
    plain Bartlett estimate falls short as the persistence grows (at rho = 0.95 by more than
    8 %: its kernel downweights the lags that carry it)."""
    rng = np.random.default_rng(11)
    n, truth = 10_000, (1 + rho) / (1 - rho)
    pre, plain = [], []
    for _ in range(20):
        s = _ar1(rng, n, rho)[:, None]
        pre.append(hac_covariance(s, np.zeros(n, int))[0][0, 0] / n)
        plain.append(hac_covariance(s, np.zeros(n, int), prewhiten=False)[0][0, 0] / n)
    assert np.mean(pre) / truth == pytest.approx(1.0, abs=0.08)
    if rho >= 0.95:
        assert np.mean(plain) / truth < 0.92


def test_the_prewhitening_caps_the_persistence():
    """A random walk (rho = 1) would make ``(I - Phi)^-1`` infinite: the VAR(1)'s singular
    values are capped at MAX_AR, so the estimate is finite."""
    from vpid_bench.analysis.intervals import MAX_AR, var1

    walk = np.cumsum(np.random.default_rng(12).standard_normal((5000, 2)), axis=0)
    assert np.linalg.svd(var1(walk), compute_uv=False).max() <= MAX_AR + 1e-12
    B, _ = hac_covariance(walk, np.zeros(5000, int))
    assert np.all(np.isfinite(B))


def test_andrews_lags_grow_with_the_correlation():
    assert andrews_lags(0.0, 10000) == 1
    assert andrews_lags(0.5, 10000) < andrews_lags(0.95, 10000) <= 2500
    assert andrews_lags(0.95, 10000) == math.ceil(
        1.1447 * (4 * 0.95**2 / (0.05**2 * 1.95**2) * 10000) ** (1 / 3))


class _Line(Problem):
    """``y = a + b t + e``: residuals ``y - a - b t`` in time order, no truth told."""

    name = "line"

    def __init__(self, y):
        super().__init__(Problem.Config())
        self.y = y
        self.t = np.linspace(-1, 1, y.size)

    @property
    def bounds(self):
        return Bounds(np.array([-50.0, -50.0]), np.array([50.0, 50.0]), ("a", "b"))

    def residuals(self, X):
        X = np.atleast_2d(X)
        return self.y[None] - X[:, :1] - X[:, 1:] * self.t[None]

    def evaluate(self, X):
        return np.sum(self.residuals(X) ** 2, axis=1)


def _fit(y):
    t = np.linspace(-1, 1, y.size)
    A = np.c_[np.ones_like(t), t]
    return np.linalg.lstsq(A, y, rcond=None)[0]


def test_the_robust_interval_equals_the_white_one_on_white_residuals():
    y = 1.0 + 2.0 * np.linspace(-1, 1, 4000) + np.random.default_rng(9).standard_normal(4000)
    out = jacobian_intervals(_Line(y), _fit(y))
    ratio = np.array(out["robust"]["se"]) / np.array(out["se"])
    assert out["assumes"] == "white residuals" and out["robust"]["method"] == "hac"
    np.testing.assert_allclose(ratio, 1.0, atol=0.15)


def test_the_robust_interval_covers_with_ar1_errors_where_the_white_one_does_not():
    """A line fitted through AR(1) errors (ρ = 0.9): over 60 records the HAC interval covers
    the true line at >= 80 % (nominal 95 %); the white-noise one far less (its half-width is
    about sqrt((1-ρ)/(1+ρ)) = 0.23 of the right one for the mean)."""
    rng = np.random.default_rng(10)
    n, truth = 1000, np.array([1.0, 2.0])
    t = np.linspace(-1, 1, n)
    white = robust = 0
    runs, widths = 60, []
    for _ in range(runs):
        y = truth[0] + truth[1] * t + _ar1(rng, n, 0.9)
        x = _fit(y)
        out = jacobian_intervals(_Line(y), x)
        lo, hi = np.array(out["lower"]), np.array(out["upper"])
        rlo, rhi = np.array(out["robust"]["lower"]), np.array(out["robust"]["upper"])
        white += lo[0] <= truth[0] <= hi[0]
        robust += rlo[0] <= truth[0] <= rhi[0]
        widths.append((rhi[0] - rlo[0]) / (hi[0] - lo[0]))
    assert robust / runs >= 0.8 and white / runs <= 0.6, (robust, white)
    assert np.median(widths) >= 2.5
    assert Z95 > 1.95


def test_the_hac_convolution_is_scipys_same_mode_convolution():
    """The Bartlett-weighted sum of the HAC estimate by numpy's FFT equals scipy's
    ``fftconvolve(mode="same")`` (to 1e-12), for short and long records and any bandwidth."""
    from scipy.signal import fftconvolve

    from vpid_bench.analysis.intervals import _convolve_same

    rng = np.random.default_rng(3)
    for t, lags in [(2, 1), (5, 1), (100, 7), (1001, 40), (4096, 250)]:
        S = rng.normal(size=(t, 3))
        w = 1.0 - np.abs(np.arange(-lags, lags + 1)) / (lags + 1)
        np.testing.assert_allclose(_convolve_same(S, w),
                                   fftconvolve(S, w[:, None], mode="same", axes=0),
                                   rtol=0, atol=1e-12 * max(1.0, float(np.abs(S).sum())))
