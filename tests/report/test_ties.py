"""Ties are ties (vpid_bench/report/ties.py): runs at one optimum (objective values within
1e-8 relative) are tied in every test, rank column and verdict, and the tie goes to the
cheaper method, on a truth problem and on a no-truth problem."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from report_synth import OV, PAPER_NAMES, optimum_file, record, write_job

from vpid_bench.report import body
from vpid_bench.report.compute import compute
from vpid_bench.report.first_screen import markdown_lines, results
from vpid_bench.report.ties import OBJECTIVE_RTOL, by_cost, rank_with_ties, same, snap_ties

#: Three optimizers at the same optimum, their last digits apart (consistent signs, so a
#: paired test on the raw values would separate them), reaching it after these batches.
METHODS = (("dear", 3e-12, 5), ("cheap", 2e-12, 2), ("mid", 1e-12, 4))
INSTANCES = 8


def _trace(f: float, at: int) -> list[float]:
    """Best-so-far over 5 batches, reaching ``f`` at batch ``at`` (1-based)."""
    return [f * (1 + 0.5 * max(0, at - 1 - i)) for i in range(5)]


def _truth_sweep(root):
    for k in range(INSTANCES):
        x_opt = OV * (1 + 0.05 * np.cos(np.arange(9) + k))
        optimum_file(root / "optima", "vehicle", f"inst{k}", x_opt, 0.1 + 0.01 * k, OV)
    for name, eps, at in METHODS:
        recs = []
        for k in range(INSTANCES):
            fo = 0.1 + 0.01 * k
            x_opt = OV * (1 + 0.05 * np.cos(np.arange(9) + k))
            x = OV + (x_opt - OV) * (1 + eps * 1e3)  # NoRE larger by that factor
            r = record(problem="vehicle", optimizer=name, ps=20, run_index=k, x=x,
                       f=fo * (1 + eps), names=PAPER_NAMES, true=OV,
                       trace_best=_trace(fo * (1 + eps), at))
            r["instance"]["id"] = f"inst{k}"
            recs.append(r)
        write_job(root / f"optimizer={name}", recs)
    return root


def _no_truth_sweep(root):
    f0 = 2.591
    (root / "optima").mkdir(parents=True)
    (root / "optima" / "rig.json").write_text(json.dumps({
        "schema": "vpid-bench/instance-optimum/1", "problem": "rig", "instance": None,
        "settings": {"ps": 20, "iterations": 4}, "x_opt": [1.0, -1.0], "f_opt": f0,
        "f_true": None, "metrics": {}, "starts": 3}))
    for name, eps, at in METHODS:
        recs = [record(problem="rig", optimizer=name, ps=20, run_index=i,
                       x=np.array([1.0 + eps, -1.0]), f=f0 * (1 + eps * (1 + 0.1 * i)),
                       names=["x1", "x2"], true=None, trace_best=_trace(f0 * (1 + eps), at))
                for i in range(INSTANCES)]
        write_job(root / f"optimizer={name}", recs)
    return root


@pytest.mark.parametrize("make", [_truth_sweep, _no_truth_sweep], ids=["truth", "no_truth"])
def test_three_optimizers_at_one_optimum_tie_and_the_cheapest_is_the_verdict(tmp_path, make):
    root = make(tmp_path)
    data = compute([root], short=False, alpha=0.05, baseline="de4")
    (r,) = results(data)
    ranks = [row[0] for row in r.rows]
    order = [row[r.headers.index("optimizer")] for row in r.rows]
    assert ranks == ["1=", "1=", "1="] and order == ["cheap", "mid", "dear"]
    assert r.decision.kind == "use" and r.decision.pick == "cheap"
    assert set(r.decision.tied) == {"mid", "dear"}
    pairs = data.tests.pairs
    assert len(pairs) == 3 and not pairs["significant"].any()
    assert set(data.groups("metric", r.context).values()) == {"a"}
    t = data.tests
    md = "\n".join(body.tests_md(t.kw, t.pairs, t.fr, data.alpha, t.by_inst))
    assert "0 of 3 pairs differ significantly" in md
    assert "Row 1" not in "\n".join(markdown_lines([r]))  # row 1 is the verdict's choice


def test_snap_ties_only_within_the_tolerance_and_the_same_instance():
    rec = {"a": {"instance": {"id": "i0"}}, "b": {"instance": {"id": "i0"}},
           "c": {"instance": {"id": "i0"}}, "d": {"instance": {"id": "i1"}}}
    rows = [{"run_id": k, "context": "c", "status": "ok", "f_best": f, "metric": m,
             "metric.NoRE": m}
            for k, f, m in (("a", 1.0, 5.0), ("b", 1.0 + 0.5e-8, 5.1), ("c", 1.0 + 2e-8, 5.2),
                            ("d", 1.0, 9.0))]
    assert snap_ties(rows, list(rec.values()) and [dict(run_id=k, **v) for k, v in rec.items()]
                     ) == 1
    assert [r["metric"] for r in rows] == [5.0, 5.0, 5.2, 9.0]
    assert rows[1]["metric.NoRE"] == 5.0
    assert same(1.0, 1.0 + 0.9 * OBJECTIVE_RTOL) and not same(1.0, 1.0 + 2 * OBJECTIVE_RTOL)


def test_tied_medians_share_a_rank_ordered_by_evaluations_then_seconds():
    summary = [{"context": "c", "algorithm": a, "n_runs": 3, "median": m, "rank": i}
               for i, (a, m) in enumerate((("x", 1.0), ("y", 1.0), ("z", 1.0), ("w", 2.0)), 1)]
    costs = {("c", "x"): (100.0, 1.0), ("c", "y"): (50.0, 9.0), ("c", "z"): (52.0, 2.0),
             ("c", "w"): (1.0, 0.1)}
    rank_with_ties(summary, costs)
    # y and z within 10 % in evaluations: seconds decide (z); then y; then x
    assert [(s["algorithm"], s["rank_shown"], s["rank"]) for s in summary] == [
        ("z", "1=", 1), ("y", "1=", 2), ("x", "1=", 3), ("w", "4", 4)]
    assert by_cost(["p", "q"], lambda s: (math.nan, math.nan)) == ["p", "q"]
