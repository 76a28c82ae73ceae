"""The structure-of-arrays Newmark kernel against the plain numpy Newmark, and its promise that
a candidate's result does not depend on its batch, lane, chunk or thread count."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_vehicle import kernel, newmark
from vpid_vehicle.config import PARAM_NAMES, VehicleConfig, window
from vpid_vehicle.model import KnownConstants
from vpid_vehicle.objective import objective
from vpid_vehicle.problem import VehicleProblem
from vpid_vehicle.road import Bump, sample, time_grid

from vpid_bench.api import ConfigError

CFG = VehicleConfig()
P = CFG.vehicle
KNOWN = KnownConstants(P.L, P.kt1, P.kt2)
BUMP = Bump.from_geometry(CFG.bump.V, CFG.bump.h, CFG.bump.w, P.L)
T = window(CFG)
X_TRUE = np.array([[getattr(P, n) for n in PARAM_NAMES]])
DT = 1e-3


def population(seed: int, n: int) -> np.ndarray:
    """n candidates spread over the default search box (0.5 ... 1.5 x the truth)."""
    return X_TRUE * np.random.default_rng(seed).uniform(0.5, 1.5, (n, 9))


def setup(mode: str = "point", gamma: float = 0.5, beta: float = 0.25, extra: float = 0.0):
    y = sample(BUMP, time_grid(T + extra, DT), mode, gamma)
    return kernel.Setup(P.L, P.kt1, P.kt2, y, DT, gamma, beta), y


# gamma, beta over the allowed box: corners, the default, a dissipative pair, explicit beta = 0.
SCHEMES = [(0.5, 0.25), (0.5, 0.0), (0.6, 0.3025), (1.0, 0.5), (1.0, 0.0), (0.75, 0.1)]


@pytest.mark.parametrize("mode", ["point", "average"])
@pytest.mark.parametrize(("gamma", "beta"), SCHEMES)
def test_responses_equal_plain_newmark(mode, gamma, beta):
    """z1'', z2'' of 11 candidates (not a multiple of the lane count) over the paper's window
    plus 0.3 s agree with the step-by-step numpy Newmark to 1e-10 of the largest acceleration
    (the recurrence is the same scheme, rearranged; only rounding may differ)."""
    s, y = setup(mode, gamma, beta, extra=0.3)
    X = population(3, 11)
    fast = s.responses(X)
    plain = newmark.body_accelerations(X, KNOWN, y, DT, gamma, beta)
    assert np.all(np.isfinite(plain))
    assert np.abs(fast - plain).max() <= 1e-10 * np.abs(plain).max()


@pytest.mark.parametrize("mode", ["point", "average"])
@pytest.mark.parametrize(("gamma", "beta"), [(0.5, 0.25), (0.6, 0.3025), (1.0, 0.0)])
def test_fused_objective_equals_numpy_objective(mode, gamma, beta):
    """Eq. (3) accumulated inside the kernel equals Eq. (3) computed in numpy on the plain
    Newmark's responses to 1e-10 relative; non-physical rows (m < 0, a1 > L, NaN) give inf."""
    s, y = setup(mode, gamma, beta)
    X = population(4, 9)
    X[6, 0] = -1.0
    X[7, 8] = P.L + 0.1
    X[8, 3] = np.nan
    ref = newmark.body_accelerations(X_TRUE, KNOWN, y, DT, gamma, beta)[0]
    ref = ref * (1 + 0.05 * np.random.default_rng(0).standard_normal(ref.shape))
    fused = s.objective(X, ref)
    plain = objective(newmark.body_accelerations(X[:6], KNOWN, y, DT, gamma, beta), ref)
    np.testing.assert_allclose(fused[:6], plain, rtol=1e-10, atol=0)
    assert np.all(np.isinf(fused[6:]))
    resp = s.responses(X)
    assert np.all(np.isnan(resp[6:])) and np.all(np.isfinite(resp[:6]))


def test_objective_is_zero_against_its_own_responses():
    """The objective and the stored responses share one step routine: a reference made by
    ``responses`` gives exactly f = 0 for the same candidate."""
    s, _ = setup("average")
    X = population(5, 6)
    ref = s.responses(X[2:3])[0]
    f = s.objective(X, ref)
    assert f[2] == 0.0 and np.all(f[[0, 1, 3, 4, 5]] > 0)


def test_result_does_not_depend_on_batch_or_lane():
    """Each candidate is computed alone: the same bits whether evaluated alone, in any lane of
    a batch, shuffled, or next to a non-physical or diverging candidate."""
    s, _ = setup("point")
    X = population(6, 13)
    X[4, 4] = 1e12  # a stiff spring: finite but extreme
    ref = s.responses(X_TRUE)[0]
    f_batch = s.objective(X, ref)
    f_alone = np.array([s.objective(X[i : i + 1], ref)[0] for i in range(len(X))])
    assert np.array_equal(f_batch, f_alone)
    perm = np.random.default_rng(1).permutation(len(X))
    assert np.array_equal(s.objective(X[perm], ref), f_batch[perm])
    R = s.responses(X)
    assert np.array_equal(s.responses(X[perm]), R[perm], equal_nan=True)
    assert np.array_equal(s.responses(X[5:6])[0], R[5])


def test_diverging_candidate_gets_inf():
    """Explicit Newmark (beta = 0) is only conditionally stable: a front suspension of 1e9 N/m
    (wheel mode omega dt ~ 6 > 2) blows up and gets f = inf, while its lane neighbours keep
    their values."""
    s, _ = setup("point", 0.5, 0.0)
    X = np.repeat(X_TRUE, 4, axis=0)
    X[1, 4] = 1e9
    ref = s.responses(X_TRUE)[0]
    f = s.objective(X, ref)
    assert np.isinf(f[1]) and np.all(f[[0, 2, 3]] == 0.0)
    assert not np.all(np.isfinite(s.responses(X[1:2])))


def test_chunks_cover_the_batch():
    """Ranges are contiguous, cover [0, n), at most `threads` of them, none smaller than
    MIN_PER_THREAD, and a small batch stays in one piece."""
    m = kernel.MIN_PER_THREAD
    assert kernel.chunks(m - 1, 8) == [(0, m - 1)]
    assert kernel.chunks(20, 2) == [(0, 20)]
    for n, threads in [(2 * m, 2), (7 * m + 5, 3), (5 * m, 8), (3 * m, 1)]:
        parts = kernel.chunks(n, threads)
        assert parts[0][0] == 0 and parts[-1][1] == n
        assert all(a[1] == b[0] for a, b in zip(parts, parts[1:]))
        assert len(parts) == min(threads, n // m)
        assert all(b - a >= m for a, b in parts)


@pytest.mark.parametrize("threads", [2, 3])
def test_threads_give_identical_arrays(threads, monkeypatch):
    """1 thread against 2 and 3 threads (chunks forced small so the batch really is split):
    bit-identical objective values and responses."""
    monkeypatch.setattr(kernel, "MIN_PER_THREAD", 4)
    s, _ = setup("average")
    X = population(7, 23)
    X[10, 0] = -1.0
    assert len(kernel.chunks(len(X), threads)) == threads
    ref = s.responses(X_TRUE)[0] * 1.01
    assert np.array_equal(s.objective(X, ref, threads), s.objective(X, ref, 1))
    assert np.array_equal(s.responses(X, threads), s.responses(X, 1), equal_nan=True)


def test_problem_threads_do_not_change_results():
    """VehicleProblem.set_threads: the default-size split (2 x MIN_PER_THREAD candidates over
    2 threads) gives the same f as 1 thread; the compiled functions keep one signature."""
    p = VehicleProblem(CFG)
    X = p.bounds.sample(np.random.default_rng(8), 2 * kernel.MIN_PER_THREAD + 1)
    f1 = p.evaluate(X)
    p.set_threads(2)
    assert p.model.threads == 2
    assert np.array_equal(p.evaluate(X), f1)
    assert np.array_equal(p.responses(X[:3]), p.responses(X)[:3])
    assert len(kernel.objective.signatures) == 1
    assert len(kernel.simulate.signatures) == 1


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "2"])
def test_set_threads_rejects_bad_values(bad):
    p = VehicleProblem(CFG)
    with pytest.raises(ConfigError) as err:
        p.set_threads(bad)
    assert err.value.key == "threads"
