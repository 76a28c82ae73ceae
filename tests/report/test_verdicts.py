"""The verdict rules (docs/report.md, "Verdicts"), each on synthetic evidence whose answer is
known, and their words: whom to use, or why no one, and what limits the accuracy."""

from __future__ import annotations

import dataclasses
import math
import statistics

import pytest

from vpid_bench.report import verdicts as vd
from vpid_bench.report.first_screen import ContextResult, terminal_text, verdict_text
from vpid_bench.report.verdicts import Evidence, Method, Search


def _pair(a, b, better=None, p=0.5):
    """One row of the metric's pairwise tests: ``better`` significantly lower, or neither."""
    return {"a": a, "b": b, "significant": better is not None, "better": better or "",
            "p_holm": p if better is None else 1e-4, "p_at_floor": False,
            "A12": 0.5 if better is None else (0.0 if better == a else 1.0),
            "A12_lo": 0.4, "A12_hi": 0.6}


def _search(reached, gap, group, evaluations=math.inf, seconds=math.nan, runs=30):
    return Search(reached, runs, gap, group, evaluations, seconds)


def _refs_beaten(names, refs=("random", "centre")):
    return [_pair(n, r, better=n) for n in names for r in refs]


def _evidence(methods, pairs, refs=("random", "centre"), **kw):
    base = dict(context="c", metric="NoRE", unit="%", methods=tuple(methods), tested=True,
                pairs=tuple(pairs), references=tuple(refs))
    return Evidence(**(base | kw))


REFS = [Method("random", 30, 70.0, "c"), Method("centre", 30, 55.0, "b")]


def test_a_tie_on_the_metric_is_broken_by_search_quality():
    """de_lsq and lsq tie on NoRE (one rank group); ``early`` ranks first by the metric but the
    search tests put lsq ahead of it: lsq is used, because it searches better."""
    methods = [Method("early", 30, 0.50, "a", _search(0, 0.04, "b")),
               Method("lsq", 30, 0.53, "a", _search(30, 1e-14, "a", 23.7, 0.02)),
               *REFS]
    pairs = [_pair("early", "lsq"), *_refs_beaten(["early", "lsq"])]
    v = vd.decide(_evidence(methods, pairs))
    assert (v.kind, v.pick, v.basis, v.tied) == (vd.USE, "lsq", vd.SEARCH, ("early",))
    text = verdict_text(v)
    assert text.startswith("Verdict for c: use lsq (the tests do not separate it from early "
                           "by NoRE at 30 runs each")
    assert "it searches better" in text


def test_a_tie_on_the_metric_and_on_search_is_broken_by_cost():
    """smoke_quarter's case: de_lsq ranks first by a hair, both reach every optimum (de_lsq
    with the smaller median gap, below the reach threshold: a tie); lsq reaches it in 23.7
    evaluations (ERT) against 130.4, so lsq is used."""
    methods = [Method("de_lsq", 30, 0.5255, "a", _search(30, 6.4e-15, "a", 130.4, 0.016)),
               Method("lsq", 30, 0.5255, "a", _search(30, 1.3e-14, "a", 23.7, 0.020)),
               *REFS]
    pairs = [_pair("de_lsq", "lsq"), *_refs_beaten(["de_lsq", "lsq"])]
    v = vd.decide(_evidence(methods, pairs))
    assert (v.kind, v.pick, v.basis) == (vd.USE, "lsq", vd.COST)
    assert [c.name for c in v.costs] == ["lsq", "de_lsq"]
    text = verdict_text(v)
    assert "use lsq" in text and "23.7 evaluations to it (ERT) against 130 for de_lsq" in text
    assert "0.02 s against 0.016 s for de_lsq" in text  # the seconds stated, not hidden


def test_evaluations_within_the_cost_tie_leave_it_to_the_seconds_then_to_the_order():
    a = Method("a", 30, 1.0, "a", _search(30, 0.0, "a", 100.0, 2.0))
    b = Method("b", 30, 1.0, "a", _search(30, 0.0, "a", 105.0, 1.0))  # within 10 %
    pairs = [_pair("a", "b"), *_refs_beaten(["a", "b"])]
    v = vd.decide(_evidence([a, b, *REFS], pairs))
    assert (v.pick, v.basis) == ("b", vd.COST)
    b_same = Method("b", 30, 1.0, "a", _search(30, 0.0, "a", 105.0, 1.95))
    v = vd.decide(_evidence([a, b_same, *REFS], pairs))
    assert (v.pick, v.basis) == ("a", vd.ORDER)  # tied on everything: the metric's first
    assert "the first of them by the median" in verdict_text(v)


def test_the_metric_leaders_that_search_worse_lose_to_the_best_searcher():
    """A run ending below its record's optimum did not search better: where the metric's
    leader is separated from the best searcher, the best searcher is named."""
    methods = [Method("early", 30, 2.4, "a", _search(0, 0.5, "b")),
               Method("good", 30, 21.4, "b", _search(30, 0.0, "a", 50.0)), *REFS]
    pairs = [_pair("early", "good", better="early"), *_refs_beaten(["early", "good"])]
    v = vd.decide(_evidence(methods, pairs))
    assert (v.pick, v.basis, v.leaders) == ("good", vd.SEARCH_ONLY, ("early",))
    assert v.tied == ()  # early is separated from good: not "not separated"
    assert "it gets closest to each record's own optimum; early ends nearer" in verdict_text(v)


@pytest.mark.parametrize("beaten", [(), ("random",), ("centre",)])
def test_no_use_where_no_method_is_separated_from_random_search_or_the_box_centre(beaten):
    """smoke_lateral_mf's case: the tests separate no optimizer from random search (or the
    box centre): no method is shown to identify the model from this record, and the verdict
    says why, with the runs the tests had; only a bound above 100 % says flatly that no method
    identifies it (smoke_lateral_mf has both): on vpid1_l_civic_sine fifteen optimizers reach
    a 2.8 % floor that the tests at 15 runs do not separate from random search."""
    methods = [Method("de_lsq", 30, 36.0, "ab", _search(26, 1e-12, "a", 205.0)),
               Method("lsq", 30, 39.2, "ab", _search(28, 1e-12, "a", 100.0)), *REFS]
    pairs = [_pair("de_lsq", "lsq"), *_refs_beaten(["de_lsq", "lsq"], beaten)]
    v = vd.decide(_evidence(methods, pairs))
    assert v.kind == vd.NONE and v.pick == "de_lsq"
    missing = {"random", "centre"} - set(beaten)
    assert set(v.not_beaten) == missing
    text = verdict_text(v)
    assert " use " not in text
    assert "no method is shown to identify this model from this record" in text
    assert "pairwise tests at 30 runs each" in text
    assert all(f"({name})" in text.split(". The lowest")[0] for name in missing)


def test_a_method_must_beat_every_reference_and_is_never_a_reference_itself():
    """``a`` beats random only, ``b`` beats both: b is used although a ranks first. The box
    centre, ranked first here, is never recommended."""
    methods = [Method("centre", 30, 10.0, "a"), Method("a", 30, 11.0, "a"),
               Method("b", 30, 12.0, "a"), Method("random", 30, 70.0, "b")]
    pairs = [_pair("a", "random", "a"), _pair("b", "random", "b"), _pair("b", "centre", "b"),
             _pair("a", "centre"), _pair("a", "b")]
    v = vd.decide(_evidence(methods, pairs))
    assert (v.kind, v.pick) == (vd.USE, "b")


def test_no_use_where_the_bound_exceeds_100_percent():
    methods = [Method("lsq", 30, 39.2, "a", _search(28, 1e-12, "a", 100.0)), *REFS]
    pairs = _refs_beaten(["lsq"])
    v = vd.decide(_evidence(methods, pairs, floors={i: 39.0 for i in range(5)},
                            bounds={i: 389.0 for i in range(5)}))
    assert v.kind == vd.NONE and v.over_bound and v.not_beaten == ()
    text = verdict_text(v)
    assert "no method identifies this model" in text and "bound norm is 389 %, above 100 %" in text
    ok = vd.decide(_evidence(methods, pairs, bounds={i: 99.0 for i in range(5)}))
    assert ok.kind == vd.USE


def test_floor_against_bound_is_a_median_per_instance():
    """Instance 0's bound (25) is above every floor (10), but the other instances' bounds
    are 3: the median of floor / bound is 3.3, not 0.4."""
    floors = {0: 10.0, 1: 10.0, 2: 10.0}
    bounds = {0: 25.0, 1: 3.0, 2: 3.0}
    assert vd.floor_over_bound(floors, bounds) == pytest.approx(10 / 3)
    assert vd.floor_over_bound(floors, {0: 25.0}) == pytest.approx(0.4)
    assert math.isnan(vd.floor_over_bound(floors, {5: 1.0}))
    assert vd.floor_over_bound({0: 1.0, 1: 9.0}, {0: 0.0, 1: 3.0}) == 3.0  # no zero bound


ESTIMATORS = {"metric": "NoRE", "instances": 5, "chosen": "eq3",
              "floors": {"eq3": {"median": 27.1, "values": [27.1] * 5},
                         "ols": {"median": 31.4, "values": [31.4] * 5},
                         "ml": {"median": 0.953, "values": [0.953] * 5}}}


@pytest.mark.parametrize("leader", [37.4, 27.1])
def test_the_estimator_is_named_as_the_bottleneck_at_any_budget(leader):
    """The paper's case: Eq. 3's floor is 33 times the bound. Whether the leader still has
    search to do (37.4 %, 1.4× the floor) or sits on the floor, the verdict names the
    estimator and what ``problem.objective=ml`` gains."""
    methods = [Method("de4", 30, leader, "a", _search(0, 0.005, "a")),
               Method("ga", 30, 61.8, "b", _search(0, 1.1, "b")), *REFS]
    pairs = [_pair("de4", "ga", "de4"), *_refs_beaten(["de4", "ga"])]
    n = 30
    v = vd.decide(_evidence(methods, pairs, floors={i: 27.1 for i in range(n)},
                            bounds={i: 0.826 for i in range(n)}, estimator="eq3",
                            estimator_floors=ESTIMATORS))
    assert v.advice is not None and v.advice.better == "ml"
    assert v.limit == (vd.LIMIT_SEARCH if leader > 30 else vd.LIMIT_ESTIMATOR)
    text = " ".join(verdict_text(v).split())
    assert "The estimator is the bottleneck" in text and "33×" in text
    assert "problem.objective=ml" in text and "0.953 % from the truth" in text
    assert "28× closer" in text
    near = vd.decide(_evidence(methods, pairs, floors={i: 1.5 for i in range(n)},
                               bounds={i: 0.826 for i in range(n)}, estimator="eq3",
                               estimator_floors=ESTIMATORS))
    assert near.advice is None and "objective=ml" not in verdict_text(near)


def test_a_single_job_gets_a_description_not_a_recommendation():
    one = vd.decide(_evidence([Method("de4", 30, 37.4, "")], [], refs=(), tested=False,
                              missing=("random", "centre")))
    assert one.kind == vd.DESCRIBE and one.single
    untested = vd.decide(_evidence([Method("de4", 30, 37.4), Method("random", 30, 60.0)], [],
                                   refs=("random",), tested=False))
    assert untested.kind == vd.DESCRIBE and untested.pick == "de4"
    for v in (one, untested):
        text = verdict_text(v)
        assert "a description, not a recommendation" in text and " use " not in text
        assert "de4 ends a median 37.4 % NoRE from the truth over 30 run(s)" in text


def test_references_not_run_are_said():
    methods = [Method("de4", 30, 37.4, "a"), Method("ga", 30, 61.8, "b")]
    v = vd.decide(_evidence(methods, [_pair("de4", "ga", "de4")], refs=(),
                            missing=("random", "centre")))
    assert (v.kind, v.pick) == (vd.USE, "de4")
    assert ("random search (random) and the box centre (centre) were not run: nothing here "
            "shows that de4 beats them") in verdict_text(v)


def test_verdicts_wrap_to_the_terminals_width(monkeypatch):
    methods = [Method("de_lsq", 30, 36.0, "a"), Method("lsq", 30, 39.2, "a"), *REFS]
    v = vd.decide(_evidence(methods, [_pair("de_lsq", "lsq"), *_refs_beaten(["lsq"], ())],
                            floors={0: 39.0}, bounds={0: 389.0}))
    res = ContextResult("c", "NoRE", "%", ["optimizer"], [["lsq"]], v.floor, v.bound,
                        verdict_text(v), True, v)
    assert len(verdict_text(v)) > 300
    for width in (60, 100):
        monkeypatch.setattr("shutil.get_terminal_size", lambda fallback=None, w=width:
                            __import__("os").terminal_size((w, 24)))
        lines = terminal_text([res]).splitlines()
        assert max(len(line) for line in lines[3:]) <= width
        assert len(lines) > 4


@pytest.mark.parametrize("problems, ps, shown", [
    (("vehicle",), (20, 30), False),  # two population sizes of one problem: one problem
    (("vehicle", "vehicle_b"), (20,), True),
])
def test_across_the_suite_needs_two_distinct_problems(tmp_path, problems, ps, shown):
    from report_synth import paired_sweep

    from vpid_bench.report import build
    from vpid_bench.report.compute import compute

    roots = [paired_sweep(tmp_path / p, p, ps) for p in problems]
    data = compute(roots, True, 0.05, "random")
    assert len(data.contexts) == 2 and len({h.context for h in data.hits}) == 2
    suite, files = build._suite_scores(data, object(), build._Names(tmp_path / "out"))
    assert (suite is not None) == shown and bool(files) == shown


def test_the_terminal_never_breaks_a_line_inside_a_name():
    """A name's own words never start a terminal line (a hostile name could look like a
    table row there); the text has no trace of the marks that keep names whole, nor of the
    Markdown escapes that keep it inert in report.md (the terminal once showed ``\\|``)."""
    name = "forged | row with many words inside"
    methods = [Method(name, 30, 1.0, "a"), Method("random", 30, 9.0, "b")]
    v = vd.decide(_evidence(methods, [_pair(name, "random", name)], refs=("random",)))
    res = ContextResult("ctx with spaces", "NoRE", "%", ["optimizer"], [["x"]], v.floor,
                        v.bound, verdict_text(v), True, v)
    for width in (40, 50, 60, 70):
        lines = terminal_text([res], width=width).splitlines()[4:]
        assert not any(line.startswith(("row", "with", "many", "words", "inside", "spaces"))
                       for line in lines), lines
        flat = " ".join(" ".join(lines).split())
        assert "use forged | row with many words inside" in flat  # the name as given
        assert "\x02" not in flat and "\x03" not in flat and "\u00a0" not in flat
    assert "\x02" not in res.verdict and "use forged \\| row with" in res.verdict


def test_each_instances_floor_meets_its_own_bound_from_the_jobs_file(tmp_path):
    """The jobs' identifiability.json lists each instance's bound: instance 0's is far above
    every floor, the others' far below. The verdict compares per instance (the estimator is
    named), where instance 0's bound alone would have hidden it."""
    import json

    from report_synth import paired_sweep

    from vpid_bench.report.compute import compute
    from vpid_bench.report.first_screen import evidence

    root = paired_sweep(tmp_path / "s", "vehicle", (20,), instances=6)
    norms = {f"inst{k}": (500.0 if k == 0 else 1.0) for k in range(6)}
    crb = {"names": ["m", "I", "m1", "m2", "k1", "k2", "c1", "c2", "a1"],
           "crb_percent": [1.0] * 9, "crb_norm_percent": 500.0, "singular_values": [1.0],
           "condition_number": 1.0, "sigma": [1.0],
           "instances": [{"instance": i, "runs": [k], "crb_percent": [1.0] * 9,
                          "crb_norm_percent": n} for k, (i, n) in enumerate(norms.items())]}
    for job in root.glob("problem=*"):
        (job / "identifiability.json").write_text(json.dumps(crb))
    data = compute([root], True, 0.05, "random")
    (context,) = data.contexts
    assert data.instance_bounds[context] == norms and data.bounds[context] == 500.0
    ev = evidence(data, context)
    floors = data.floors(context)
    assert set(floors) == set(norms) and all(10 < f < 40 for f in floors.values())
    v = vd.decide(ev)
    assert v.ratio == pytest.approx(statistics.median(floors[k] / norms[k] for k in norms))
    assert v.bound == 1.0 and v.advice is not None
    text = " ".join(verdict_text(v).split())
    assert "median of each instance's own, 1 to 500" in text
    assert "The estimator is the bottleneck" in text
    one = vd.decide(dataclasses.replace(ev, bounds={k: 500.0 for k in floors}))
    assert one.advice is None and one.below_bound  # instance 0's bound for all: hidden


def test_the_papers_sweep_names_objective_ml_on_its_first_screen(tmp_path):
    """The Done-when of issue 32: the README's sweep (here at a tiny budget, where search
    still gains) names the estimator as the bottleneck and what ``problem.objective=ml``
    gains, on the terminal's first screen, wrapped to the terminal's width."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "sweeps"))
    from sweep_helpers import run_cli

    done = run_cli(["-m", "optimizer=de1,de4", "problem.ps=6", "problem.iterations=2",
                    "runs=2", "progress=false", "archive=false",
                    f"hydra.sweep.dir={tmp_path / 's'}"], tmp_path, env={"COLUMNS": "90"},
                   timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    screen = done.stdout.split("report:")[0]
    verdict = screen[screen.index("Verdict for vehicle ps=6"):]
    assert max(len(line) for line in verdict.splitlines()) <= 90
    flat = " ".join(verdict.split())
    assert "A larger budget or a better optimizer would still gain" in flat
    assert "The estimator is the bottleneck" in flat and "problem.objective=ml" in flat
