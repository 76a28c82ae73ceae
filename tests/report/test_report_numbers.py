"""The report's numbers on synthetic records with known answers: the vehicle plugin's paper
data and protocol check, NoRE arithmetic, generic metric columns, rankings, significance,
effect size, Friedman, number formats and honest notes."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from report_synth import (
    DE4_PS20_MEAN,
    OV,
    PAPER_NAMES,
    UNITS,
    objective_job,
    record,
    write_job,
)
from vpid_vehicle import paper
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.report import protocol_gaps

from vpid_bench.report import render, stats, tables
from vpid_bench.report.build import build_report
from vpid_bench.report.load import load_records, run_rows, runs_frame


def paper_config(ps: int, **changes) -> dict:
    """The vehicle's problem config as a record stores it, the paper's protocol unless
    changed (``changes``: nested dicts merged one level deep)."""
    cfg = dataclasses.asdict(VehicleConfig(ps=ps, iterations=50))
    for key, value in changes.items():
        cfg[key] = {**cfg[key], **value} if isinstance(value, dict) else value
    return cfg


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


def _vehicle_job(root, algo, ps, mean, deltas, cfg=None, problem="vehicle"):
    """Runs whose identified vectors average exactly to ``mean`` (paper protocol unless
    ``cfg`` says otherwise)."""
    recs = []
    for i, d in enumerate(deltas):
        for j, sign in enumerate((1.0, -1.0)):
            x = mean * (1.0 + sign * d)
            recs.append(record(problem=problem, optimizer=algo, ps=ps, run_index=2 * i + j,
                               x=x, f=0.01 + d, names=PAPER_NAMES, true=OV, iterations=50,
                               problem_extra=cfg or paper_config(ps), units=UNITS))
    return write_job(root / f"{algo}-{ps}", recs)


def _csv(path):
    import pandas as pd

    return pd.read_csv(path)


def test_paper_de4_row_gives_nore_1_51_under_the_paper_protocol(tmp_path):
    """Runs averaging to the paper's DE4 mean vector (PS = 20) under the paper's protocol:
    NoRE of the mean 1.51, the published row beside it, a zero difference, and the headline's
    `paper NoRE` column."""
    _vehicle_job(tmp_path / "s", "de4", 20, DE4_PS20_MEAN, [0.01, 0.02, 0.05])
    rep = build_report([tmp_path / "s"], tmp_path / "out", short=True)
    mv = _csv(tmp_path / "out" / "tables" / "mean_vector.csv")
    ours = mv[(mv.source == "ours") & (mv.quantity == "eps_percent")].iloc[0]
    assert ours["n_runs"] == 6 and round(ours["nore_percent"], 2) == 1.51
    mean_cols = [f"{n} [{u}]" for n, u in zip(PAPER_NAMES, UNITS, strict=True)]
    assert list(mv.columns[5:14]) == mean_cols  # units from the records' parameters.units
    np.testing.assert_allclose(
        mv[(mv.source == "ours") & (mv.quantity == "mean")][mean_cols].to_numpy(float)[0],
        DE4_PS20_MEAN, rtol=1e-12)
    diff = mv[mv.source == "difference"].iloc[0]
    assert abs(diff["nore_percent"]) < 0.01
    assert np.all(np.abs(diff[mean_cols].to_numpy(float)) < 0.01)
    assert "Table II" in mv[mv.source == "paper"]["note"].iloc[0]
    head = _csv(tmp_path / "out" / "tables" / "headline.csv")
    assert head["paper NoRE"].iloc[0] == 1.51
    assert head["mean-vec NoRE"].iloc[0] == pytest.approx(ours["nore_percent"])
    md = rep.report_md.read_text()
    assert "de4 (paper)" in md and "the-papers-experiment-reproduced" in md
    assert "not shown" not in md


@pytest.mark.parametrize("change, gap", [
    ({"noise": {"level": 0.0}}, "noise"),
    ({"noise": {"model": "additive"}}, "noise"),
    ({"record": {"extra": 0.5}}, "record.extra=0.5"),
    ({"dt": 0.0005}, "dt=0.0005"),
    ({"bump": {"V": 30.0}}, "bump.V=30.0"),
    ({"vehicle": {"k2": 16000.0}}, "vehicle.k2=16000.0"),
    ({"reference": {"file": "x.csv"}}, "reference file"),
])
def test_protocol_gaps_name_each_departure(change, gap):
    base = record(problem="vehicle", optimizer="de4", ps=20, run_index=0, x=OV, f=0.1,
                  names=PAPER_NAMES, true=OV, iterations=50, problem_extra=paper_config(20))
    assert protocol_gaps(base) == []
    changed = record(problem="vehicle", optimizer="de4", ps=20, run_index=0, x=OV, f=0.1,
                     names=PAPER_NAMES, true=OV, iterations=50,
                     problem_extra=paper_config(20, **change))
    (line,) = protocol_gaps(changed)
    assert gap in line


def test_protocol_gaps_population_and_generations():
    other = record(problem="vehicle", optimizer="de4", ps=40, run_index=0, x=OV, f=0.1,
                   names=PAPER_NAMES, true=OV, iterations=10, problem_extra=paper_config(40))
    gaps = " ".join(protocol_gaps(other))
    assert "ps=40" in gaps and "10 generations" in gaps and "budget 440" in gaps


def test_paper_numbers_are_not_shown_outside_the_protocol(tmp_path):
    """The same runs without noise: no published row, no `paper NoRE` column, one line
    saying why."""
    cfg = paper_config(20, noise={"level": 0.0})
    _vehicle_job(tmp_path / "s", "de4", 20, DE4_PS20_MEAN, [0.01], cfg=cfg)
    rep = build_report([tmp_path / "s"], tmp_path / "out", short=True)
    mv = _csv(tmp_path / "out" / "tables" / "mean_vector.csv")
    assert set(mv.source) == {"ours"}
    head = _csv(tmp_path / "out" / "tables" / "headline.csv")
    assert "paper NoRE" not in head.columns and "mean-vec NoRE" in head.columns
    md = rep.report_md.read_text()
    (line,) = [ln for ln in md.splitlines() if "not shown" in ln]
    assert "The paper's numbers are not shown here" in line
    assert "noise multiplicative 0.0" in " ".join(md.split()) and "(paper)" not in md


def test_no_vehicle_sections_for_another_problem(tmp_path):
    _vehicle_job(tmp_path / "s", "de4", 20, DE4_PS20_MEAN, [0.01], problem="car")
    rep = build_report([tmp_path / "s"], tmp_path / "out", short=True)
    assert not (tmp_path / "out" / "tables" / "mean_vector.csv").exists()
    assert "Tables II" not in rep.report_md.read_text()


def test_generic_metric_columns(tmp_path):
    """A problem's metrics become `metric.<name>` columns; the headline ranks by the first
    metric every run of the context has, else by f."""
    recs = [record(problem="toy", optimizer="a", ps=10, run_index=i, x=np.ones(2), f=1.0 + i,
                   names=["x1", "x2"], true=None, metrics={"err": 3.0 - i, "other": 7.0})
            for i in range(3)]
    write_job(tmp_path / "s" / "a", recs)
    # In another context one run lacks "err": that context is ranked by f.
    recs = [record(problem="toy", optimizer="a", ps=20, run_index=i, x=np.ones(2), f=5.0 + i,
                   names=["x1", "x2"], true=None,
                   metrics={"err": 1.0} if i else {"other": 2.0}) for i in range(2)]
    write_job(tmp_path / "s" / "b", recs)
    rows = run_rows(load_records([tmp_path / "s"]).records)
    by_ctx = {r["context"]: r for r in rows}
    assert by_ctx["toy ps=10"]["metric_name"] == "err"
    assert by_ctx["toy ps=20"]["metric_name"] == "f_best"
    assert {"metric.err", "metric.other"} <= set(rows[0])
    summary = {s["context"]: s for s in tables.summarize(rows)}
    assert summary["toy ps=10"]["median"] == 2.0 and summary["toy ps=10"]["other_median"] == 7.0
    assert summary["toy ps=20"]["median"] == 5.5
    rep = build_report([tmp_path / "s"], tmp_path / "out", short=True)
    head = _csv(tmp_path / "out" / "tables" / "headline.csv")
    assert list(head["metric"]) == ["err", "f_best"]
    assert "err" in rep.headline


def test_the_population_size_is_the_problems_as_its_record_states_it(tmp_path):
    """A run's ``ps`` (its context's first token and the rows' ``ps``) is the problem's
    protocol, ``problem.config.ps``: never an optimizer parameter of that name (the loader
    once read ``optimizer.params.ps`` first)."""
    recs = [record(problem="toy", optimizer="a", ps=10, run_index=i, x=np.ones(2), f=1.0 + i,
                   names=["x1", "x2"], true=None) for i in range(2)]
    for r in recs:
        r["optimizer"]["params"]["ps"] = 99
    write_job(tmp_path / "s" / "a", recs)
    rows = run_rows(load_records([tmp_path / "s"]).records)
    assert {(r["context"], r["ps"]) for r in rows} == {("toy ps=10", 10)}


def test_a_null_metric_ranks_last_and_minus_inf_stays_minus_inf(tmp_path):
    job = objective_job(tmp_path / "s", "a", 10, [1.0, 2.0, 3.0])
    path = sorted((job / "records").glob("run-*.json"))[0]
    text = path.read_text().replace('"f_best": 1.0', '"f_best": -Infinity')
    path.write_text(text)
    rows = run_rows(load_records([tmp_path / "s"]).records)
    assert rows[0]["f_best"] == -math.inf
    (s,) = tables.summarize(rows)
    assert s["best"] == -math.inf and s["f_best"] == -math.inf
    assert render.fmt(s["f_best"]) == "-inf"


@pytest.fixture
def three_optimizers(tmp_path):
    """Objective values: good < mid < bad (no overlap), twin == good in distribution."""
    rng = np.random.default_rng(1)
    good = list(1.0 + rng.random(10))
    objective_job(tmp_path, "good", 20, good)
    objective_job(tmp_path, "mid", 20, list(3.0 + rng.random(10)))
    objective_job(tmp_path, "random", 20, list(5.0 + rng.random(10)))
    objective_job(tmp_path, "twin", 20, [v + 1e-3 for v in good])
    return run_rows(load_records([tmp_path]).records)


def test_ranking_significance_and_effect_size(three_optimizers):
    rows = three_optimizers
    df = runs_frame(rows)
    assert set(df.metric_name) == {"f_best"}  # no metrics: the objective is the metric
    st = tables.summarize(rows)
    assert [s["algorithm"] for s in st] == ["good", "twin", "mid", "random"]
    assert [s["rank"] for s in st] == [1, 2, 3, 4]
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
    verdicts = dict(zip([s["algorithm"] for s in st],
                        tables.baseline_verdicts(st, stats.pairwise_by_context(df)),
                        strict=True))
    assert verdicts["random"] == "baseline"
    assert verdicts["good"].startswith("beats it")


def test_a12_matches_a_direct_count():
    from scipy import stats as ss

    x, y = np.array([1.0, 2.0, 3.0, 3.0]), np.array([3.0, 0.5, 4.0])
    direct = np.mean([(a > b) + 0.5 * (a == b) for a in x for b in y])
    u = ss.mannwhitneyu(x, y).statistic
    assert stats.a12(x, y) == pytest.approx(direct, abs=1e-12)
    assert stats.a12(x, y) == pytest.approx(u / (len(x) * len(y)), abs=1e-12)


def test_friedman_needs_blocks_and_says_so(three_optimizers):
    fr = stats.friedman_across_blocks(runs_frame(three_optimizers))
    assert fr.mean_ranks is None and "at least 5 blocks" in fr.note


def test_friedman_is_not_run_on_fewer_than_five_blocks(tmp_path):
    for ps in (20, 30, 40, 50):
        for name, base in (("a", 1.0), ("b", 2.0), ("c", 3.0)):
            objective_job(tmp_path, name, ps, [base + 0.1 * i for i in range(3)])
    fr = stats.friedman_across_blocks(runs_frame(run_rows(load_records([tmp_path]).records)))
    assert fr.mean_ranks is None and "found 4" in fr.note


def test_friedman_across_population_sizes(tmp_path):
    for ps in (20, 30, 40, 50, 60):
        for name, base in (("a", 1.0), ("b", 2.0), ("c", 3.0)):
            objective_job(tmp_path, name, ps, [base + 0.1 * i for i in range(3)])
    fr = stats.friedman_across_blocks(runs_frame(run_rows(load_records([tmp_path]).records)))
    assert list(fr.mean_ranks.index) == ["a", "b", "c"]
    np.testing.assert_allclose(fr.mean_ranks.to_numpy(), [1.0, 2.0, 3.0])
    # chi2 = 12 / (n k (k+1)) * sum(R_j^2) - 3 n (k+1), rank sums 5, 10, 15: 70 - 60
    assert fr.statistic == pytest.approx(10.0)
    # Exact permutation p: 6 of the 6^5 arrangements within blocks are as extreme.
    assert fr.p == pytest.approx(6 / 6**5) and fr.p_method.startswith("exact")
    assert set(fr.nemenyi.columns) == {"a", "b", "c"}


def test_a_single_optimizer_gets_notes_not_errors(tmp_path):
    objective_job(tmp_path, "solo", 20, [1.0, 2.0])
    df = runs_frame(run_rows(load_records([tmp_path]).records))
    assert "needs at least 2 optimizers" in stats.kruskal_by_context(df)["note"].iloc[0]
    assert stats.pairwise_by_context(df).empty


def test_context_splits_on_varying_problem_keys_only(tmp_path):
    for level in (0.0, 0.05):
        recs = [record(problem="toy", optimizer="a", ps=20, run_index=i, x=np.ones(2),
                       f=float(i), names=["x1", "x2"], true=None,
                       problem_extra={"noise": {"level": level}}) for i in range(2)]
        write_job(tmp_path / f"lvl{level}", recs)
    objective_job(tmp_path / "s1", "a", 20, [5.0], seed=1)  # a seed alone is no context
    rows = run_rows(load_records([tmp_path]).records)
    assert sorted({r["context"] for r in rows}) == ["toy ps=20 noise.level=0",
                                                    "toy ps=20 noise.level=0.05",
                                                    "toy ps=20 noise.level=None"]


def test_number_formats_are_consistent_within_a_column():
    """No `14517` beside `1.513e+04`: one format per column."""
    assert render.format_column([14517.0, 15130.4]) == ["14517", "15130"]
    assert render.format_column([0.04855, 0.1245, 28.54]) == ["0.0486", "0.1245", "28.5400"]
    sci = render.format_column([2.7e-14, 0.93, None, math.inf])
    assert sci == ["2.700e-14", "9.300e-01", "", "inf"]
    assert render.format_column([1, 2, 30]) == ["1", "2", "30"]
    assert render.format_column(["a", 1.5]) == ["a", "1.500"]


def test_hand_computed_single_job_numbers(tmp_path):
    """Run i moves only m by A[i] (relative): per-run NoRE 1, 2, 4, 10 %, plus a failed run."""
    A, F = [0.01, 0.02, 0.04, 0.10], [0.5, 0.1, 0.3, 0.2]
    recs = []
    for i, (a, f) in enumerate(zip(A, F, strict=True)):
        x = OV.copy()
        x[0] *= 1 + a
        recs.append(record(problem="vehicle", optimizer="de4", ps=20, run_index=i, x=x, f=f,
                           names=PAPER_NAMES, true=OV, iterations=50,
                           problem_extra=paper_config(20)))
    recs.append(record(problem="vehicle", optimizer="de4", ps=20, run_index=4, x=None, f=None,
                       names=PAPER_NAMES, true=OV, status="failed", iterations=50,
                       problem_extra=paper_config(20)))
    job = write_job(tmp_path / "job", recs, status="failed_runs")
    rep = build_report([job], job / "report", short=True)
    (s,) = tables.summarize(run_rows(rep.loaded.records))
    assert (s["context"], s["algorithm"], s["metric_name"]) == ("vehicle ps=20", "de4", "NoRE")
    assert (s["n_runs"], s["n_failed"]) == (4, 1)
    # numpy's linear quartiles: 1 + 0.75 (2 - 1), 4 + 0.25 (10 - 4).
    assert s["median"] == pytest.approx(3.0)
    assert (s["q1"], s["q3"], s["iqr"]) == pytest.approx((1.75, 5.5, 3.75))
    assert s["mean"] == pytest.approx(4.25)
    # sd: squared deviations 3.25², 2.25², 0.25², 5.75² sum to 48.75; / (4 - 1) = 16.25.
    assert s["sd"] == pytest.approx(math.sqrt(16.25))
    assert s["f_median"] == pytest.approx(0.25)  # f: 0.1, 0.2, 0.3, 0.5
    head = _csv(job / "report" / "tables" / "headline.csv")
    # Mean vector: m is off by the mean of A, 4.25 %, every other parameter exact.
    assert head["mean-vec NoRE"].iloc[0] == pytest.approx(4.25)
    assert head["paper NoRE"].iloc[0] == 1.51  # Table II, DE4
    flat = " ".join(rep.headline.split())  # the verdict is wrapped to the terminal
    for text in ("de4", "NoRE", "[1.75, 5.5]", "a description, not a recommendation",
                 "de4 ends a median 3 NoRE from the truth over 4 run(s)"):
        assert text in flat, text
    assert " use de4" not in flat  # a single job compares nothing: no recommendation
    # the plugin's columns (mean-vector and published NoRE) are in the detail, not the first
    # screen, where they would sit beside the per-run median as if comparable
    assert "1.51" not in rep.headline
    detail = rep.report_md.read_text().split("## Rankings in detail")[1]
    assert "paper NoRE" in detail and "1.51" in detail
    md = rep.report_md.read_text()
    assert "**Failed run** de4 on vehicle ps=20, run 4 (seed 0): RuntimeError: boom" in md
    assert "vpid-bench-report" in md and not (job / "report" / "figures").exists()
    assert any("failed_runs" in line for line in rep.failures)
    assert json.loads(json.dumps(head.to_dict()))  # plain data
