"""The report's numbers on synthetic records with known answers: paper data, NoRE
arithmetic, rankings, significance, effect size, Friedman, honest notes."""

from __future__ import annotations

import numpy as np
import pytest
from report_synth import DE4_PS20_MEAN, OV, PAPER_NAMES, objective_job, record, write_job

from vpid_bench.report import paper, stats, tables
from vpid_bench.report.load import load_records, runs_frame


def test_paper_data_is_consistent_with_itself():
    """Published ε follow from the published means (rounding: 0.1 points, a1 has 3 digits),
    and each NoRE is the norm of its ε row (0.03 points)."""
    t = paper.paper_table()
    for ps in (20, 30):
        ov = t[(t.ps == ps) & (t.algorithm == "OV")][list(paper.PARAMETERS)].to_numpy(float)[0]
        np.testing.assert_allclose(ov, OV)
        algos = sorted(set(t[t.ps == ps].algorithm) - {"OV"})
        assert algos == ["DE1", "DE2", "DE3", "DE4", "DE5", "DE6", "DE7", "DE8", "GA"]
        for a in algos:
            pub = paper.published(t, a.lower(), ps)
            mean = np.array([pub["mean"][p] for p in paper.PARAMETERS])
            eps = np.array([pub["eps"][p] for p in paper.PARAMETERS])
            np.testing.assert_allclose(100 * (mean - ov) / ov, eps, atol=0.1, err_msg=a)
            assert abs(np.linalg.norm(eps) - pub["nore"]) < 0.03, (a, ps)


def test_table_iii_de2_row_is_repaired():
    pub = paper.published(paper.paper_table(), "de2", 30)
    assert (pub["eps"]["m"], pub["eps"]["I"], pub["eps"]["k1"]) == (0.53, 0.42, -0.73)
    assert "repaired" in pub["note"]


def _vehicle_job(root, algo, ps, mean, deltas, problem="vehicle"):
    """Runs whose identified vectors average exactly to ``mean``."""
    recs = []
    for i, d in enumerate(deltas):
        for j, sign in enumerate((1.0, -1.0)):
            x = mean * (1.0 + sign * d)
            recs.append(record(problem=problem, optimizer=algo, ps=ps, run_index=2 * i + j,
                               x=x, f=0.01 + d, names=PAPER_NAMES, true=OV))
    return write_job(root / f"{algo}-{ps}", recs)


def test_paper_de4_row_gives_nore_1_51(tmp_path):
    """Runs averaging to the paper's DE4 mean vector (PS = 20) reproduce NoRE = 1.51 and
    differ from the published row by rounding only."""
    _vehicle_job(tmp_path, "de4", 20, DE4_PS20_MEAN, [0.01, 0.02, 0.05])
    df = runs_frame(load_records([tmp_path]).records)
    mv = tables.mean_vector_table(df)
    ours = mv[(mv.source == "ours") & (mv.quantity == "eps_percent")].iloc[0]
    assert ours["n_runs"] == 6
    assert round(ours["nore"], 2) == 1.51
    np.testing.assert_allclose(
        mv[(mv.source == "ours") & (mv.quantity == "mean")][PAPER_NAMES].to_numpy(float)[0],
        DE4_PS20_MEAN, rtol=1e-12)
    diff = mv[(mv.source == "difference") & (mv.quantity == "eps_percent")].iloc[0]
    assert abs(diff["nore"]) < 0.01
    assert np.all(np.abs(diff[PAPER_NAMES].to_numpy(float)) < 0.01)
    assert "Table II" in mv[mv.source == "paper"]["note"].iloc[0]


def test_no_paper_rows_for_another_problem(tmp_path):
    _vehicle_job(tmp_path, "de4", 20, DE4_PS20_MEAN, [0.01], problem="car")
    mv = tables.mean_vector_table(runs_frame(load_records([tmp_path]).records))
    assert set(mv.source) == {"ours"}


@pytest.fixture
def three_optimizers(tmp_path):
    """Objective values: good < mid < bad (no overlap), twin == good in distribution."""
    rng = np.random.default_rng(1)
    good = list(1.0 + rng.random(10))
    objective_job(tmp_path, "good", 20, good)
    objective_job(tmp_path, "mid", 20, list(3.0 + rng.random(10)))
    objective_job(tmp_path, "random", 20, list(5.0 + rng.random(10)))
    objective_job(tmp_path, "twin", 20, [v + 1e-3 for v in good])
    return runs_frame(load_records([tmp_path]).records)


def test_ranking_significance_and_effect_size(three_optimizers):
    df = three_optimizers
    assert set(df.metric_name) == {"f_best"}  # no true values: the objective is the metric
    st = tables.run_stats_table(df)
    assert list(st.sort_values("rank_median").algorithm) == ["good", "twin", "mid", "random"]
    kw = stats.kruskal_by_context(df)
    assert kw["p"].iloc[0] < 1e-4
    pairs = stats.pairwise_by_context(df).set_index(["a", "b"])
    gm = pairs.loc[("good", "mid")]
    assert gm["U"] == 0 and gm["A12"] == 0.0 and gm["effect"] == "large"
    assert gm["significant"] and gm["better"] == "good"
    # Holm: 6 pairs; the smallest raw p is multiplied by 6, never made smaller.
    assert np.all(pairs["p_holm"] >= pairs["p"] - 1e-15)
    assert pairs["p_holm"].min() == pytest.approx(6 * pairs["p"].min())
    gt = pairs.loc[("good", "twin")]
    assert not gt["significant"] and gt["better"] == ""
    assert gt["A12"] < 0.5  # good is always lower by 1e-3: P(good > twin) is small
    verdicts = dict(zip(st.algorithm, tables.baseline_verdicts(st, stats.pairwise_by_context(df)),
                        strict=True))
    assert verdicts["random"] == "baseline"
    assert verdicts["good"].startswith("beats it")


def test_a12_matches_a_direct_count():
    from scipy import stats as ss

    x, y = np.array([1.0, 2.0, 3.0, 3.0]), np.array([3.0, 0.5, 4.0])
    direct = np.mean([(a > b) + 0.5 * (a == b) for a in x for b in y])
    u = ss.mannwhitneyu(x, y).statistic
    assert stats.a12_from_u(u, len(x), len(y)) == pytest.approx(direct, abs=1e-12)


def test_friedman_needs_blocks_and_says_so(three_optimizers, tmp_path):
    fr = stats.friedman_across_blocks(three_optimizers)
    assert fr.mean_ranks is None and "at least 2 blocks" in fr.note


def test_friedman_across_population_sizes(tmp_path):
    for ps in (20, 30, 40):
        for name, base in (("a", 1.0), ("b", 2.0), ("c", 3.0)):
            objective_job(tmp_path, name, ps, [base + 0.1 * i for i in range(3)])
    fr = stats.friedman_across_blocks(runs_frame(load_records([tmp_path]).records))
    assert list(fr.mean_ranks.index) == ["a", "b", "c"]
    np.testing.assert_allclose(fr.mean_ranks.to_numpy(), [1.0, 2.0, 3.0])
    assert fr.statistic == pytest.approx(6.0)  # chi2 = 12 n / (k (k+1)) * sum(R^2) - 3n(k+1)
    assert fr.p == pytest.approx(np.exp(-3.0))  # chi2 with 2 dof: survival exp(-x/2)
    assert set(fr.nemenyi.columns) == {"a", "b", "c"}


def test_a_single_optimizer_gets_notes_not_errors(tmp_path):
    objective_job(tmp_path, "solo", 20, [1.0, 2.0])
    df = runs_frame(load_records([tmp_path]).records)
    assert "needs at least 2 optimizers" in stats.kruskal_by_context(df)["note"].iloc[0]
    assert stats.pairwise_by_context(df).empty


def test_context_splits_on_varying_problem_keys_only(tmp_path):
    for level in (0.0, 0.05):
        recs = [record(problem="toy", optimizer="a", ps=20, run_index=i, x=np.ones(2),
                       f=float(i), names=["x1", "x2"], true=None,
                       problem_extra={"noise": {"level": level}}) for i in range(2)]
        write_job(tmp_path / f"lvl{level}", recs)
    objective_job(tmp_path / "s1", "a", 20, [5.0], seed=1)  # a seed alone is no context
    df = runs_frame(load_records([tmp_path]).records)
    assert sorted(df.context.unique()) == ["toy ps=20 noise.level=0",
                                           "toy ps=20 noise.level=0.05",
                                           "toy ps=20 noise.level=None"]
