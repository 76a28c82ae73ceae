"""The MATLAB-R2014b-like GA: its operators by hand, elitism and evaluation accounting."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_ga.ga import GAParams, GeneticAlgorithm, default_elite_count
from vpid_ga.operators import (
    AdaptiveStep,
    crossoverscattered,
    fitscalingrank,
    matlab_round,
    mutationadaptfeasible,
    selectionstochunif,
)

from vpid_bench.api import Bounds, ConfigError
from vpid_bench.params import build_dataclass

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


def test_mutation_stays_in_box_even_from_the_faces():
    rng = np.random.default_rng(2)
    lo, hi = BOX.lower, BOX.upper
    pop = np.vstack([lo, hi, 0.5 * (lo + hi)])
    kids = mutationadaptfeasible(pop, np.array([0, 1, 2] * 300), 1.0, lo, hi, rng)
    assert np.all(BOX.contains(kids))
    assert np.mean(np.any(kids != pop[[0, 1, 2] * 300], axis=1)) > 0.99  # they do move
    small = mutationadaptfeasible(pop, np.array([2] * 100), 1e-3, lo, hi, rng)
    assert np.all(np.abs(small - pop[2]) <= 1e-3 * (hi - lo))


def test_counts_at_paper_population_sizes():
    ga = make(ps=20, iterations=3)
    assert (ga.n_elite, ga.n_xover, ga.n_mutate, ga.n_parents) == (1, 15, 4, 34)
    ga = make(ps=30, iterations=3)
    assert (ga.n_elite, ga.n_xover, ga.n_mutate) == (1, 23, 6)  # round(0.8 * 29) = 23


def test_evaluations_per_generation_are_ps_minus_elites_and_elites_survive():
    ga = make(ps=20, iterations=6, elite_count=3, seed=4)
    X = ga.ask()
    assert X.shape == (20, 3)
    ga.tell(X, sphere(X))
    sizes = []
    while not ga.done:
        order = np.argsort(ga.scores, kind="stable")[:3]
        elites, elite_scores = ga.population[order].copy(), ga.scores[order].copy()
        kids = ga.ask()
        sizes.append(len(kids))
        assert np.all(BOX.contains(kids))
        ga.tell(kids, sphere(kids))
        np.testing.assert_array_equal(ga.population[:3], elites)  # unchanged, not re-evaluated
        np.testing.assert_array_equal(ga.scores[:3], elite_scores)
    assert sizes == [17] * 6
    # elitism makes the best score monotone
    assert np.all(np.diff(ga.best_history) <= 0)


def test_runner_trace_shows_ps_minus_elite_steps():
    from vpid_bench.runner import run

    class Sphere:
        name = "sphere"
        bounds = BOX

        def evaluate(self, X):
            return sphere(X)

    result = run(Sphere(), make(ps=20, iterations=4), budget=20 * 5)
    assert result.trace_evaluations == [20, 39, 58, 77, 96]
    assert result.stopped_by == "optimizer"


@pytest.mark.parametrize("key,value", [("elite_count", 20), ("elite_count", -2),
                                       ("crossover_fraction", 1.2), ("ps", 1)])
def test_bad_parameters_name_the_key(key, value):
    with pytest.raises(ConfigError, match=key):
        build_dataclass(GAParams, {key: value}, prefix="optimizer")
