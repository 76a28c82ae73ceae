"""The MATLAB-R2014b-like GA: its operators by hand, both mutation operators, elitism,
evaluation accounting (``ps`` per generation, as ``stepGA``) and beating random search."""

from __future__ import annotations

import typing

import numpy as np
import pytest
from scipy.stats import mannwhitneyu
from vpid_ga.ga import GAParams, GeneticAlgorithm, default_elite_count
from vpid_ga.mutation import (
    ACTIVE_TOL,
    box_directions,
    first_feasible,
    mutation_scaled_halving,
    mutationadaptfeasible,
    trial_directions,
    trial_order,
)
from vpid_ga.operators import (
    AdaptiveStep,
    crossoverscattered,
    fitscalingrank,
    matlab_round,
    selectionstochunif,
)

from vpid_bench.api import Bounds, ConfigError
from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.params import build_dataclass
from vpid_bench.runner import run

BOX = Bounds(np.array([-1.0, 0.0, 10.0]), np.array([1.0, 5.0, 20.0]), ("a", "b", "c"))


def sphere(X):
    return np.sum(X * X, axis=1)


def make(seed=0, **kw):
    return GeneticAlgorithm(build_dataclass(GAParams, kw, prefix="optimizer"), BOX,
                            np.random.default_rng(seed))


def test_matlab_round_half_away_from_zero():
    assert [matlab_round(x) for x in (14.5, 15.2, 2.5, 0.5, -2.5)] == [15, 15, 3, 1, -3]


def test_default_elite_count_is_floor_five_percent():
    assert [default_elite_count(ps) for ps in (10, 19, 20, 30, 39, 40, 100)] == [0, 0, 1, 1, 1,
                                                                                  2, 5]


def test_fitscalingrank_by_hand():
    scores = np.array([3.0, 1.0, np.inf, 2.0])  # ranks 3, 1, 4, 2
    raw = np.array([1 / np.sqrt(3), 1.0, 0.5, 1 / np.sqrt(2)])
    expected = 6 * raw / raw.sum()
    np.testing.assert_allclose(fitscalingrank(scores, 6), expected, rtol=1e-15)
    assert fitscalingrank(scores, 6).sum() == pytest.approx(6.0)


def test_selectionstochunif_counts_follow_expectation():
    # expectations 2, 1, 1 of 4 parents: equally spaced pointers give exactly 2, 1, 1 picks
    rng = np.random.default_rng(0)
    for _ in range(100):
        picks = selectionstochunif(np.array([2.0, 1.0, 1.0]), 4, rng)
        assert sorted(picks.tolist()) == [0, 0, 1, 2]
    # fractional expectations: each count is floor or ceil of the expectation
    exp = fitscalingrank(np.arange(20.0), 34)
    for _ in range(100):
        counts = np.bincount(selectionstochunif(exp, 34, rng), minlength=20)
        assert counts.sum() == 34
        assert np.all(counts >= np.floor(exp) - 1e-9) and np.all(counts <= np.ceil(exp) + 1e-9)


def test_crossoverscattered_takes_each_gene_from_one_parent():
    pop = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0], [2.0, 2.0, 2.0, 2.0]])
    kids = crossoverscattered(pop, np.array([0, 1, 2, 0, 1, 2] * 50), np.random.default_rng(1))
    assert kids.shape == (150, 4)
    pairs = [(0, 1), (2, 0), (1, 2)]
    for k, (a, b) in enumerate(pairs * 50):
        assert set(kids[k]) <= {float(a), float(b)}
    # about half the genes from each parent
    first = kids[0::3] == 0.0
    assert 0.4 < first.mean() < 0.6


def test_adaptive_step_rule():
    s = AdaptiveStep()
    assert s.update(1, []) == 1.0 and s.update(2, [5.0]) == 1.0
    assert s.update(3, [5.0, 5.0]) == 0.25  # no improvement: / 4
    assert s.update(4, [5.0, 5.0, 5.0]) == 0.0625
    assert s.update(5, [5.0, 5.0, 5.0, 4.0]) == 0.25  # improvement: * 4, capped at 1
    assert s.update(6, [4.0, 3.0]) == 1.0
    assert s.update(7, [3.0, 2.0]) == 1.0


# -- mutation=adaptfeasible: MATLAB's structure, piece by piece --------------------------------


@pytest.mark.parametrize("step,p", [(1.0, 1), (0.25, 2), (1 / 16, 4)])
def test_box_directions_is_a_permuted_lower_triangular_mesh_basis(step, p):
    dim, n = 5, 400
    X = np.zeros((n, dim))
    basis, active = box_directions(X, step, np.full(dim, -10.0), np.full(dim, 10.0),
                                   np.random.default_rng(3))
    assert basis.shape == (n, dim, dim) and not active.any()  # no bound is active
    # rows and columns permuted together: the diagonal stays the diagonal, +-1/sqrt(step)
    np.testing.assert_array_equal(np.abs(np.diagonal(basis, axis1=1, axis2=2)), p)
    # a permuted triangular matrix: |det| is the product of its diagonal, p^dim
    np.testing.assert_allclose(np.abs(np.linalg.det(basis)), p**dim, rtol=1e-9)
    # ... and not just any matrix with that determinant: some ordering of the coordinates makes
    # it lower triangular (the nonzero off-diagonal pattern has no cycle), checked by peeling
    # off a coordinate whose row has no off-diagonal entry, dim times
    for B in basis[:50]:
        left = list(range(dim))
        while left:
            sub = B[np.ix_(left, left)] - np.diag(np.diag(B[np.ix_(left, left)]))
            free = [i for i, row in zip(left, sub, strict=True) if not row.any()]
            assert free, B
            left.remove(free[0])
    off = basis[:, ~np.eye(dim, dtype=bool)]
    # off the diagonal: half the entries are the zeros above the (permuted) diagonal, the other
    # half round((p + 1) U - 0.5) = 0, 1, ..., p, each with probability 1 / (p + 1)
    assert set(np.unique(off)) <= set(range(p + 1))
    assert np.mean(off == 0) == pytest.approx(0.5 + 0.5 / (p + 1), abs=0.02)
    for k in range(1, p + 1):
        assert np.mean(off == k) == pytest.approx(0.5 / (p + 1), abs=0.02)


def test_box_directions_active_bounds_in_absolute_units():
    lo, hi = np.zeros(4), np.ones(4)
    # x0 on its lower bound, x2 within the tolerance (1e-6, absolute) of its upper one, x1 just
    # outside the tolerance, x3 inside
    X = np.array([[0.0, 2e-6, 1.0 - 0.5e-6, 0.5]])
    assert ACTIVE_TOL == 1e-6
    _, active = box_directions(X, 1.0, lo, hi, np.random.default_rng(0))
    np.testing.assert_array_equal(active, [[True, False, True, False]])


def test_trial_directions_by_hand():
    basis = np.array([[[2.0, 0.0], [1.0, -2.0]]])  # columns b0 = (2, 1), b1 = (0, -2)
    active = np.array([[True, False]])  # tangent direction t = e0
    # slots: b0 b1 b0 b1 t t, then 2 padding slots; signs by position: + + - - + -
    order = np.array([[5, 0, 3, 2, 1, 4, 6, 7]])
    trials, valid = trial_directions(basis, active, order)
    expected = np.array([[1, 0], [2, 1], [0, 2], [-2, -1], [0, -2], [-1, 0.0]])
    np.testing.assert_array_equal(trials[0, :6], expected)
    np.testing.assert_array_equal(valid, [[True] * 6 + [False] * 2])


def test_trial_order_permutes_the_real_slots_first():
    active = np.array([[True, False, False], [False, False, False], [True, True, True]])
    orders = [trial_order(active, np.random.default_rng(s)) for s in range(200)]
    for order in orders:
        assert sorted(order[0, :8]) == list(range(8)) and sorted(order[0, 8:]) == [8, 9, 10, 11]
        assert sorted(order[1, :6]) == list(range(6))
        assert sorted(order[2]) == list(range(12))
    # uniform: every real slot comes first about equally often (8 slots: 1/8 each)
    first = np.array([o[0, 0] for o in orders])
    assert np.all(np.bincount(first, minlength=8) > 10)


def test_first_feasible_by_hand():
    trials = np.array([[[1, 0], [2, 1], [0, 2], [-2, -1], [0, -2], [-1, 0.0]]])
    valid = np.ones((1, 6), dtype=bool)
    X, lo = np.array([[0.0, 0.5]]), np.zeros(2)
    # the first trial fits: (0.25, 0.5)
    np.testing.assert_array_equal(first_feasible(X, 0.25, trials, valid, lo, np.ones(2)),
                                  [[0.25, 0.5]])
    # x0 <= 0.2: (0.25, 0.5) and (0.5, 0.75) leave the box, (0, 1.0) lies on its face: kept
    np.testing.assert_array_equal(
        first_feasible(X, 0.25, trials, valid, lo, np.array([0.2, 1.0])), [[0.0, 1.0]])
    # ... unless that trial is padding: then (-0.5, 0.25) leaves the box, (0, 0) is kept
    padded = valid.copy()
    padded[0, 2] = False
    np.testing.assert_array_equal(
        first_feasible(X, 0.25, trials, padded, lo, np.array([0.2, 1.0])), [[0.0, 0.0]])
    # step 1 in a 0.9 x 1 box: (1, .5), (2, 1.5), (0, 2.5), (-2, -.5), (0, -1.5), (-1, .5) all
    # leave it, so the child is the parent (no halving)
    np.testing.assert_array_equal(
        first_feasible(X, 1.0, trials, valid, lo, np.array([0.9, 1.0])), X)


def test_adaptfeasible_interior_child_is_one_basis_step():
    """Deep inside the box every trial fits, so the child is the first trial: ``+ step`` times
    one basis column (trial 1 has sign +): one entry +-step/sqrt(step) (the diagonal), the
    others step times an integer in 0 ... 1/sqrt(step). In the parameters' units: the same
    seed gives the same child in a box 1000 times wider."""
    step, p = 0.25, 2
    pop = np.zeros((1, 6))
    lo, hi = np.full(6, -10.0), np.full(6, 10.0)
    kids = mutationadaptfeasible(pop, np.zeros(2000, dtype=int), step, lo, hi,
                                 np.random.default_rng(5))
    units = kids / step
    np.testing.assert_array_equal(units, np.round(units))
    assert set(np.unique(units)) <= {-2.0, 0.0, 1.0, 2.0}
    assert np.all(np.sum(np.abs(units) == p, axis=1) >= 1)
    assert np.all(np.sum(units < 0, axis=1) <= 1)  # only the diagonal entry can be negative
    assert 0.45 < np.mean(np.any(units < 0, axis=1)) < 0.55  # its sign is random
    wide = mutationadaptfeasible(pop, np.zeros(2000, dtype=int), step, 1000 * lo, 1000 * hi,
                                 np.random.default_rng(5))
    np.testing.assert_array_equal(wide, kids)


def test_adaptfeasible_on_a_face_uses_the_tangent_cone_with_matlabs_signs():
    """1-D box [0, 0.3], parent on the lower bound, step 1/4: the basis step is +-0.5 (out of
    the box either way), the tangent steps are +-0.25, of which only +0.25 fits. Trials
    (slots b b t t, signs + - + - by position): the child is 0.25 exactly when one of the two
    t slots lands on position 1 or 3 (the + positions), probability 1 - (2/4)(1/3) = 5/6,
    else the parent. (Trying every direction with both signs would give 0.25 always.)"""
    kids = mutationadaptfeasible(np.zeros((1, 1)), np.zeros(4000, dtype=int), 0.25,
                                 np.zeros(1), np.array([0.3]), np.random.default_rng(6))
    assert set(np.unique(kids)) == {0.0, 0.25}
    assert np.mean(kids == 0.25) == pytest.approx(5 / 6, abs=0.025)  # 4 standard errors
    # a 2-D corner: only +e0 or +e1 steps fit
    kids = mutationadaptfeasible(np.zeros((1, 2)), np.zeros(3000, dtype=int), 0.25,
                                 np.zeros(2), np.full(2, 0.3), np.random.default_rng(7))
    rows = {tuple(k) for k in kids}
    assert rows == {(0.25, 0.0), (0.0, 0.25), (0.0, 0.0)}


def test_adaptfeasible_children_are_feasible_and_seeded():
    lo, hi = BOX.lower, BOX.upper
    rng = np.random.default_rng(8)
    pop = np.vstack([lo, hi, 0.5 * (lo + hi), BOX.sample(rng, 7)])
    parents = np.arange(10).repeat(50)
    for step in (1.0, 0.25, 1e-3):
        kids = mutationadaptfeasible(pop, parents, step, lo, hi, np.random.default_rng(9))
        assert np.all(BOX.contains(kids))
        moved = np.any(kids != pop[parents], axis=1)
        assert moved.mean() > 0.5
        # a child is one step along a basis or tangent direction: no coordinate moves more
        # than step * (1/sqrt(step) + 1) (the largest entry of a basis column)
        assert np.all(np.abs(kids - pop[parents]) <= step * (1 / np.sqrt(step) + 1) + 1e-12)
        again = mutationadaptfeasible(pop, parents, step, lo, hi, np.random.default_rng(9))
        np.testing.assert_array_equal(again, kids)
        other = mutationadaptfeasible(pop, parents, step, lo, hi, np.random.default_rng(10))
        assert not np.array_equal(other, kids)


# -- mutation=scaled_halving: the earlier operator, kept as an option --------------------------


def test_scaled_halving_stays_in_box_even_from_the_faces():
    rng = np.random.default_rng(2)
    lo, hi = BOX.lower, BOX.upper
    pop = np.vstack([lo, hi, 0.5 * (lo + hi)])
    kids = mutation_scaled_halving(pop, np.array([0, 1, 2] * 300), 1.0, lo, hi, rng)
    assert np.all(BOX.contains(kids))
    assert np.mean(np.any(kids != pop[[0, 1, 2] * 300], axis=1)) > 0.99  # they do move
    small = mutation_scaled_halving(pop, np.array([2] * 100), 1e-3, lo, hi, rng)
    assert np.all(np.abs(small - pop[2]) <= 1e-3 * (hi - lo))  # a fraction of the width


# -- the GA --------------------------------------------------------------------------------------


def test_counts_at_paper_population_sizes():
    ga = make(ps=20, iterations=3)
    assert (ga.n_elite, ga.n_xover, ga.n_mutate, ga.n_parents) == (1, 15, 4, 34)
    ga = make(ps=30, iterations=3)
    assert (ga.n_elite, ga.n_xover, ga.n_mutate) == (1, 23, 6)  # round(0.8 * 29) = 23


@pytest.mark.parametrize("mutation", ["adaptfeasible", "scaled_halving"])
def test_every_generation_is_scored_whole_and_elites_survive(mutation):
    ga = make(ps=20, iterations=6, elite_count=3, seed=4, mutation=mutation)
    X = ga.ask()
    assert X.shape == (20, 3)
    ga.tell(X, sphere(X))
    sizes = []
    while not ga.done:
        order = np.argsort(ga.scores, kind="stable")[:3]
        elites = ga.population[order].copy()
        X = ga.ask()
        sizes.append(len(X))
        assert np.all(BOX.contains(X))
        np.testing.assert_array_equal(X[:3], elites)  # the elites come first, unchanged
        f = sphere(X) + 1e-3 * ga.generation  # a drifting objective: the new scores are used
        ga.tell(X, f)
        np.testing.assert_array_equal(ga.population, X)
        np.testing.assert_array_equal(ga.scores, f)
    assert sizes == [20] * 6
    assert len(ga.best_history) == 6


def test_runner_trace_spends_ps_per_generation():
    class Sphere:
        name = "sphere"
        bounds = BOX

        def evaluate(self, X):
            return sphere(X)

    result = run(Sphere(), make(ps=20, iterations=4), budget=20 * 5)
    assert result.trace_evaluations == [20, 40, 60, 80, 100]
    assert result.evaluations == 100
    assert np.all(np.diff(result.trace_best) <= 0)


def test_records_show_ps_times_iterations_plus_one(compose_config, tmp_path):
    from vpid_bench.experiment import run_from_config
    from vpid_bench.store.records import read_record

    for ps, iterations in ((20, 3), (30, 2)):
        cfg = compose_config(["problem=functions", "optimizer=ga", f"problem.ps={ps}",
                              f"problem.iterations={iterations}", "runs=2", "progress=false",
                              "report=false"])
        summary = run_from_config(cfg, tmp_path / f"ga-{ps}")
        assert summary.ran == 2 and not summary.failed
        for path in summary.record_paths:
            record = read_record(path)
            assert record["optimizer"]["params"]["mutation"] == "adaptfeasible"
            assert record["result"]["evaluations"] == ps * (iterations + 1)
            steps = np.diff([0, *record["trace"]["evaluations"]]).tolist()
            assert steps == [ps] * (iterations + 1)


def _sphere_finals(registry, name: str, seeds, **overrides) -> np.ndarray:
    ps, iterations = 20, 50
    problem = build_problem(registry, {"name": "functions", "function": "sphere", "dim": 10,
                                       "ps": ps, "iterations": iterations})
    cls, params = optimizer_params(registry, {"name": name, "ps": ps, "iterations": iterations,
                                              **overrides})
    return np.array([
        run(problem, cls(params, problem.bounds, np.random.default_rng(s)),
            ps * (iterations + 1)).f_best
        for s in seeds
    ])


@pytest.mark.parametrize("mutation", ["adaptfeasible", "scaled_halving"])
def test_ga_beats_random_search_on_sphere(registry, mutation):
    """10-D sphere on [-5.12, 5.12]^10, 20 x 51 evaluations, 10 seeds each. Random search's
    best stays near 13-28; the GA reaches about 0.5. The worst GA run must beat the best
    random run, and a one-sided rank test must give p < 0.01."""
    ga = _sphere_finals(registry, "ga", range(10), mutation=mutation)
    rnd = _sphere_finals(registry, "random", range(10))
    assert ga.max() < rnd.min()
    assert mannwhitneyu(ga, rnd, alternative="less").pvalue < 0.01


def test_mutation_is_a_literal_choice_key():
    assert typing.get_origin(typing.get_type_hints(GAParams)["mutation"]) is typing.Literal
    assert build_dataclass(GAParams, {}, prefix="optimizer").mutation == "adaptfeasible"
    assert make(mutation="scaled_halving").params.mutation == "scaled_halving"
    with pytest.raises(ConfigError, match="optimizer.mutation.*'adaptfeasible', 'scaled_halving'"):
        build_dataclass(GAParams, {"mutation": "gaussian"}, prefix="optimizer")


@pytest.mark.parametrize("key,value", [("elite_count", 20), ("elite_count", -2),
                                       ("crossover_fraction", 1.2), ("ps", 1)])
def test_bad_parameters_name_the_key(key, value):
    with pytest.raises(ConfigError, match=key):
        build_dataclass(GAParams, {key: value}, prefix="optimizer")


@pytest.mark.parametrize("step", [1.0, 0.25, 0.03, 1e-4])
def test_the_compiled_mutation_equals_the_reference_bit_for_bit(step):
    """vpid_ga.fused computes the adaptive-feasible children from the same random numbers as
    the numpy reference: identical children (points on the bounds and corners included, so
    the tangent cone and the padding of the trial order are exercised), and the generator
    left in the same state."""
    dim, lo, hi = 9, np.full(9, -1.0), np.full(9, 2.0)
    rng = np.random.default_rng(int(step * 1e4) + 1)
    pop = rng.uniform(lo, hi, (40, dim))
    pop[:10, :3] = lo[:3]  # on a bound
    pop[10:20, 4:] = hi[4:]  # on the other
    pop[20:25] = lo  # a corner
    parents = rng.integers(0, 40, 60)
    a, b = np.random.default_rng(7), np.random.default_rng(7)
    numpy_kids = mutationadaptfeasible(pop, parents, step, lo, hi, a, engine="numpy")
    numba_kids = mutationadaptfeasible(pop, parents, step, lo, hi, b, engine="numba")
    assert np.array_equal(numpy_kids, numba_kids)
    assert np.array_equal(np.signbit(numpy_kids), np.signbit(numba_kids))
    assert a.random() == b.random()
