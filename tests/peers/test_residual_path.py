"""The residual path of the run loop: shapes, counting, the refusal before the run."""

from __future__ import annotations

import numpy as np
import pytest
from peers_helpers import LinearLSQ, NoResiduals

from vpid_bench.api import ConfigError, Optimizer, OptimizerParams, Problem, check_compatible
from vpid_bench.runner import run


class Recorder(Optimizer):
    """Asks batches of 4 uniform rows and keeps what tell receives."""

    wants_residuals = True

    def __init__(self, bounds, rng):
        super().__init__(OptimizerParams(), bounds, rng)
        self.told: list[tuple] = []
        self.closed = 0

    def ask(self):
        return self.bounds.sample(self.rng, 4)

    def tell(self, X, f, residuals=None):
        self.told.append((X, f, residuals))

    def close(self):
        self.closed += 1


def _linear(groups=None):
    rng = np.random.default_rng(0)
    return LinearLSQ(rng.normal(size=(6, 3)), rng.normal(size=6), -2.0, 2.0, groups)


def test_tell_gets_residuals_of_the_told_rows_and_every_row_counts():
    problem = _linear(groups=[0, 0, 0, 1, 1, 1])
    opt = Recorder(problem.bounds, np.random.default_rng(1))
    result = run(problem, opt, budget=10)
    # batches of 4, 4, then 2 cut by the budget (not told); every row evaluated once
    assert result.evaluations == problem.evaluated == 10 and result.batches == 3
    assert len(opt.told) == 2 and opt.closed == 1
    np.testing.assert_array_equal(opt.residual_groups, [0, 0, 0, 1, 1, 1])
    for X, f, R in opt.told:
        assert R.shape == (4, 6)
        np.testing.assert_allclose(R, problem.b - X @ problem.A.T, rtol=1e-14)
        expected = np.linalg.norm(R[:, :3], axis=1) + np.linalg.norm(R[:, 3:], axis=1)
        np.testing.assert_allclose(f, expected, rtol=1e-14)


def test_has_residuals_is_whether_residuals_is_overridden():
    assert _linear().has_residuals
    assert not NoResiduals().has_residuals


def test_default_residual_groups_is_one_group_and_default_pairs_f_with_r():
    class Plain(LinearLSQ):
        residual_groups = Problem.residual_groups  # the base class's default

    p = Plain(np.eye(3), np.arange(3.0), -1.0, 1.0)
    np.testing.assert_array_equal(p.residual_groups(), [0, 0, 0])
    X = np.array([[0.5, 0.0, -0.5]])
    f, R = p.evaluate_with_residuals(X)
    np.testing.assert_allclose(R, [[-0.5, 1.0, 2.5]])
    np.testing.assert_allclose(f, [np.linalg.norm(R)])


def test_refused_before_the_run_naming_both():
    problem = NoResiduals()
    opt = Recorder(problem.bounds, np.random.default_rng(1))
    with pytest.raises(ConfigError, match="Recorder.*plain_sphere") as info:
        check_compatible(problem, Recorder)
    assert info.value.key == "optimizer" and "\n" not in str(info.value)
    with pytest.raises(ConfigError, match="'lsq'.*'plain_sphere'"):
        check_compatible(problem, Recorder, name="lsq")
    with pytest.raises(ConfigError):
        run(problem, opt, budget=10)
    assert problem.evaluated == 0 and opt.closed == 1
    check_compatible(_linear(), Recorder)  # compatible: no error
    check_compatible(problem, Optimizer)  # an optimizer without residuals: any problem


def test_registered_least_squares_refused_on_a_problem_without_residuals(registry):
    cls = registry.optimizer("lsq")
    with pytest.raises(ConfigError, match="'lsq'.*'plain_sphere'"):
        check_compatible(NoResiduals(), cls, name="lsq")
    check_compatible(NoResiduals(), registry.optimizer("scipy_de"), name="scipy_de")


def test_vehicle_groups_and_one_simulation_for_f_and_r(vehicle):
    p = vehicle
    N = p.t.size
    groups = p.residual_groups()
    assert groups.shape == (2 * N,) and (groups == 0).sum() == N and np.all(groups[N:] == 1)
    X = np.vstack([p.bounds.sample(np.random.default_rng(3), 3), p.x_true])
    X[1, 8] = -1.0  # non-physical: inf
    f, R = p.evaluate_with_residuals(X)
    assert f.shape == (4,) and R.shape == (4, 2 * N)
    np.testing.assert_allclose(R, p.residuals(X))
    assert np.isinf(f[1])
    np.testing.assert_allclose(f[[0, 2, 3]], p.evaluate(X)[[0, 2, 3]], rtol=1e-12)
