"""Rule 5 of the verdicts (issue 43, item 3): under model error, an optimum farther from the
truth than a reference ends means the fitted model cannot identify the vehicle; reaching it
is search, never credited as identification."""

from __future__ import annotations

from vpid_bench.report import verdicts as vd
from vpid_bench.report.first_screen import verdict_text
from vpid_bench.report.verdicts import Evidence, Method, Search

WHAT = "a bilinear damper, rebound 1.5/compression 0.5 times cs (RK4); the fitted damper is linear"


def _evidence(floor: float, model_error: str = WHAT) -> Evidence:
    """vpid1_q_golden_bilinear's case: lsq reaches every optimum (61.5 % from the truth),
    random search ends at 51.9 %, the box centre at 44.7 %; lsq beats both by the tests."""
    lsq = Method("lsq", 15, floor, "a", Search(15, 15, 1e-14, "a", 40.0, 0.1))
    refs = [Method("random", 15, 51.9, "b"), Method("centre", 15, 44.7, "b")]
    pairs = tuple({"a": "lsq", "b": r, "significant": True, "better": "lsq", "p_holm": 1e-4,
                   "p_at_floor": False, "A12": 0.0, "A12_lo": 0.0, "A12_hi": 0.1}
                  for r in ("random", "centre"))
    return Evidence("vpid1_q_golden_bilinear", "NoRE", "%", (lsq, *refs), True, pairs,
                    {i: floor for i in range(15)}, {i: 0.537 for i in range(15)},
                    references=("random", "centre"), model_error=model_error)


def test_an_optimum_farther_than_the_references_is_not_identification():
    v = vd.decide(_evidence(61.5))
    assert v.kind == vd.NONE and v.pick == "lsq"
    assert dict(v.cannot_identify) == {"random": 51.9, "centre": 44.7}
    text = verdict_text(v)
    assert "the fitted model cannot identify the true system" in text
    assert "a richer fitted structure is needed" in text
    assert "use lsq" not in text and "stopped short" not in text


def test_without_model_error_or_nearer_than_the_references_the_rule_is_silent():
    """The same numbers from the fitted model's own record, and a model-error optimum nearer
    the truth than every reference: rule 5 does not apply (lsq can be used)."""
    assert vd.decide(_evidence(61.5, model_error="")).cannot_identify == ()
    near = vd.decide(_evidence(20.0))
    assert near.cannot_identify == () and near.kind == vd.USE and near.pick == "lsq"
