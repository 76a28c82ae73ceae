"""JADE, SHADE and L-SHADE: parameter adaptation on hand-built success histories,
current-to-pbest/1 on a hand-made population with a fixed archive, L-SHADE's population size
schedule, the archive's size, defaults and validation, and statistical behaviour on the
sphere. About 2 s."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import mannwhitneyu
from vpid_de.adaptation import (
    SuccessHistory,
    improvement_weights,
    jade_update,
    lehmer_mean,
    sample_cr,
    sample_f,
    weighted_mean,
)
from vpid_de.adaptive_de import ADAPTIVE
from vpid_de.kernels import current_to_pbest1, partner_indices, pbest_indices
from vpid_de.population import Archive, lpsr_size, round_half_up, worst_removed

from vpid_bench.api import Bounds, ConfigError
from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.params import build_dataclass
from vpid_bench.runner import run

BOX4 = Bounds(np.full(4, -5.0), np.full(4, 5.0), ("a", "b", "c", "d"))


def sphere(X):
    return np.sum(X * X, axis=1)


def make(name, seed=0, box=BOX4, **kw):
    cls = ADAPTIVE[name]
    return cls(build_dataclass(cls.Params, kw, prefix="optimizer"), box,
               np.random.default_rng(seed))


def drive(opt, f=sphere, max_batches=10_000):
    """Run an ask/tell loop until done; return the sizes of the asked batches."""
    sizes = []
    while not opt.done and len(sizes) < max_batches:
        X = opt.ask()
        sizes.append(len(X))
        opt.tell(X, f(X))
    return sizes


# -- means and adaptation on hand-built success histories ------------------------------------------


def test_means_by_hand():
    S = np.array([0.5, 1.0, 0.25])
    assert weighted_mean(S) == pytest.approx(1.75 / 3)
    # Lehmer: (0.25 + 1 + 0.0625) / (0.5 + 1 + 0.25) = 1.3125 / 1.75 = 0.75
    assert lehmer_mean(S) == pytest.approx(0.75)
    w = np.array([0.25, 0.75, 0.0])
    assert weighted_mean(S, w) == pytest.approx(0.125 + 0.75)
    # (0.25 * 0.25 + 0.75 * 1) / (0.25 * 0.5 + 0.75 * 1) = 0.8125 / 0.875 = 13/14
    assert lehmer_mean(S, w) == pytest.approx(13 / 14)
    assert math.isnan(lehmer_mean(np.zeros(3)))


def test_jade_update_by_hand():
    # mean_A(S_CR) = 0.8 -> 0.9 * 0.5 + 0.1 * 0.8 = 0.53
    # mean_L(S_F) = 0.75 -> 0.9 * 0.5 + 0.1 * 0.75 = 0.525
    mu_cr, mu_f = jade_update(0.5, 0.5, np.array([0.9, 0.7, 0.8]),
                              np.array([0.5, 1.0, 0.25]), c=0.1)
    assert mu_cr == pytest.approx(0.53) and mu_f == pytest.approx(0.525)
    # no success: nothing learnt
    assert jade_update(0.3, 0.7, np.array([]), np.array([]), c=0.1) == (0.3, 0.7)


def test_improvement_weights_by_hand():
    np.testing.assert_allclose(improvement_weights(np.array([1.0, 3.0])), [0.25, 0.75])
    # a parent that had failed (f = inf): its improvement takes all the weight
    np.testing.assert_allclose(improvement_weights(np.array([1.0, np.inf, np.inf])),
                               [0.0, 0.5, 0.5])


def test_shade_memory_by_hand():
    memory = SuccessHistory(H=3)
    # improvements 1 and 3 -> weights 0.25, 0.75
    memory.update(np.array([0.2, 0.8]), np.array([0.5, 1.0]), np.array([1.0, 3.0]))
    # M_CR: 0.25 * 0.2 + 0.75 * 0.8 = 0.65 (weighted arithmetic mean)
    # M_F: (0.25 * 0.25 + 0.75 * 1) / (0.25 * 0.5 + 0.75 * 1) = 13/14 (weighted Lehmer mean)
    np.testing.assert_allclose(memory.M_CR, [0.65, 0.5, 0.5])
    np.testing.assert_allclose(memory.M_F, [13 / 14, 0.5, 0.5])
    assert memory.k == 1
    memory.update(np.array([]), np.array([]), np.array([]))  # no success: no entry, no step
    assert memory.k == 1
    memory.update(np.array([0.1]), np.array([0.3]), np.array([2.0]))
    memory.update(np.array([0.4]), np.array([0.6]), np.array([5.0]))
    np.testing.assert_allclose(memory.M_CR, [0.65, 0.1, 0.4])
    np.testing.assert_allclose(memory.M_F, [13 / 14, 0.3, 0.6])
    assert memory.k == 0  # written in turn, cyclically
    memory.update(np.array([0.9]), np.array([0.9]), np.array([1.0]))
    np.testing.assert_allclose(memory.M_CR, [0.9, 0.1, 0.4])


def test_lshade_memory_lehmer_cr_and_terminal_value_by_hand():
    memory = SuccessHistory(H=2, lehmer_cr=True, terminal=True)
    memory.update(np.array([0.2, 0.8]), np.array([0.5, 1.0]), np.array([1.0, 3.0]))
    # M_CR: (0.25 * 0.04 + 0.75 * 0.64) / (0.25 * 0.2 + 0.75 * 0.8) = 0.49 / 0.65
    assert memory.M_CR[0] == pytest.approx(0.49 / 0.65)
    assert memory.M_F[0] == pytest.approx(13 / 14)
    # every success had CR = 0: entry 1 becomes terminal ...
    memory.update(np.array([0.0, 0.0]), np.array([0.4, 0.6]), np.array([1.0, 1.0]))
    assert np.isnan(memory.M_CR[1]) and memory.M_F[1] == pytest.approx(0.52 / 1.0)
    memory.update(np.array([0.5]), np.array([0.5]), np.array([1.0]))  # entry 0 again
    memory.update(np.array([0.9]), np.array([0.5]), np.array([1.0]))  # entry 1: stays terminal
    assert memory.M_CR[0] == pytest.approx(0.5) and np.isnan(memory.M_CR[1])
    # a target that draws a terminal entry uses CR = 0
    cr = sample_cr(np.random.default_rng(0), np.array([np.nan, 0.5, np.nan]), 3)
    assert cr[0] == 0.0 and cr[2] == 0.0 and 0.0 <= cr[1] <= 1.0


def test_sample_f_is_a_truncated_regenerated_cauchy():
    F = sample_f(np.random.default_rng(1), 0.5, 20000)
    assert np.all((F > 0.0) & (F <= 1.0))
    # P(F = 1) = P(C > 1 | C > 0) for C ~ Cauchy(0.5, 0.1):
    # (1/2 - atan(5)/pi) / (1/2 + atan(5)/pi) = 0.0670; binomial sd 0.0018, allow 5 sd
    expected = (0.5 - math.atan(5) / math.pi) / (0.5 + math.atan(5) / math.pi)
    assert abs(np.mean(F == 1.0) - expected) < 0.009
    assert abs(np.median(F) - 0.5) < 0.01  # median mu, barely moved by the redraws (~0.007)


def test_sample_cr_is_a_clipped_normal():
    CR = sample_cr(np.random.default_rng(2), 0.05, 20000)
    assert np.all((CR >= 0.0) & (CR <= 1.0))
    # P(N(0.05, 0.1) < 0) = Phi(-0.5) = 0.3085; sd 0.0033, allow 5 sd
    assert abs(np.mean(CR == 0.0) - 0.3085) < 0.017


# -- current-to-pbest/1 ----------------------------------------------------------------------------

# Four members and a fixed archive of two, in 2-D, exact binary fractions.
X = np.array([[0.0, 0.0], [1.0, 2.0], [2.0, 4.0], [4.0, 1.0]])
ARCHIVE = np.array([[8.0, 8.0], [16.0, 3.0]])
XA = np.vstack([X, ARCHIVE])


def test_current_to_pbest1_by_hand_with_archive():
    pbest = np.array([3, 3, 1, 3])
    r1 = np.array([1, 2, 3, 0])
    r2 = np.array([4, 5, 0, 2])  # 4, 5: the archive's rows
    F = np.array([[0.5], [0.25], [1.0], [0.5]])
    V = current_to_pbest1(X, pbest, r1, XA, r2, F)
    # 0: x0 + 0.5 (x3 - x0) + 0.5 (x1 - a0) = [2, 0.5] + [-3.5, -3] = [-1.5, -2.5]
    # 1: x1 + 0.25 (x3 - x1) + 0.25 (x2 - a1) = [1, 2] + [0.75, -0.25] + [-3.5, 0.25]
    # 2: x2 + 1 (x1 - x2) + 1 (x3 - x0) = [1, 2] + [4, 1] = [5, 3]
    # 3: x3 + 0.5 (x3 - x3) + 0.5 (x0 - x2) = [4, 1] + [-1, -2] = [3, -1]
    np.testing.assert_array_equal(V, [[-1.5, -2.5], [-1.75, 2.0], [5.0, 3.0], [3.0, -1.0]])


def test_pbest_is_one_of_the_best():
    rng = np.random.default_rng(3)
    f = np.array([5.0, 1.0, 3.0, 2.0, 4.0, 0.5])
    for _ in range(200):
        assert np.all(pbest_indices(rng, f, 1) == 5)
        assert set(pbest_indices(rng, f, 3)) <= {5, 1, 3}
        counts = np.array([1, 2, 2, 6, 6, 6])
        p = pbest_indices(rng, f, counts)
        assert p[0] == 5 and p[1] in (5, 1) and p[2] in (5, 1)
    # uniform among the 3 best: each ~ 1/3 over 6000 draws (sd 0.0061, allow 5 sd)
    draws = np.concatenate([pbest_indices(rng, f, 3) for _ in range(1000)])
    freq = np.bincount(draws, minlength=6) / draws.size
    np.testing.assert_allclose(freq[[1, 3, 5]], 1 / 3, atol=0.031)


def test_r2_excludes_target_and_r1_and_is_uniform_over_population_and_archive():
    rng = np.random.default_rng(4)
    r1 = np.array([1, 2, 3, 0])
    draws = np.stack([partner_indices(rng, r1, len(XA)) for _ in range(6000)])
    assert not np.any(draws == np.arange(4)) and not np.any(draws == r1)
    assert draws.min() >= 0 and draws.max() == len(XA) - 1
    # target 0 (r1 = 1): rows 2, 3, 4, 5 with probability 1/4 each (sd 0.0056, allow 5 sd)
    freq = np.bincount(draws[:, 0], minlength=6) / 6000
    np.testing.assert_allclose(freq, [0, 0, 0.25, 0.25, 0.25, 0.25], atol=0.028)
    with pytest.raises(ValueError):
        partner_indices(rng, np.array([1, 0]), 2)


# -- the archive and L-SHADE's schedule ------------------------------------------------------------


def test_archive_keeps_its_size():
    rng = np.random.default_rng(5)
    archive = Archive(5, 2)
    archive.add(X[:3], rng)
    np.testing.assert_array_equal(archive.rows, X[:3])  # under capacity: all kept, in order
    archive.add(XA[2:], rng)  # 3 + 4 = 7 rows -> 5, a subset of what was added
    assert len(archive) == 5
    added = {tuple(r) for r in np.vstack([X[:3], XA[2:]])}
    assert {tuple(r) for r in archive.rows} <= added
    before = {tuple(r) for r in archive.rows}
    archive.resize(2, rng)
    assert len(archive) == 2 and {tuple(r) for r in archive.rows} <= before
    assert len(Archive(0, 2).rows) == 0
    nothing = Archive(0, 2)
    nothing.add(X, rng)
    assert len(nothing) == 0


def test_lpsr_size_by_hand():
    # round((4 - 72) / 400 * nfe + 72), halves up, never below 4
    assert lpsr_size(0, 400, 72, 4) == 72
    assert lpsr_size(144, 400, 72, 4) == 48  # 72 - 24.48 = 47.52
    assert lpsr_size(192, 400, 72, 4) == 39  # 72 - 32.64 = 39.36
    assert lpsr_size(399, 400, 72, 4) == 4  # 72 - 67.83 = 4.17
    assert lpsr_size(400, 400, 72, 4) == 4
    assert lpsr_size(500, 400, 72, 4) == 4
    assert lpsr_size(50, 100, 9, 4) == 7  # 9 - 2.5 = 6.5 rounds up
    assert round_half_up(2.5) == 3 and round_half_up(2.4999) == 2


def test_worst_removed_keeps_the_best_in_order():
    f = np.array([3.0, 1.0, 4.0, 1.0, 5.0])
    Xs, fs = worst_removed(np.arange(5.0)[:, None], f, 3)
    np.testing.assert_array_equal(Xs[:, 0], [0.0, 1.0, 3.0])
    np.testing.assert_array_equal(fs, [3.0, 1.0, 1.0])


def test_lshade_population_schedule_by_hand_and_budget_kept():
    """N_init = 18 D = 72 (D = 4), N_min = 4, a budget of 400: each generation has the
    size planned after the previous one (hand-computed with lpsr_size above); the last one is
    cut to what the budget leaves."""
    opt = make("lshade", N_init="paper", budget=400)
    sizes = drive(opt)
    assert sizes == [72, 72, 48, 39, 33, 27, 23, 19, 15, 13, 11, 9, 7, 6, 5, 1]
    assert sum(sizes) == 400 == opt.nfe and opt.done
    assert len(opt.population) == 4


@pytest.mark.parametrize("budget,handed", [(400, None), (400, 400), (1000, 250), (50, None)])
def test_lshade_never_exceeds_the_budget(budget, handed):
    """Through the run loop: ps = 20, iterations = 19 gives 400 evaluations by default;
    L-SHADE plans over the budget it is handed (params.budget), stops there and never asks
    for more; the run loop's own budget cuts it where that is smaller."""
    opt = make("lshade", ps=20, iterations=19, budget=handed, seed=1)

    class Sphere:
        name, bounds = "sphere", BOX4

        def evaluate(self, X):
            return sphere(X)

    result = run(Sphere(), opt, budget)
    planned = handed or 400
    assert opt.budget == planned
    assert result.evaluations == min(budget, planned)
    assert opt.nfe <= planned


@pytest.mark.parametrize("name", sorted(ADAPTIVE))
def test_archive_size_is_kept_during_a_run(name):
    opt = make(name, ps=12, iterations=40, budget=800)
    while not opt.done:
        X = opt.ask()
        opt.tell(X, sphere(X))
        cap = (round_half_up(2.6 * len(opt.population)) if name == "lshade" else 12)
        assert len(opt.archive) <= cap == opt.archive.capacity
    assert len(opt.archive) > 0  # parents that lost were archived
    no_archive = make("jade", ps=12, iterations=10, archive=False)
    drive(no_archive)
    assert len(no_archive.archive) == 0


@pytest.mark.parametrize("name", sorted(ADAPTIVE))
def test_successes_reach_the_adaptation(name):
    """What adapt() receives is exactly the CR_i, F_i of the trials that strictly improved on
    their parent, with the improvements; selection keeps the better (SHADE, L-SHADE: also an
    equal) trial."""
    opt = make(name, ps=10, iterations=3, seed=7)
    seen = []
    adapt = opt.adapt
    opt.adapt = lambda S_CR, S_F, d: (seen.append((S_CR, S_F, d)), adapt(S_CR, S_F, d))
    X0 = opt.ask()
    opt.tell(X0, sphere(X0))
    P, fP = opt.population.copy(), opt.fitness.copy()
    U = opt.ask()
    CR, F = opt._CR.copy(), opt._F.copy()
    fU = sphere(U)
    fU[0] = fP[0]  # one tie
    opt.tell(U, fU)
    win = fU < fP
    S_CR, S_F, delta = seen[0]
    np.testing.assert_array_equal(S_CR, CR[win])
    np.testing.assert_array_equal(S_F, F[win])
    np.testing.assert_array_equal(delta, fP[win] - fU[win])
    assert np.all((F > 0) & (F <= 1)) and np.all((CR >= 0) & (CR <= 1))
    replaced = (fU <= fP) if opt.ties else win
    if name != "lshade":  # L-SHADE may shrink its population right after selection
        np.testing.assert_array_equal(opt.population[replaced], U[replaced])
        np.testing.assert_array_equal(opt.population[~replaced], P[~replaced])


def test_jade_learns_its_means():
    opt = make("jade", ps=20, iterations=30, seed=2)
    drive(opt)
    assert (opt.mu_cr, opt.mu_f) != (0.5, 0.5)
    assert 0.0 <= opt.mu_cr <= 1.0 and 0.0 < opt.mu_f <= 1.0


# -- defaults, keys, validation ------------------------------------------------------------------

PAPER_DEFAULTS = {
    "jade": {"c": 0.1, "p": 0.05, "archive": True, "bounds": "midpoint"},
    "shade": {"H": 100, "p_max": 0.2, "bounds": "midpoint"},
    "lshade": {"H": 6, "p": 0.11, "r_arc": 2.6, "N_min": 4, "N_init_rate": 18.0,
               "N_init": "ps", "bounds": "midpoint"},
}


@pytest.mark.parametrize("name", sorted(PAPER_DEFAULTS))
def test_defaults(name):
    plain = dataclasses.asdict(ADAPTIVE[name].Params())
    for key, value in PAPER_DEFAULTS[name].items():
        assert plain[key] == value, (name, key)


@pytest.mark.parametrize(
    "name,key,value",
    [("jade", "c", 0.0), ("jade", "p", 1.5), ("jade", "bounds", "wrap"), ("shade", "H", 0),
     ("shade", "p_max", 0.0), ("lshade", "N_init", "huge"), ("lshade", "N_min", 2),
     ("lshade", "r_arc", -1.0), ("lshade", "p", 0.0),
     ("lshade", "N_init_rate", 0.0), ("jade", "archive", "yes")],
)
def test_bad_values_name_the_key(name, key, value):
    with pytest.raises(ConfigError, match=f"optimizer.{key}"):
        build_dataclass(ADAPTIVE[name].Params, {key: value}, prefix="optimizer")


def test_literal_choices_are_listed():
    with pytest.raises(ConfigError, match="one of 'ps', 'paper'"):
        build_dataclass(ADAPTIVE["lshade"].Params, {"N_init": "18D"}, prefix="optimizer")


@pytest.mark.parametrize("name", sorted(ADAPTIVE))
def test_population_minimum(name):
    kw = {"N_init": "ps", "N_min": 3} if name == "lshade" else {}
    drive(make(name, ps=3, iterations=3, **kw))  # the smallest population works
    with pytest.raises(ConfigError, match="problem.ps"):
        make(name, ps=2, iterations=3, **kw)


def test_lshade_initial_population_from_the_paper_or_ps():
    assert make("lshade", N_init="paper").ask().shape == (72, 4)  # 18 x 4
    assert make("lshade", N_init="ps", ps=11).ask().shape == (11, 4)
    assert make("lshade", N_init="paper", N_init_rate=2.0).ask().shape == (8, 4)
    with pytest.raises(ConfigError, match="optimizer.N_init_rate"):
        make("lshade", N_init="paper", N_init_rate=0.5)  # 2 < N_min


@pytest.mark.parametrize("name", sorted(ADAPTIVE))
def test_schedule_and_box(name):
    opt = make(name, ps=7, iterations=5)
    sizes = drive(opt)
    assert sum(sizes) == 7 * 6 and opt.done
    if name != "lshade":
        assert sizes == [7] * 6


def test_registered(registry):
    assert set(ADAPTIVE) <= set(registry.optimizers)


# -- statistical behaviour -------------------------------------------------------------------------

PS, ITERATIONS = 20, 50


def _finals(registry, name: str, seeds) -> np.ndarray:
    problem = build_problem(registry, {"name": "functions", "function": "sphere", "dim": 10,
                                       "ps": PS, "iterations": ITERATIONS})
    cls, params = optimizer_params(registry, {"name": name, "ps": PS, "iterations": ITERATIONS})
    return np.array([
        run(problem, cls(params, problem.bounds, np.random.default_rng(s)),
            PS * (ITERATIONS + 1)).f_best
        for s in seeds
    ])


@pytest.fixture(scope="module")
def random_sphere(registry):
    return _finals(registry, "random", range(10))


@pytest.mark.parametrize("name", sorted(ADAPTIVE))
def test_beats_random_search_on_the_sphere(registry, random_sphere, name):
    """10-D sphere, 20 x 51 = 1020 evaluations, 10 seeds each. Random search's best stays
    near 13-28; the adaptive DEs reach ~0.01. The worst run must beat random's best run, and
    a one-sided Mann-Whitney test must give p < 0.01."""
    finals = _finals(registry, name, range(10))
    assert finals.max() < random_sphere.min()
    assert mannwhitneyu(finals, random_sphere, alternative="less").pvalue < 0.01


@pytest.mark.parametrize("bounds", ["reinit", "clip", "reflect", "midpoint"])
@pytest.mark.parametrize("name", sorted(ADAPTIVE))
def test_numba_trials_match_the_numpy_reference_bit_for_bit(name, bounds):
    """Whole runs with the trials of vpid_de.fused.pbest_trials and with the numpy kernels
    (current_to_pbest1, binomial_crossover, the bounds rule) are identical: same seed, same
    draws in the same order, same floating-point operations. The optimum sits at a corner of
    the box so the bounds rules fire often; the archive fills, so r2 reaches into it."""
    runs = {}
    for engine in ("numba", "numpy"):
        opt = make(name, seed=5, bounds=bounds, iterations=40)
        opt.engine = engine
        asked = []
        while not opt.done:
            X = opt.ask()
            asked.append(X)
            opt.tell(X, np.sum((X - BOX4.upper) ** 2, axis=1))
        runs[engine] = np.vstack(asked)
        assert len(opt.archive) > 0
    assert len(runs["numba"]) > 100
    np.testing.assert_array_equal(runs["numba"], runs["numpy"])
