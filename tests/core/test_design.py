"""``vpid-bench-design``: candidate record designs ranked by their Cramér–Rao norm, with
D- and A-optimality, the floor beside the bound, profiles; bad input refused in one line."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from vpid_vehicle.config import RecordConfig, VehicleConfig
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.analysis.identifiability import cramer_rao
from vpid_bench.design import main


def _table(out: str) -> list[list[str]]:
    return [[c.strip() for c in line.strip("|").split("|")] for line in out.splitlines()
            if line.startswith("| ") and not line.startswith(("| design", "| ---", "| parameter"))]


def test_designs_are_every_combination_ranked_by_the_bound(capsys):
    assert main(["vehicle", "objective=ml", "--vary", "record.extra=0,0.5",
                 "--vary", "noise.model=multiplicative,additive"]) == 0
    out = capsys.readouterr()
    rows = _table(out.out)
    assert len(rows) == 4 and "design 4/4" in out.err
    norms = [float(r[1]) for r in rows]
    assert norms == sorted(norms)
    assert rows[0][0] == "objective=ml record.extra=0.5 noise.model=multiplicative"


def test_the_numbers_are_the_bound_and_its_optimality_criteria(capsys):
    """A-opt is the sum of the squared relative bounds; D-opt the d-th root of the Fisher
    determinant in relative parameters (the product of the squared scaled singular values).
    The table prints 3 significant digits: agreement within 5e-3 relative."""
    assert main(["vehicle", "record.extra=0.5"]) == 0
    row = _table(capsys.readouterr().out)[0]
    crb = cramer_rao(VehicleProblem(VehicleConfig(record=RecordConfig(extra=0.5))))
    rel = np.asarray(crb["crb_percent"]) / 100
    s = np.asarray(crb["singular_values"])
    assert float(row[1]) == pytest.approx(crb["crb_norm_percent"], rel=5e-3)
    assert float(row[5]) == pytest.approx(np.sum(rel**2), rel=5e-3)
    assert float(row[4]) == pytest.approx(np.prod(s**2) ** (1 / s.size), rel=5e-3)
    assert row[6] == "none" and row[7] == "no"


def test_the_floor_and_profiles_beside_the_bound(capsys):
    """Under the likelihood the measured floor on 4 instances is within 3x the bound; the
    profile table lists every parameter."""
    assert main(["vehicle", "objective=ml", "--floor", "4", "--profile"]) == 0
    out = capsys.readouterr().out
    row = _table(out)[0]
    assert float(row[2]) < 3 * float(row[1])
    assert "Profile-likelihood 95 % intervals" in out and out.count("| identifiable |") == 9


def test_an_undetermined_parameter_is_named(capsys):
    assert main(["vehicle", "noise.model=additive"]) == 0
    assert "k2 (20.7 %)" in _table(capsys.readouterr().out)[0][6]


@pytest.mark.parametrize("args, words", [
    (["vehicel"], ["problem='vehicel'", "vehicle"]),
    (["vehicle", "bogus=1"], ["problem.bogus", "known keys"]),
    (["vehicle", "--vary", "record.extra"], ["--vary", "key=value"]),
    (["vehicle", "objective=ml", "noise.level=0"], ["problem.objective"]),
    (["vehicle", "--floor", "-1"], ["--floor"]),
    (["vehicle", "record.extra=\x07"], ["settings=", "YAML"]),  # found by the fuzz test
    (["vehicle", "--vary", "record.extra=" + ",".join(str(i / 1000) for i in range(201))],
     ["at most 200 designs"]),
])
def test_bad_input_is_refused_in_one_line(capsys, args, words):
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("error: ")
    assert all(w in err[-1] for w in words), err[-1]


@settings(max_examples=40, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=12),
                max_size=3))
def test_fuzzed_settings_never_raise(capsys, words):
    """Any settings: a result or one refusal line (exit 0 or 2), never a traceback."""
    try:
        code = main(["quarter_missing" if not words else "vehicle", *words])
    except SystemExit as exc:  # argparse's own refusal (an unknown --flag)
        code = exc.code
    assert code in (0, 2)
