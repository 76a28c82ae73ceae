"""Runs judged against their instance's optimum: optimum files, the search-quality ranking,
rank groups, paired tests, anytime ECDF/ERT/AUC, the IOHprofiler export, block statistics."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pytest
from report_synth import OV, PAPER_NAMES, nore, record, write_job

from vpid_bench.report import anytime, stats
from vpid_bench.report.build import build_report
from vpid_bench.report.load import load_records, run_rows, runs_frame
from vpid_bench.report.optima import add_optimum_columns, load_optima

N_INST = 10


def _x_opt(i: int) -> np.ndarray:
    """Instance i's optimum: a fixed offset from the truth (NoRE about 30 %)."""
    return OV * (1 + 0.1 * np.cos(np.arange(9) + i))


def _f_opt(i: int) -> float:
    return 0.1 + 0.01 * i


def _optimum_file(folder: Path, i: int, **over) -> Path:
    data = {"schema": "vpid-bench/instance-optimum/1", "problem": "vehicle",
            "instance": f"inst{i}", "settings": {"ps": 20, "iterations": 4},
            "x_opt": _x_opt(i).tolist(), "f_opt": _f_opt(i), "f_true": _f_opt(i) * 1.2,
            "metrics": {"NoRE": nore(_x_opt(i), OV)}, "starts": 3, **over}
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"opt{i}.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def _paired_sweep(root: Path, below: bool = False) -> Path:
    """Three optimizers, one run per instance each (instance ids set: the runs pair):
    ``good`` reaches each optimum, ``early`` stops near the truth (low NoRE, 50 % above the
    optimum in f), ``random`` is far in both."""
    rng = np.random.default_rng(1)
    for algo in ("good", "early", "random"):
        recs = []
        for i in range(N_INST):
            fo = _f_opt(i)
            if algo == "good":
                x, f, tr = _x_opt(i), fo, [4 * fo, 2 * fo, 1.5 * fo, 1.1 * fo, fo]
                if below and i == 0:
                    f, tr = fo - 1e-3, [4 * fo, 2 * fo, 1.5 * fo, 1.1 * fo, fo - 1e-3]
            elif algo == "early":
                x, f, tr = OV * (1 + 0.01 * rng.standard_normal(9)), 1.5 * fo, [3 * fo] * 4 + [
                    1.5 * fo]
            else:
                x, f, tr = OV * (1 + 0.4 * rng.standard_normal(9)), 3 * fo, [9 * fo] * 4 + [
                    3 * fo]
            r = record(problem="vehicle", optimizer=algo, ps=20, run_index=i, x=x, f=f,
                       names=PAPER_NAMES, true=OV, trace_best=tr)
            r["instance"]["id"] = f"inst{i}"
            r["parameters"]["lower"] = (0.5 * OV).tolist()
            r["parameters"]["upper"] = (1.5 * OV).tolist()
            recs.append(r)
        write_job(root / f"optimizer={algo}", recs)
    for i in range(N_INST):
        _optimum_file(root / "optima", i)
    return root


def test_optimum_columns_hand_checked_and_bad_files_skipped(tmp_path):
    root = _paired_sweep(tmp_path, below=True)
    (root / "optima" / "bad.json").write_text(json.dumps({"schema": "vpid-bench/instance-"
                                                          "optimum/1", "f_opt": "x"}))
    _optimum_file(root / "optima" / "other", 0)  # not a folder the report reads
    loaded = load_records([root])
    rows = run_rows(loaded.records)
    index = load_optima([root], loaded.records)
    assert len(index.optima) == N_INST
    assert [p.name for p, _ in index.skipped] == ["bad.json"]
    assert "problem: expected a text" in index.skipped[0][1]
    notes = add_optimum_columns(rows, loaded.records, index)
    assert len(notes) == 1 and "below its instance's optimum" in notes[0]
    early = next(r for r in rows if r["algorithm"] == "early" and r["run_index"] == 2)
    assert early["instance"] == "inst2"
    assert early["f_opt"] == pytest.approx(_f_opt(2))
    assert early["gap"] == pytest.approx(0.5 * _f_opt(2))
    assert early["rel_gap"] == pytest.approx(0.5)
    assert early["nore_floor"] == pytest.approx(nore(_x_opt(2), OV))
    x = np.array([early[f"x.{p}"] for p in PAPER_NAMES])
    assert early["nore_to_opt"] == pytest.approx(
        100 * np.linalg.norm((x - _x_opt(2)) / OV), rel=1e-12)
    below = next(r for r in rows if r["algorithm"] == "good" and r["run_index"] == 0)
    assert below["gap"] == pytest.approx(-1e-3)  # kept negative, never hidden
    cols = list(rows[0])
    assert cols[cols.index("metric_name") + 1:][:6] == [
        "instance", "f_opt", "gap", "rel_gap", "nore_floor", "nore_to_opt"]


def test_an_optimum_of_another_record_is_not_used(tmp_path):
    root = _paired_sweep(tmp_path)
    for p in (root / "optima").glob("*.json"):
        p.unlink()
    _optimum_file(root / "optima", 0, settings={"ps": 30, "iterations": 9, "noise": 0.1})
    _optimum_file(root / "optima" / "..", 1)  # the folder above the sweep: not read
    loaded = load_records([root])
    rows = run_rows(loaded.records)
    add_optimum_columns(rows, loaded.records, load_optima([root], loaded.records))
    assert all(math.isnan(r["f_opt"]) for r in rows)


def test_compact_letters_on_a_hand_built_p_value_matrix():
    names = ["A", "B", "C", "D"]
    p = np.array([[1, 0.30, 0.01, 0.001],
                  [0.30, 1, 0.20, 0.02],
                  [0.01, 0.20, 1, 0.40],
                  [0.001, 0.02, 0.40, 1]])
    diff = {frozenset((names[i], names[j])) for i, j in itertools.combinations(range(4), 2)
            if p[i, j] < 0.05}
    assert stats.compact_letters(names, diff) == {"A": "a", "B": "ab", "C": "bc", "D": "c"}
    assert stats.compact_letters(names, set()) == dict.fromkeys(names, "a")
    every = {frozenset(c) for c in itertools.combinations(names, 2)}
    assert stats.compact_letters(names, every) == {"A": "a", "B": "b", "C": "c", "D": "d"}
    # Two letters shared: every unseparated pair shares one, every separated pair none.
    diff2 = {frozenset(("A", "C")), frozenset(("B", "D"))}
    got = stats.compact_letters(names, diff2)
    for a, b in itertools.combinations(names, 2):
        assert bool(set(got[a]) & set(got[b])) == (frozenset((a, b)) not in diff2)


def _signed_rank_p(d: np.ndarray) -> float:
    """Brute force: two-sided p of the Wilcoxon statistic over all 2^n sign flips."""
    r = np.argsort(np.argsort(np.abs(d))) + 1.0
    obs = min(r[d > 0].sum(), r[d < 0].sum())
    stat = [min(r[np.array(s) > 0].sum(), r[np.array(s) < 0].sum())
            for s in itertools.product([-1, 1], repeat=len(d))]
    return float(np.mean(np.array(stat) <= obs + 1e-12))


def test_paired_wilcoxon_is_exact_against_enumeration():
    x = np.array([1.0, 2.5, 3.1, 4.7, 5.2, 6.9, 7.4])
    y = x + np.array([0.3, -0.11, 0.52, 0.74, 0.9, -0.05, 1.3])
    _, p, how = stats.wilcoxon_paired(x, y)
    assert how == "exact"
    assert p == pytest.approx(_signed_rank_p(x - y), rel=1e-12)


def test_friedman_permutation_p_against_brute_force():
    t = np.random.default_rng(3).random((4, 3))
    from scipy.stats import rankdata

    def s(tt):
        return np.sum(rankdata(tt, axis=1).sum(axis=0) ** 2)

    s0 = s(t)
    perms = list(itertools.permutations(range(3)))
    count = [s(np.array([t[i, list(p)] for i, p in enumerate(arr)])) >= s0 - 1e-9
             for arr in itertools.product(perms, repeat=4)]
    chi2, p, how = stats.friedman_test(t)
    assert how.startswith("exact") and p == pytest.approx(np.mean(count), rel=1e-12)
    # Friedman's chi-square by hand: 12 / (n k (k+1)) * sum R_j^2 - 3 n (k+1)
    r = rankdata(t, axis=1).sum(axis=0)
    assert chi2 == pytest.approx(12 / (4 * 3 * 4) * np.sum(r**2) - 3 * 4 * 4)


def test_ecdf_ert_and_auc_on_hand_built_traces():
    # Run A: rel_gap 0.5 after 10 evaluations, 0.05 after 100; run B: 2 then 0.5.
    a = anytime.RunHits("c", "x", 1000.0, 100.0,
                        anytime.hit_times([10, 100], [0.5, 0.05], targets=(1.0, 0.1)))
    b = anytime.RunHits("c", "x", 1000.0, 100.0,
                        anytime.hit_times([10, 100], [2.0, 0.5], targets=(1.0, 0.1)))
    assert a.hits == (10.0, 100.0) and b.hits[0] == 100.0 and math.isnan(b.hits[1])
    np.testing.assert_allclose(anytime.ecdf([a, b], [5, 10, 50, 100, 1000]),
                               [0, 0.25, 0.25, 0.75, 0.75])
    assert anytime.ert([a, b], 0) == pytest.approx((10 + 100) / 2)
    assert anytime.ert([a, b], 1) == pytest.approx((100 + 100) / 1)  # B spent all 100
    c = anytime.RunHits("c", "x", 1000.0, 100.0, (math.nan, math.nan))
    assert anytime.ert([c], 0) == math.inf
    # AUC over log evaluations 1..1000: pairs hit at 10, 100, 100, never: (2/3+1/3+1/3+0)/4
    assert anytime.auc([a, b], 1000.0) == pytest.approx(1 / 3)
    assert anytime.auc([anytime.RunHits("c", "x", 1000.0, 1.0, (1.0, 1.0))]) == 1.0


def test_paired_report_ranks_twice_with_groups_and_explains_the_disagreement(tmp_path):
    root = _paired_sweep(tmp_path)
    rep = build_report([root], root / "report")
    md = rep.report_md.read_text(encoding="utf-8")
    assert max(len(line) for line in md.splitlines()) <= 120
    flat = " ".join(md.split())  # prose is wrapped: compare phrases across line breaks
    assert "Wilcoxon signed-rank, paired by instance" in flat
    assert "By search quality" in md and "| reached |" in md and f"{N_INST}/{N_INST}" in md
    # the first screen: the ranking, the floor beside it and a verdict to act on
    results = flat.split("## Rankings in detail")[0]
    assert "Ranked by NoRE, lower is better (floor 21.4)." in results
    assert ("Verdict for vehicle ps=20: use good (it gets closest to each record's own "
            "optimum; early ends nearer the truth by NoRE but searches worse; against early: "
            "p_holm") in results  # the effect size beside the pick
    assert "A12=" in results.split("ps=20: use good")[1].split(")")[0]
    assert "More search will not help here" in results
    assert ("The rankings of vehicle ps=20 disagree beyond ties (medians within 0.001 "
            "relative count as equal): early ranks 1 by NoRE but 2") in flat
    assert "below the median floor" in flat and "centred on the true values" in flat
    # 6 instances are the blocks: Friedman runs per context; 1 context: not across contexts.
    assert "instances as blocks" in flat
    head = (root / "report" / "tables" / "headline.csv").read_text().splitlines()
    assert head[0].startswith("context,rank,group,")
    sq = (root / "report" / "tables" / "search_quality.csv").read_text().splitlines()
    assert sq[1].split(",")[3] == "good" and sq[1].split(",")[5] == str(N_INST)
    ert = (root / "report" / "tables" / "ert.csv").read_text().splitlines()
    assert f"vehicle ps=20,random,1e-06,{N_INST},0,inf,inf,inf" in ert
    assert (root / "report" / "figures" / "ecdf_vehicle_ps=20.png").stat().st_size > 5000
    assert not rep.failures


def test_ioh_export_loads_in_iohinspector(tmp_path):
    ih = pytest.importorskip("iohinspector")
    from vpid_bench.store.ioh import export_ioh

    root = _paired_sweep(tmp_path)
    loaded = load_records([root])
    rows = run_rows(loaded.records)
    add_optimum_columns(rows, loaded.records, load_optima([root], loaded.records))
    files = export_ioh(tmp_path / "out" / "ioh", loaded.records, rows, tmp_path / "out")
    assert len(files) == 6  # per optimizer: the JSON meta-data and one .dat
    dm = ih.DataManager()
    dm.add_folder(str(tmp_path / "out" / "ioh"))
    ov = dm.overview
    assert ov.height == 3 * N_INST
    assert sorted(set(ov["algorithm_name"])) == ["early", "good", "random"]
    good = ov.filter(ov["algorithm_name"] == "good")
    np.testing.assert_allclose(sorted(good["best_y"]), 0.0, atol=1e-15)  # raw_y = f - f_opt
    data = dm.load(monotonic=True, include_meta_data=True)
    pl = pytest.importorskip("polars")
    last = data.group_by("data_id").agg(pl.col("evaluations").max().alias("e"))
    assert set(last["e"]) == {100}  # each run ends with its last evaluation (the budget)


def test_block_statistics_need_five_instances(tmp_path):
    root = _paired_sweep(tmp_path)
    df = runs_frame(run_rows(load_records([root]).records))
    df["instance"] = [f"inst{i}" for i in df["run_index"]]
    res = stats.friedman_by_instances(df)["vehicle ps=20"]
    assert res.mean_ranks is not None and len(res.blocks) == N_INST
    few = stats.friedman_by_instances(df[df["run_index"] < 4])["vehicle ps=20"]
    assert few.note.endswith("found 4")
    assert few.mean_ranks is None and "at least 5 blocks" in few.note


@pytest.mark.parametrize("n", [14, pytest.param(30, marks=pytest.mark.slow), 50])  # 30: -m slow
def test_the_fast_wilcoxon_permutation_test_is_scipys(n):
    """With ties or zero differences (14 <= n <= 50) the paired Wilcoxon test is a seeded
    permutation test; the report's vectorised version gives scipy's statistic and p-value
    exactly (scipy's calls the statistic once per resample: 50 times slower)."""
    import warnings

    from scipy.stats import wilcoxon

    rng = np.random.default_rng(n)
    for shift in (0.0, 0.3, 1.0):
        x = np.round(rng.normal(0.0, 1.0, n), 1)
        y = np.round(rng.normal(shift, 1.0, n), 1)
        x[:2] = y[:2]  # zero differences
        w, p, how = stats.wilcoxon_paired(x, y)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = wilcoxon(x, y, method=stats._permutation())
        assert how.startswith("permutation")
        assert (w, p) == (float(ref.statistic), float(ref.pvalue))
