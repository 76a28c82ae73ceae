"""DE building blocks on tiny hand-built populations, checked against hand-computed vectors.

``draw_indices`` and ``binomial_crossover`` are the generator-drawing forms the adaptive DEs
(JADE, SHADE, L-SHADE) use; DE1-DE8 use ``indices_from_keys`` and ``crossover_from_uniforms``
on one block of uniforms per generation. Both forms are tested here."""

from __future__ import annotations

from typing import get_args

import numpy as np
import pytest
from vpid_de.fused import BOUNDS_IDS
from vpid_de.kernels import (
    BOUNDS_RULES,
    MUTATIONS,
    BoundsRule,
    best1,
    best2,
    binomial_crossover,
    crossover_from_uniforms,
    current_to_best1,
    current_to_rand1,
    draw_indices,
    greedy_selection,
    rand1,
    rand2,
)
from vpid_de.variants import eq15

# Six members in 2-D, chosen so that every difference is an exact binary fraction.
X = np.array(
    [[0.0, 0.0], [1.0, 2.0], [2.0, 4.0], [4.0, 1.0], [8.0, 8.0], [16.0, 3.0]]
)
# One row of fixed indices per target (none equal to its own row), five columns.
R = np.array(
    [[1, 2, 3, 4, 5], [2, 3, 4, 5, 0], [3, 4, 5, 0, 1], [4, 5, 0, 1, 2], [5, 0, 1, 2, 3],
     [0, 1, 2, 3, 4]]
)
BEST = 3
F, K = 0.5, 0.25


def test_rand1_eq7_by_hand():
    # target 0: x1 + F (x2 - x3) = [1, 2] + 0.5 [-2, 3] = [0, 3.5]
    V = rand1(X, BEST, R, F)
    np.testing.assert_array_equal(V[0], [0.0, 3.5])
    # target 5: x0 + F (x1 - x2) = [0, 0] + 0.5 [-1, -2] = [-0.5, -1]
    np.testing.assert_array_equal(V[5], [-0.5, -1.0])


def test_best2_eq9_by_hand():
    # target 0: x3 + F (x1 + x2 - x3 - x4) = [4, 1] + 0.5 ([1+2-4-8, 2+4-1-8]) = [-0.5, -0.5]
    V = best2(X, BEST, R, F)
    np.testing.assert_array_equal(V[0], [-0.5, -0.5])


def test_best1_eq10_by_hand():
    # target 2: x3 + F (x3 - x4) = [4, 1] + 0.5 [-4, -7] = [2, -2.5]
    V = best1(X, BEST, R, F)
    np.testing.assert_array_equal(V[2], [2.0, -2.5])


def test_current_to_best1_eq11_by_hand():
    # target 1: x1 + F (x3 - x1) + F (x2 - x3) = [1,2] + 0.5[3,-1] + 0.5[-2,3] = [1.5, 3]
    V = current_to_best1(X, BEST, R, F)
    np.testing.assert_array_equal(V[1], [1.5, 3.0])


def test_rand2_eq12_by_hand():
    # target 0: x1 + F (x2 - x3) + F (x4 - x5) = [1,2] + 0.5[-2,3] + 0.5[-8,5] = [-4, 6]
    V = rand2(X, BEST, R, F)
    np.testing.assert_array_equal(V[0], [-4.0, 6.0])


def test_current_to_rand1_eq13_by_hand():
    # target 4: x4 + K (x5 - x4) + F (x0 - x1) = [8,8] + 0.25[8,-5] + 0.5[-1,-2] = [9.5, 5.75]
    V = current_to_rand1(X, BEST, R, F, K)
    np.testing.assert_array_equal(V[4], [9.5, 5.75])


def test_per_vector_factor_column_scales_each_row():
    F_col = np.array([[0.5], [1.0], [0.0], [0.0], [0.0], [0.0]])
    V = rand1(X, BEST, R, F_col)
    np.testing.assert_array_equal(V[0], [0.0, 3.5])  # F = 0.5
    np.testing.assert_array_equal(V[1], X[2] + 1.0 * (X[3] - X[4]))  # F = 1
    np.testing.assert_array_equal(V[2], X[3])  # F = 0 leaves the base vector


def test_kernel_table_index_counts():
    # Eq. 7: 3, Eq. 9: 4, Eq. 10: 2, Eq. 11: 2, Eq. 12: 5, Eq. 13: 3 indices besides i.
    counts = {name: n for name, (_, n) in MUTATIONS.items()}
    assert counts == {"rand1": 3, "best2": 4, "best1": 2, "current_to_best1": 2, "rand2": 5,
                      "current_to_rand1": 3}


@pytest.mark.parametrize("ps,n", [(4, 3), (6, 5), (20, 5), (3, 2)])
def test_draw_indices_distinct_and_exclude_target(ps, n):
    rng = np.random.default_rng(1)
    for _ in range(50):
        r = draw_indices(rng, ps, n)
        assert r.shape == (ps, n)
        assert np.all((r >= 0) & (r < ps))
        assert not np.any(r == np.arange(ps)[:, None])
        assert all(len(set(row)) == n for row in r)


def test_draw_indices_uniform_over_others():
    # Each of the ps - 1 others should be r1 of target 0 with probability 1/(ps-1).
    rng = np.random.default_rng(2)
    ps, trials = 5, 20000
    first = np.array([draw_indices(rng, ps, 1)[0, 0] for _ in range(trials)])
    freq = np.bincount(first, minlength=ps) / trials
    assert freq[0] == 0.0
    # binomial sd = sqrt(0.25 * 0.75 / 20000) = 0.0031; allow 5 sd
    np.testing.assert_allclose(freq[1:], 0.25, atol=0.016)


def test_draw_indices_refuses_too_small_population():
    with pytest.raises(ValueError):
        draw_indices(np.random.default_rng(0), 4, 4)


def test_crossover_keeps_at_least_one_mutant_gene_even_with_cr_zero():
    rng = np.random.default_rng(3)
    Xp = np.zeros((50, 7))
    V = np.ones((50, 7))
    U = binomial_crossover(Xp, V, 0.0, rng)
    assert np.all(U.sum(axis=1) == 1.0)  # exactly the rnbr(i) gene comes from the mutant


def test_crossover_cr_one_takes_the_whole_mutant_and_rate_matches_cr():
    rng = np.random.default_rng(4)
    Xp, V = np.zeros((200, 10)), np.ones((200, 10))
    np.testing.assert_array_equal(binomial_crossover(Xp, V, 1.0, rng), V)
    U = binomial_crossover(Xp, V, 0.3, rng)
    # expected fraction: 0.3 + 0.7 / 10 = 0.37 (the forced gene); sd ~ 0.0034 over 2000 genes
    assert abs(U.mean() - 0.37) < 0.02


def test_crossover_takes_one_rate_per_target():
    rng = np.random.default_rng(6)
    Xp, V = np.zeros((3, 2000)), np.ones((3, 2000))
    U = binomial_crossover(Xp, V, np.array([[0.0], [0.5], [1.0]]), rng)
    # row 0: only the forced gene; row 1: about half (sd 0.011, allow 5 sd); row 2: all
    assert U[0].sum() == 1.0 and abs(U[1].mean() - 0.5) < 0.056 and U[2].all()


def test_greedy_selection_ties_replace_only_when_asked():
    Xp, U = np.array([[0.0], [1.0], [2.0]]), np.array([[10.0], [11.0], [12.0]])
    fX, fU = np.array([1.0, 1.0, np.inf]), np.array([1.0, 2.0, np.inf])
    np.testing.assert_array_equal(greedy_selection(Xp, fX, U, fU)[0][:, 0], [0.0, 1.0, 2.0])
    Xn, fn = greedy_selection(Xp, fX, U, fU, ties=True)
    np.testing.assert_array_equal(Xn[:, 0], [10.0, 1.0, 12.0])
    np.testing.assert_array_equal(fn, [1.0, 1.0, np.inf])


def test_bounds_choices_are_one_list():
    # the Literal the params module validates, the numpy rules and the compiled ids agree
    assert get_args(BoundsRule) == tuple(BOUNDS_RULES) == tuple(BOUNDS_IDS)


def test_greedy_selection_strictly_better_replaces():
    Xp = np.array([[0.0], [1.0], [2.0], [3.0]])
    fX = np.array([1.0, 1.0, 1.0, np.inf])
    U = np.array([[10.0], [11.0], [12.0], [13.0]])
    fU = np.array([0.5, 1.0, np.inf, 7.0])
    Xn, fn = greedy_selection(Xp, fX, U, fU)
    np.testing.assert_array_equal(Xn[:, 0], [10.0, 1.0, 2.0, 13.0])
    np.testing.assert_array_equal(fn, [0.5, 1.0, 1.0, 7.0])
    np.testing.assert_array_equal(Xp[:, 0], [0.0, 1.0, 2.0, 3.0])  # inputs untouched


LOWER = np.array([-1.0, 0.1, 1e-3])
UPPER = np.array([1.0, 0.3, 2e-3])


@pytest.mark.parametrize("rule", sorted(BOUNDS_RULES))
def test_bounds_rule_keeps_every_candidate_in_the_box(rule):
    rng = np.random.default_rng(5)
    width = UPPER - LOWER
    parent = LOWER + rng.random((2000, 3)) * width
    # far outside, just outside (1 ulp), on the faces, inside
    U = LOWER + rng.uniform(-5.0, 6.0, size=(2000, 3)) * width
    U[:10] = np.nextafter(UPPER, np.inf)
    U[10:20] = np.nextafter(LOWER, -np.inf)
    U[20:30] = UPPER
    out = BOUNDS_RULES[rule](U.copy(), parent, LOWER, UPPER, rng.random(U.shape))
    assert np.all((out >= LOWER) & (out <= UPPER))
    inside = (U >= LOWER) & (U <= UPPER)
    np.testing.assert_array_equal(out[inside], U[inside])  # coordinates inside are untouched


def test_reinit_uses_the_given_uniforms_by_hand():
    lo, hi = np.array([0.0, 0.0]), np.array([10.0, 4.0])
    U = np.array([[-2.0, 1.0], [3.0, 5.0]])
    u = np.array([[0.25, 0.9], [0.9, 0.5]])
    np.testing.assert_array_equal(BOUNDS_RULES["reinit"](U, U, lo, hi, u), [[2.5, 1.0], [3.0, 2.0]])


def test_crossover_from_uniforms_by_hand():
    Xp, V = np.zeros((2, 4)), np.ones((2, 4))
    u = np.array([[0.1, 0.95, 0.9, 0.5], [0.99, 0.99, 0.99, 0.99]])
    U = crossover_from_uniforms(Xp, V, 0.9, u, np.array([0.6, 0.3]))  # rnbr = 2, 1
    np.testing.assert_array_equal(U, [[1, 0, 1, 1], [0, 1, 0, 0]])


def test_bounds_rules_by_hand():
    lo, hi = np.array([0.0]), np.array([10.0])
    U = np.array([[-2.0], [13.0], [25.0]])
    parent = np.array([[4.0], [6.0], [8.0]])
    np.testing.assert_array_equal(BOUNDS_RULES["clip"](U, parent, lo, hi), [[0.0], [10.0], [10.0]])
    np.testing.assert_array_equal(BOUNDS_RULES["reflect"](U, parent, lo, hi), [[2.0], [7.0], [5.0]])
    np.testing.assert_array_equal(BOUNDS_RULES["midpoint"](U, parent, lo, hi),
                                  [[2.0], [8.0], [9.0]])


def test_eq15_forms():
    # Das et al.: from R_max at k = 0 down to R_min + (R_max - R_min)/K_max at k = K_max - 1
    assert eq15(0, 50, 1.2, 0.4) == pytest.approx(1.2)
    assert eq15(49, 50, 1.2, 0.4) == pytest.approx(0.4 + 0.8 / 50)
    assert eq15(25, 50, 1.2, 0.4) == pytest.approx(0.8)
    # as printed: (R_max - R_min)(K_max - k)/K_max, 0.8 at k = 0
    assert eq15(0, 50, 1.2, 0.4, "printed") == pytest.approx(0.8)
    assert eq15(25, 50, 1.2, 0.4, "printed") == pytest.approx(0.4)
