"""Effect sizes beside every verdict: A12 with a bootstrap interval, and a p-value at a
permutation test's resolution printed as a bound."""

from __future__ import annotations

import numpy as np
import pytest

from vpid_bench.report.body import verdict_short
from vpid_bench.report.stats import N_RESAMPLES, a12, a12_interval, p_floor
from vpid_bench.report.tables import pair_detail


def test_a12_interval_edges_and_coverage():
    x = np.arange(10.0)
    assert a12_interval(x, x + 100, paired=True) == (0.0, 0.0)  # x always lower
    assert a12_interval(x, x, paired=True) == (0.5, 0.5)
    # two samples of one distribution: the 95 % interval holds 0.5 in about 95 % of draws
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(200):
        a, b = rng.standard_normal(30), rng.standard_normal(30)
        lo, hi = a12_interval(a, b, paired=False)
        assert lo <= a12(a, b) <= hi
        hits += lo <= 0.5 <= hi
    assert 0.88 <= hits / 200 <= 0.99, hits


@pytest.mark.parametrize("paired", [True, False])
def test_a12_interval_is_the_percentile_bootstrap_of_resampled_pairs(paired):
    """The interval equals, bit for bit, the percentile bootstrap written out: every
    resample's A12 as the mean pair score over its resampled pairs (the same draws), with
    ties and samples of unequal size."""
    from vpid_bench.report.stats import N_BOOT

    rng = np.random.default_rng(9)
    for n, m in [(30, 30), (7, 12), (1, 5), (28, 14)]:
        x, y = rng.integers(0, 5, n).astype(float), rng.normal(2.0, 1.5, m).round(0)
        draws = np.random.default_rng(3)
        ix = draws.integers(0, n, (N_BOOT, n))
        iy = ix if paired and n == m else draws.integers(0, m, (N_BOOT, m))
        xs, ys = x[ix][:, :, None], y[iy][:, None, :]
        boots = np.mean((xs > ys) + 0.5 * (xs == ys), axis=(1, 2))
        tail = (1.0 - 0.95) / 2.0
        want = tuple(float(v) for v in np.quantile(boots, [tail, 1.0 - tail]))
        assert a12_interval(x, y, paired=paired, seed=3) == want


def test_the_detail_reads_from_the_named_side_and_bounds_a_floor_p():
    row = {"a": "de4", "b": "random", "p_holm": 3e-4, "p_at_floor": True, "A12": 0.1,
           "A12_lo": 0.02, "A12_hi": 0.2}
    assert pair_detail(row, "de4") == "p_holm≤0.0003, A12=0.10 [0.02, 0.20]"
    assert pair_detail(row, "random") == "p_holm≤0.0003, A12=0.90 [0.80, 0.98]"
    exact = {**row, "p_at_floor": False, "p_holm": 0.012}
    assert pair_detail(exact, "de4").startswith("p_holm=0.012, ")
    assert verdict_short(f"beats it ({pair_detail(row, 'de4')})") == \
        "yes, p≤0.0003, A12=0.10 [0.02, 0.20]"
    assert verdict_short("does not clear it (p_holm=1, A12=0.39 [0.24, 0.56])") == \
        "no, p=1, A12=0.39 [0.24, 0.56]"


def test_the_floor_is_the_permutation_resolution():
    assert p_floor("permutation (9999 resamples)") == pytest.approx(2 / (N_RESAMPLES + 1))
    assert p_floor("exact") == 0.0


def test_methods_the_tests_do_not_separate_are_not_called_equivalent_beyond_the_margin():
    from vpid_bench.report.first_screen import verdict_text
    from vpid_bench.report.verdicts import EQUIVALENCE_MARGIN, Evidence, Method, decide

    def verdict(*medians):
        methods = tuple(Method(n, 10, m, "a") for n, m in zip("abc", medians, strict=False))
        return decide(Evidence("ctx", "NoRE", "%", methods, True, (), references=()))

    assert "differ by up to" not in verdict_text(verdict(10.0, 10.5))  # 5 %: within
    text = verdict_text(verdict(10.0, 10.5, 15.0))
    assert "differ by up to 50 %" in text and f"{100 * EQUIVALENCE_MARGIN:g} % margin" in text


def test_mann_whitney_with_one_run_and_ties_gives_a_p_not_an_error():
    """scipy's permutation test needs two observations per sample; one run per job with a
    tie (two optimizers stopped at the same value) once raised ValueError in the report."""
    import numpy as np

    from vpid_bench.report.stats import mann_whitney

    assert mann_whitney(np.array([1.0]), np.array([1.0])) == (0.5, 1.0, "normal approximation")
    u, p, how = mann_whitney(np.array([1.0]), np.array([1.0, 2.0, 2.0, 3.0]))
    assert 0 < p < 1 and how == "normal approximation"
    assert mann_whitney(np.array([1.0]), np.array([2.0]))[1:] == (1.0, "exact")


def test_a_friedman_p_at_the_permutation_floor_is_printed_as_a_bound():
    """30 blocks ranking three optimizers alike: no permutation of 9999 is as extreme, so p is
    the test's resolution 1/10000 and the report prints it as a bound; with 5 blocks and 3
    optimizers the p is exact (6^5 arrangements) and is printed as a value."""
    import pandas as pd

    from vpid_bench.report.body import _friedman_md
    from vpid_bench.report.stats import friedman_on_table

    rng = np.random.default_rng(0)
    base = rng.random(30)[:, None]
    table = pd.DataFrame(base + np.array([0.0, 1.0, 2.0]), columns=["a", "b", "c"])
    fr = friedman_on_table(table)
    assert fr.p == pytest.approx(1 / (N_RESAMPLES + 1)) and fr.p_at_floor
    text = " ".join(" ".join(_friedman_md(fr, "Across", 0.05, "")).split())
    assert "p≤0.0001 (permutation" in text and "p = " not in text
    exact = friedman_on_table(table.iloc[:5])
    assert exact.p_method.startswith("exact") and not exact.p_at_floor
    assert f"p={exact.p:.2g} (exact" in " ".join(" ".join(_friedman_md(exact, "A", 0.05,
                                                                      "")).split())
