"""``optimizer=cmaes`` (the ``cma`` package, extra ``peers``): seeding, bounds, stopping,
quiet, and better than random search. Skipped when cma is not installed. About 10 s, 3 s of it
``import cma`` (which loads scipy.stats and matplotlib)."""

from __future__ import annotations

import numpy as np
import pytest
from peers_helpers import run_optimizer
from scipy.stats import mannwhitneyu

from vpid_bench.api import Bounds, ConfigError, Problem
from vpid_bench.build import build_problem
from vpid_bench.params import build_dataclass
from vpid_bench.runner import run

pytest.importorskip("cma")

from vpid_peers.cmaes import CMAES, CMAESParams  # noqa: E402


def _sphere(registry, dim: int, ps: int, iterations: int):
    return build_problem(registry, {"name": "functions", "function": "sphere", "dim": dim,
                                    "ps": ps, "iterations": iterations})


_run = run_optimizer


def test_registered_so_the_contract_test_covers_it(registry):
    # tests/optimizers/test_optimizer_contract.py runs every name of Registry().optimizers
    assert registry.optimizer("cmaes") is CMAES


def test_beats_random_search_on_sphere(registry):
    """10-D sphere, 20 x 51 evaluations, 10 seeds: random search's best stays near 13-28,
    CMA-ES reaches about 0.01. The worst CMA-ES run must beat the best random run, and a
    one-sided rank test must give p < 0.01."""
    problem = _sphere(registry, 10, 20, 50)
    cma_f = np.array([_run(registry, "cmaes", problem, s)[0].f_best for s in range(10)])
    rnd_f = np.array([_run(registry, "random", problem, s)[0].f_best for s in range(10)])
    assert cma_f.max() < rnd_f.min()
    assert mannwhitneyu(cma_f, rnd_f, alternative="less").pvalue < 0.01


def test_stops_itself_when_converged(registry):
    """4-D sphere with room for 5010 evaluations: cma's tolerances (tolfun 1e-11 on the
    normalised problem) end the run first, near the optimum."""
    problem = _sphere(registry, 4, 10, 500)
    for seed in (0, 1, 2):
        result, optimizer = _run(registry, "cmaes", problem, seed)
        assert result.stopped_by == "optimizer"
        assert result.evaluations < result.budget // 2
        assert set(optimizer.stop_reasons) & {"tolfun", "tolfunhist", "tolx", "tolflatfitness"}
        assert result.f_best < 1e-8


def test_stops_at_the_protocol_schedule_like_de(registry):
    """A run budget above ps x (iterations + 1) is not used, as DE's generations are not
    (Rastrigin does not converge that fast)."""
    problem = build_problem(registry, {"name": "functions", "function": "rastrigin",
                                       "dim": 10, "ps": 10, "iterations": 5})
    result, optimizer = _run(registry, "cmaes", problem, seed=3, budget=1000)
    assert result.evaluations == 60 and result.stopped_by == "optimizer"
    assert optimizer.stop_reasons == {"schedule": 60}


def test_same_seed_same_run_and_global_rng_untouched(registry):
    problem = _sphere(registry, 5, 10, 10)
    np.random.seed(12345)
    state = np.random.get_state()[1].copy()
    first, _ = _run(registry, "cmaes", problem, seed=7)
    # cma draws only from the run's Generator: numpy's global state is neither read nor moved
    np.testing.assert_array_equal(np.random.get_state()[1], state)
    np.random.seed(999)  # a different global state must not matter either
    again, _ = _run(registry, "cmaes", problem, seed=7)
    np.testing.assert_array_equal(again.x_best, first.x_best)
    assert again.trace_best == first.trace_best
    other, _ = _run(registry, "cmaes", problem, seed=8)
    assert other.trace_best != first.trace_best


class _Linear(Problem):
    """f = sum(x) on [1, 2]^3: the minimum 3 is the lower corner, on the box's boundary."""

    name = "linear"

    def __init__(self) -> None:
        super().__init__(None)  # type: ignore[arg-type]
        self._bounds = Bounds(np.ones(3), np.full(3, 2.0), ("a", "b", "c"))

    @property
    def bounds(self) -> Bounds:
        return self._bounds

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        assert self._bounds.contains(X).all()
        return X.sum(axis=1)


def test_bounds_handled_by_the_library_reach_a_corner():
    """cma's BoundTransform keeps every candidate inside (the problem asserts it) and lets the
    search converge onto the boundary: within 1e-6 of the corner after 1200 evaluations."""
    problem = _Linear()
    params = CMAESParams(ps=12, iterations=99)
    result = run(problem, CMAES(params, problem.bounds, np.random.default_rng(0)), 1200)
    assert result.f_best - 3.0 < 1e-6


def test_sigma0_is_a_fraction_of_the_box(registry):
    """The first population's spread in each coordinate is sigma0 x width (500 rows: the
    sample standard deviation is within 10% of it). The start, the generator's first 3
    uniforms, is at least 0.34 from every face for this seed, where cma's bound transformation
    is the identity (it bends only within 0.05 of a face of the unit cube)."""
    x0 = np.random.default_rng(6).random(3)
    assert np.all((x0 > 0.34) & (x0 < 0.66))
    problem = _sphere(registry, 3, 500, 1)
    params = CMAESParams(ps=500, iterations=1, sigma0=0.02, popsize="ps")
    X = CMAES(params, problem.bounds, np.random.default_rng(6)).ask()
    np.testing.assert_allclose(X.mean(axis=0), problem.bounds.lower + x0 * problem.bounds.width,
                               atol=0.005 * 10.24)
    np.testing.assert_allclose(X.std(axis=0), 0.02 * problem.bounds.width, rtol=0.1)


def test_bad_values_name_the_key():
    with pytest.raises(ConfigError, match=r"optimizer\.sigma0=0\.0"):
        build_dataclass(CMAESParams, {"sigma0": 0.0}, prefix="optimizer")
    with pytest.raises(ConfigError, match=r"optimizer\.sigma0=1\.5"):
        build_dataclass(CMAESParams, {"sigma0": 1.5}, prefix="optimizer")
    with pytest.raises(ConfigError, match=r"problem\.ps=1"):
        build_dataclass(CMAESParams, {"ps": 1, "popsize": "ps"}, prefix="optimizer")
    for bad in ("big", 1, 10**6):
        with pytest.raises(ConfigError, match=r"optimizer\.popsize"):
            build_dataclass(CMAESParams, {"popsize": bad}, prefix="optimizer")
    with pytest.raises(ConfigError, match=r"optimizer\.restarts"):
        build_dataclass(CMAESParams, {"restarts": "popi"}, prefix="optimizer")


@pytest.mark.parametrize("popsize, expected", [("library", 4 + int(3 * np.log(9))),
                                               ("ps", 20), (7, 7)])
def test_population_is_the_librarys_by_default(popsize, expected):
    """cma's own 4 + 3 ln(d) (10 for 9 parameters) unless ps or a number is asked for."""
    bounds = Bounds(np.zeros(9), np.ones(9), tuple(f"x{i}" for i in range(9)))
    params = build_dataclass(CMAESParams, {"ps": 20, "popsize": popsize}, prefix="optimizer")
    assert CMAES(params, bounds, np.random.default_rng(0)).ask().shape == (expected, 9)


def test_ipop_restarts_with_twice_the_population_until_the_budget(registry):
    """On the 4-D sphere cma converges long before a budget of 5010 evaluations: without
    restarts the run stops there; with ipop a new search with twice the population starts
    each time, and the budget is used up."""
    problem = _sphere(registry, 4, 10, 500)
    plain, _ = _run(registry, "cmaes", problem, 0)
    result, optimizer = _run(registry, "cmaes", problem, 0, restarts="ipop")
    assert plain.evaluations < plain.budget // 2
    assert optimizer.searches >= 3 and result.evaluations >= result.budget - 2 * 10 * 2**8
    assert optimizer._popsize == (4 + int(3 * np.log(4))) * 2 ** (optimizer.searches - 1)
    assert result.f_best <= plain.f_best


def test_quiet_no_output_and_no_files(registry, tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    problem = _sphere(registry, 4, 10, 500)
    _run(registry, "cmaes", problem, seed=0)  # runs until cma's own stop
    out, err = capfd.readouterr()
    assert out == "" and err == ""
    assert list(tmp_path.iterdir()) == []  # cma's default would write outcmaes/*.dat


def test_bipop_alternates_a_large_and_a_small_regime(registry):
    """BIPOP (Hansen 2009): after the first search, each restart goes to the regime that has
    used fewer evaluations; large searches double the population, small ones draw a
    population between the first and half the large one, and a smaller step."""
    problem = _sphere(registry, 3, 10, 1)
    params = CMAESParams(ps=10, iterations=1, budget=10**7, sigma0=0.3, restarts="bipop")
    opt = CMAES(params, problem.bounds, np.random.default_rng(3))
    first = opt._popsize
    seen = []
    for _ in range(40):  # end each search at once: every tell is a restart
        X = opt.ask()
        opt._es.stop = lambda: {"test": 1}  # noqa: B023 - the current search's stop
        opt.tell(X, problem.evaluate(X))
        seen.append((opt._regime, opt._popsize, opt._sigma))
    regimes = [r for r, _, _ in seen]
    assert "small" in regimes and "large" in regimes
    large = [n for r, n, _ in seen if r == "large"]
    assert large == [first * 2 ** k for k in range(1, len(large) + 1)]
    for k, (regime, n, sigma) in enumerate(seen):
        if regime == "small":
            big = max([first, *[m for r, m, _ in seen[:k] if r == "large"]])
            assert first <= n <= max(first, big // 2) and 0.003 <= sigma <= 0.3
    # the budgets of both regimes stay within one search of each other
    assert abs(opt._spent["small"] - opt._spent["large"]) <= max(large)
