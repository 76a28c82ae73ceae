"""Across the suite: ECDFs aggregated over problems on the evaluations/D axis, scores with
bootstrap intervals, groups per family and dimension, checked against hand computation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vpid_bench.report import suite_scores as ss
from vpid_bench.report.anytime import RunHits, auc


def hits(context, algorithm, *times, budget=100.0):
    return RunHits(context, algorithm, budget, budget, tuple(float(t) for t in times))


def test_the_aggregated_ecdf_weighs_each_problem_the_same_on_evaluations_per_dimension():
    # problem a (D=2): one run hits its two targets at 4 and 40 evaluations (2 and 20 per D)
    # problem b (D=4): two runs; one hits both at 8 (2 per D), one hits one target at 80
    per = {"a": [hits("a", "x", 4, 40)],
           "b": [hits("b", "x", 8, 8), hits("b", "x", 80, math.nan)]}
    dims = {"a": 2, "b": 4}
    grid = np.array([1.0, 2.0, 10.0, 20.0])
    got = ss.aggregated_ecdf(per, dims, grid)
    # a: 0, 1/2, 1/2, 1 ; b: 0, 2/4, 2/4, 3/4 -> means
    np.testing.assert_allclose(got, [0.0, 0.5, 0.5, 0.875])


def test_the_score_is_the_mean_of_per_problem_aucs_and_its_interval_brackets_it():
    per = {"a": [hits("a", "x", 1, 10), hits("a", "x", 10, 100)],
           "b": [hits("b", "x", 1, math.nan)]}
    budgets = {"a": 100.0, "b": 100.0}
    s, lo, hi, solved = ss.score(per, budgets, np.random.default_rng(0))
    want = np.mean([auc(per["a"], 100.0), auc(per["b"], 100.0)])
    assert s == pytest.approx(want)
    assert lo <= s <= hi and lo < hi  # problem a's two runs differ: the interval is wide
    assert solved == pytest.approx(np.mean([1.0, 0.5]))
    one = ss.score({"b": per["b"]}, budgets, np.random.default_rng(0))
    assert one[1] == one[2] == pytest.approx(one[0])  # a single run: nothing to resample


def test_groups_per_family_and_dimension_and_an_incomplete_optimizer_is_named():
    facts = {"q": ("quarter", 4), "h": ("half", 7), "f": ("full", 9), "f2": ("full", 9)}
    gs = ss.groups(facts)
    assert gs[0].kind == "all" and set(gs[0].contexts) == set(facts)
    assert {(g.kind, g.name) for g in gs[1:]} == {
        ("family", "quarter"), ("family", "half"), ("family", "full"),
        ("dimension", "D=4"), ("dimension", "D=7"), ("dimension", "D=9")}
    runs = [hits(c, "good", 1, 2) for c in facts] + [hits(c, "bad", 50, math.nan)
                                                     for c in facts]
    runs += [hits("q", "partial", 1, 1)]
    rows, notes = ss.score_rows(runs, facts)
    everything = [r for r in rows if r[0] == "all"]
    assert [r[2] for r in everything] == ["good", "bad"]
    assert notes == ["partial is not scored across the suite: it has no runs with known optima "
                     "on f, f2, h"]
    quarter = [r[2] for r in rows if r[:2] == ["family", "quarter"]]
    assert quarter[0] == "partial"  # it ran all of that group


def test_families_come_from_the_problem_classes(registry):
    family = ss.family_lookup(registry)
    assert family("smoke_quarter") == "quarter car"
    assert family("vpid1_f_bmw_iso_c") == "full car"
    assert family("functions") == ""
    assert family("no_such_problem") == ""


def test_the_tables_shown_are_sorted_by_score_with_human_headers_and_no_empty_rung():
    """Issue 46: the scores best first under readable headers (the CSV keeps its own); the
    budget ladder in the same order, a rung no run reached (10,000·D here) left out."""
    rows = [["all", "all problems", "a", 2, 10, 0.2, 0.1, 0.3, 0.5],
            ["all", "all problems", "b", 2, 10, 0.6, 0.5, 0.7, 1.0],
            ["family", "full", "a", 1, 5, 0.4, 0.3, 0.5, 0.5],
            ["family", "full", "b", 1, 5, 0.3, 0.2, 0.4, 1.0]]
    headers, shown = ss.score_table(rows)
    assert headers == ["rank", "optimizer", "score (mean AUC, 0 to 1)", "95 % interval",
                       "solved by the end (%)", "runs"]
    assert shown == [[1, "b", "0.600", "[0.500, 0.700]", 100, 10],
                     [2, "a", "0.200", "[0.100, 0.300]", 50, 10]]
    assert [r[:3] for r in ss.score_table(rows, "family")[1]] == [
        ["full (1 problem)", 1, "a"], ["full (1 problem)", 2, "b"]]
    ladder = [["all problems", "a", 0.5, 0.9, math.nan, math.nan],
              ["all problems", "b", 0.1, 0.99, 1.0, math.nan],
              ["all problems", "c", 0.7, 0.7, math.nan, math.nan]]  # scored nowhere
    headers, shown = ss.ladder_table(ladder, rows)
    assert headers == ["optimizer", "solved by 10·D (%)", "solved by 100·D (%)",
                       "solved by 1,000·D (%)"]
    assert shown == [["b", 10, 99, 100], ["a", 50, 90, None], ["c", 70, 70, None]]
