"""The vectorisable arc tangent and sine of the Magic Formula kernel (``ride/vecmath``)
against the C library's, over millions of points spread over every branch of their range
reductions, and at the special values; and the kernel that uses them: a candidate's outputs
are the same alone and in a batch of any size (the vector and the scalar loop agree)."""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from vpid_vehicle.ride import vecmath


@numba.njit(error_model="numpy")
def _ours(kind, x, out):  # pragma: no cover - compiled
    for i in range(x.size):
        out[i] = vecmath.atan(x[i]) if kind == 0 else vecmath.sin(x[i])


@numba.njit(error_model="numpy")
def _libm(kind, x, out):  # pragma: no cover - compiled
    for i in range(x.size):
        out[i] = math.atan(x[i]) if kind == 0 else math.sin(x[i])


def _both(kind: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.empty_like(x), np.empty_like(x)
    _ours(kind, x, a)
    _libm(kind, x, b)
    return a, b


def _ulps(got: np.ndarray, want: np.ndarray) -> float:
    return float(np.max(np.abs(got - want) / np.spacing(np.abs(want))))


def _signed(rng: np.random.Generator, magnitudes: np.ndarray) -> np.ndarray:
    return magnitudes * rng.choice([-1.0, 1.0], magnitudes.size)


def test_atan_is_within_one_ulp_of_the_c_library():
    """Uniform points on [-1, 1] and [-50, 50], log-spaced ones from 1e-12 to 1e12, and the
    branch edges 0.66 and tan(3 pi / 8) with their neighbours: at most 1 ulp apart."""
    rng = np.random.default_rng(0)
    edges = np.array([0.66, vecmath._T3P8])
    near = np.concatenate([np.nextafter(edges, 0), edges, np.nextafter(edges, np.inf)])
    x = np.concatenate([rng.uniform(-1, 1, 10**6), rng.uniform(-50, 50, 10**6),
                        _signed(rng, 10 ** rng.uniform(-12, 12, 10**6)), near, -near])
    got, want = _both(0, x)
    assert _ulps(got, want) <= 1.0


@pytest.mark.parametrize("low, high", [(-np.pi, np.pi), (-100.0, 100.0), (-2.0**30, 2.0**30)])
def test_sin_is_within_two_ulp_of_the_c_library(low, high):
    """Uniform points on [-pi, pi] (the Magic Formula's range), [-100, 100] and out to
    2**30, and log-spaced small ones: at most 2 ulp apart."""
    rng = np.random.default_rng(1)
    x = np.concatenate([rng.uniform(low, high, 10**6),
                        _signed(rng, 10 ** rng.uniform(-12, 0, 10**5))])
    got, want = _both(1, x)
    assert _ulps(got, want) <= 2.0


@pytest.mark.parametrize("kind", [0, 1])
def test_special_values_are_the_c_librarys(kind):
    """Signed zeros and subnormals keep their sign; atan(+-inf) = +-pi/2; sin(+-inf) and
    NaN give NaN (a NaN's sign bit is not compared: it carries no value)."""
    x = np.array([0.0, -0.0, np.inf, -np.inf, np.nan, 5e-324, -5e-324])
    got, want = _both(kind, x)
    assert np.array_equal(got, want, equal_nan=True)
    number = ~np.isnan(want)
    assert np.array_equal(np.signbit(got[number]), np.signbit(want[number]))


def test_a_candidate_is_the_same_alone_and_in_any_batch():
    """The Magic Formula model runs its candidates 4 at a time with a scalar remainder: a
    candidate's channels are bit-identical alone and in batches of 1 to 9."""
    from vpid_vehicle.ride.magic import LateralMFConfig, LateralMFProblem

    p = LateralMFProblem(LateralMFConfig(duration_s=1.0, sensors="yaw_ay_beta"))
    X = p.bounds.sample(np.random.default_rng(2), 9)
    alone = np.concatenate([p.model.simulate(x[None], p.known, "yaw_ay_beta", p.u,
                                             p.config.dt, "newmark") for x in X])
    for n in range(1, 10):
        batch = p.model.simulate(X[:n], p.known, "yaw_ay_beta", p.u, p.config.dt, "newmark")
        assert np.array_equal(batch, alone[:n])
