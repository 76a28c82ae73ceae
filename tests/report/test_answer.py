"""The answer first (issue 46, item 3): which optimizer, for which budget, with which
estimator, derived from the budget ladder, the suite scores and the verdicts (never written
by hand), at the top of the terminal's first screen and of report.md; ties stay ties."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from report_synth import OV, PAPER_NAMES, optimum_file, record, write_job

from vpid_bench.report import answer
from vpid_bench.report.build import build_report
from vpid_bench.report.ties import SHARE_TIE, share_leaders

NAN = math.nan
#: archive/vpid1's budget ladder across its 17 problems (share of (run, target) pairs solved
#: by 10·D, 100·D, 1,000·D; its runs stop at 1,000·D) and suite scores, as its report computes
#: them (tables/budget_ladder.csv, tables/suite_scores.csv), for the optimizers that matter
#: here.
VPID1 = {  # name: (10·D, 100·D, 1,000·D, score)
    "lsq": (0.9238, 0.9961, 1.0, 0.643), "de_lsq": (0.0560, 0.4011, 1.0, 0.236),
    "cmaes": (0.0599, 0.4728, 0.9798, 0.285), "de2": (0.0510, 0.2891, 0.9793, 0.227),
    "lshade": (0.0521, 0.2840, 0.9782, 0.233), "jade": (0.0482, 0.3216, 0.9759, 0.229),
    "de7": (0.0415, 0.2185, 0.9686, 0.187), "nevergrad": (0.0801, 0.5569, 0.8280, 0.273),
    "de3": (0.0594, 0.4162, 0.5866, 0.203), "random": (0.0454, 0.0969, 0.1518, 0.055),
    "centre": (0.0118, 0.0118, 0.0118, 0.012)}
USERS = frozenset({"lsq", "de_lsq"})  # their classes set wants_residuals


def _ladder(table: dict[str, tuple[float, ...]]) -> tuple[list[list], dict[str, float]]:
    return ([["all problems", k, *v[:3], NAN] for k, v in table.items()],
            {k: v[3] for k, v in table.items()})


def test_the_vpid1_ladder_gives_the_readmes_answer():
    """lsq with residuals at every budget; without: nevergrad by 10·D and 100·D, cmaes by
    1,000·D with de2, lshade and jade as many (within one point), de7 not."""
    pools = answer.pools(*_ladder(VPID1), USERS)
    assert [p.label for p in pools] == ["with residuals", "without residuals"]
    assert [r.leaders for r in pools[0].rungs] == [("lsq",), ("lsq",), ("lsq", "de_lsq")]
    assert [r.per_dim for r in pools[1].rungs] == [10, 100, 1000]
    assert [r.leaders for r in pools[1].rungs] == [
        ("nevergrad",), ("nevergrad",), ("cmaes", "lshade", "jade", "de2")]
    a = answer.Answer(pools=pools, problems=17)
    text = dict(answer.sentences(a))["Which optimizer, by budget"]
    assert text.startswith(
        "with residuals, `lsq` at every budget (10·D: 92 %, 100·D: 100 %, 1,000·D: 100 %; "
        "`de_lsq` as many by 1,000·D); without residuals, `nevergrad` by 10·D and 100·D "
        "(8 %, 56 %), `cmaes` by 1,000·D (98 %; `lshade`, `jade` and `de2` as many). "
        "Share of (run, target) pairs solved across the 17 problems")


def test_the_answer_follows_the_data_not_a_name():
    """The same ladder with cmaes and nevergrad's columns swapped names nevergrad by
    1,000·D; without optimizers that use residuals there is one answer, unlabelled."""
    swapped = dict(VPID1)
    swapped["cmaes"], swapped["nevergrad"] = VPID1["nevergrad"], VPID1["cmaes"]
    pools = answer.pools(*_ladder(swapped), USERS)
    assert pools[1].rungs[-1].leaders[0] == "nevergrad"
    assert pools[1].rungs[0].leaders == ("cmaes",)
    alone = answer.pools(*_ladder(VPID1), frozenset())
    assert [p.label for p in alone] == [""]
    assert [r.leaders[0] for r in alone[0].rungs] == ["lsq", "lsq", "lsq"]


def test_a_share_within_one_point_ties_and_the_higher_score_comes_first():
    shares = {"a": 0.98, "b": 0.98 - SHARE_TIE + 1e-9, "c": 0.98 - SHARE_TIE - 1e-6,
              "d": NAN}
    assert share_leaders(shares, {"a": 0.1, "b": 0.2, "c": 0.9}) == ("b", "a")
    assert share_leaders({"x": NAN}, {}) == ()


def test_a_reference_that_solves_as_many_is_said_and_never_named_the_leader():
    table = {"cmaes": (0.05, 0.5, 0.9, 0.3), "random": (0.052, 0.1, 0.15, 0.05)}
    pools = answer.pools(*_ladder(table), frozenset())
    first = pools[0].rungs[0]
    assert first.leaders == ("cmaes",) and first.references == ("random",)
    text = answer._pool_text(pools[0])
    assert "random search as many by 10·D: none is shown to beat it there" in text
    assert pools[0].rungs[1].references == ()


def test_a_long_tie_names_three_and_counts_the_rest():
    table = {f"o{k}": (0.02 * k, 0.05 * k, 0.97 + 0.001 * k, 0.1 * k) for k in range(8)}
    text = answer._pool_text(answer.pools(*_ladder(table), frozenset())[0])
    assert text == ("`o7` at every budget (10·D: 14 %, 100·D: 35 %, 1,000·D: 98 %; `o6`, `o5`, "
                    "`o4` and 4 more as many by 1,000·D)")


def _suite_sweep(root: Path, instances: int = 6) -> Path:
    """Two problems; on each, lsq (its class uses residuals) reaches every instance's
    optimum by its second batch, cmaes ends 10 % above it; 9 parameters, ps 9, 10·D
    evaluations each run; each instance's optimum written beside."""
    for problem in ("vehicle", "vehicle_b"):
        for k in range(instances):
            x_opt = OV * (1 + 0.1 * np.cos(np.arange(9) + k))
            optimum_file(root / "optima", problem, f"inst{k}", x_opt, 0.1 + 0.01 * k, OV)
        for algo, trace in (("lsq", (2, 1, 1, 1, 1)), ("cmaes", (4, 2, 1.5, 1.2, 1.1))):
            recs = []
            for k in range(instances):
                fo = 0.1 + 0.01 * k
                x = OV * (1 + 0.1 * np.cos(np.arange(9) + k)) * (1 + 0.01 * (trace[-1] - 1))
                r = record(problem=problem, optimizer=algo, ps=9, iterations=9, run_index=k,
                           x=x, f=fo * trace[-1], names=PAPER_NAMES, true=OV,
                           trace_best=[fo * t for t in trace])
                r["instance"]["id"] = f"inst{k}"
                recs.append(r)
            write_job(root / f"problem={problem},optimizer={algo}", recs)
    return root


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    """The report of :func:`_suite_sweep` (a few seconds): suite scores, a budget ladder, a
    verdict per problem."""
    root = _suite_sweep(tmp_path_factory.mktemp("answer"))
    rep = build_report([root], root / "report")
    assert rep.failures == []
    return rep


def test_report_md_opens_with_the_answer(suite):
    lines = suite.report_md.read_text(encoding="utf-8").splitlines()
    assert lines.index("## The answer") < 8
    head = " ".join(" ".join(lines[:15]).split())
    assert ("- **Which optimizer, by budget**: with residuals, `lsq` by 10·D (100 %); without "
            "residuals, `cmaes` by 10·D (14 %).") in head
    flat = " ".join(suite.report_md.read_text(encoding="utf-8").split())
    assert ("- **Per problem**: the verdicts at the runs' budget (10·D): use `lsq` on both "
            "problems.") in flat
    assert "| vehicle | use lsq (1 not separated) | 21.2 | | the records |" in flat
    assert "[Results](#results)" in flat
    assert flat.index("## The answer") < flat.index("## Results") < flat.index(
        "Verdict for vehicle ps=9: use lsq")


def test_the_terminal_opens_with_the_same_answer(suite):
    """The first screen of the terminal (what the command prints): the answer within its
    first 15 lines, wrapped to the width, before the first context's ranking."""
    lines = suite.headline.splitlines()
    assert lines[0] == "The answer"
    first = "\n".join(lines[:15])
    assert "Which optimizer, by budget: with residuals, lsq by 10·D (100 %); without" in first
    assert "Per problem: the verdicts at the runs' budget (10·D): use lsq on both" in first
    assert "vehicle    use lsq (1 not separated)  21.2          the records" in first
    assert suite.headline.index("The answer") < suite.headline.index("Verdict for vehicle")


def test_the_overview_opens_with_the_answer_and_readable_score_tables(suite):
    """index.html: the answer block first (before the verdicts, which sit one click away in
    a details element each); the scores and the ladder under readable headers, no raw
    column name, no empty rung."""
    html = (suite.out_dir / "index.html").read_text(encoding="utf-8")
    answer_at = html.index('<section id="answer"')
    assert answer_at < html.index('id="verdicts"') < html.index('id="suite"')
    assert "<strong>Which optimizer, by budget</strong>" in html[answer_at:]
    verdicts = html[html.index('id="verdicts"'):html.index('id="suite"')]
    assert verdicts.count("<details") == 2 and "Verdict for vehicle ps=9: use lsq" in verdicts
    for raw in ("group_kind", "score_auc", "score_lo", "solved_at_"):
        assert raw not in html, raw
    assert "score (mean AUC, 0 to 1)" in html and "solved by 10·D (%)" in html
    assert "100·D" not in html.split('id="ladder"')[1].split("</table>")[0]
