# ruff: noqa: N802 - each test is named by its id in issue 44 (test_N12_...)
"""Issue 44, round five's record failures (N12, N13, N14, N15, N18) and issue 41's strict
records: each hostile own record is refused by the pre-flight in one ``error:`` line naming
the row, column or time, exit status 2, before any job (no records, no job folder)."""

from __future__ import annotations

import math

import pytest
from hostile_helpers import main_in_process, run_cli

QUARTER = ["problem=ride_quarter", "runs=1", "progress=false", "report=false"]


def _record(path, header="t,zsdd,zudd,h", rows=200, cell=None, t=lambda k: 12.3 + 0.002 * k):
    """A quarter-car record (500 Hz from 12.3 s, two smooth channels and the road);
    ``cell(k, j)`` replaces the text of row ``k`` (0-based data row), column ``j``, where it
    returns one."""
    lines = [header]
    for k in range(rows):
        values = [repr(t(k)), repr(math.sin(0.05 * k) + 0.1), repr(math.cos(0.07 * k)),
                  repr(0.01 * math.sin(0.03 * k))]
        for j in range(4):
            new = cell(k, j) if cell else None
            if new is not None:
                values[j] = new
        lines.append(",".join(values))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _refused(argv, capsys, in_tmp):
    code, err = main_in_process(argv, capsys)
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("error: "), err
    assert "Traceback" not in err and "Warning" not in err
    assert not list(in_tmp.rglob("records")), "nothing may run"
    return err


def test_N12_huge_sample_refused(in_tmp, capsys, tmp_path):
    """One sample of 1e300 once made its channel's norm overflow (the fit ignored the
    channel, runs ok): refused, naming its row and column."""
    path = _record(tmp_path / "r.csv", cell=lambda k, j: "1e300" if (k, j) == (50, 1) else None)
    err = _refused([*QUARTER, f"problem.reference.file={path}"], capsys, in_tmp)
    assert "values of magnitude at most 1e+100 in SI units; row 52 column zsdd is 1e+300" in err


def test_N12_single_sample_dominating_a_channel_is_named(in_tmp, capsys, tmp_path):
    """A finite spike (1e6 in a channel of about 1) that alone makes up most of the channel's
    sum of squares: refused, naming the row, the column and its share."""
    path = _record(tmp_path / "r.csv", cell=lambda k, j: "1e6" if (k, j) == (80, 2) else None)
    err = _refused([*QUARTER, f"problem.reference.file={path}"], capsys, in_tmp)
    assert "row 82 column zudd (1e+06) makes up 100 % of its sum of squares" in err


def test_N18_g_cell_overflowing_after_conversion_refused(in_tmp, capsys, tmp_path):
    """1e308 in a ``[g]`` column is finite as written and infinite in m/s^2: once recorded
    ok with f_best inf, now refused in one line."""
    path = _record(tmp_path / "r.csv", header="t,zsdd,zudd [g],h",
                   cell=lambda k, j: "1e308" if (k, j) == (10, 2) else None)
    err = _refused([*QUARTER, f"problem.reference.file={path}"], capsys, in_tmp)
    assert "row 12 column zudd is 1e+308 (x 9.80665 in SI units)" in err


@pytest.mark.parametrize("text", ["1_000", "\uff11\uff12", "\u0661\u0662"],
                         ids=["underscore", "full-width", "arabic-indic"])
def test_N15_underscore_and_fullwidth_digits_refused(text, in_tmp, capsys, tmp_path):
    """Python's float() reads ``1_000`` and full-width or other Unicode digits: a record's
    cell must be ASCII digits."""
    assert float(text) in (1000.0, 12.0)  # what float() alone would have accepted
    path = _record(tmp_path / "r.csv", cell=lambda k, j: text if (k, j) == (3, 1) else None)
    err = _refused([*QUARTER, f"problem.reference.file={path}"], capsys, in_tmp)
    assert "a number in column zsdd of every row; row 5 has none (ASCII digits" in err


def test_N13_record_spanning_1e_12_s_refused(in_tmp, capsys, tmp_path):
    """Rows 1e-13 s apart: once numpy's "Shape of array too small to calculate a numerical
    gradient"; now the span and the model steps it covers, named."""
    path = _record(tmp_path / "r.csv", rows=11, t=lambda k: 1.0 + 1e-13 * k)
    err = _refused([*QUARTER, f"problem.reference.file={path}"], capsys, in_tmp)
    assert "a record spanning at least 10 model steps" in err
    assert "gradient" not in err


@pytest.mark.parametrize(("value", "word"), [("0", "zero"), ("1e-310", "denormal")])
def test_N14_zero_or_denormal_channel_refused_in_the_preflight(value, word, in_tmp, capsys,
                                                               tmp_path):
    """A channel all zero or denormal was refused only when a job built the problem (after
    an info line); now by the pre-flight, before any job (docs/own-record.md)."""
    path = _record(tmp_path / "r.csv", cell=lambda k, j: value if j == 2 else None)
    err = _refused([*QUARTER, f"problem.reference.file={path}"], capsys, in_tmp)
    assert f"column zudd is {word} throughout" in err
    assert [p.name for p in in_tmp.iterdir()] == ["r.csv"], "no job folder either"


def test_misnamed_input_and_unused_column_exit_2_naming_them(tmp_path):
    """The command itself: a road in a column called ``road`` (once silently replaced by the
    configured hump) and a column nobody uses each exit 2 with one line naming it."""
    path = _record(tmp_path / "road.csv", header="t,zsdd,zudd,road")
    base = ["problem=ride_quarter", "runs=1", "progress=false", "report=false"]
    job = run_cli([*base, f"problem.reference.file={path}"], cwd=tmp_path)
    lines = job.stderr.strip().splitlines()
    assert job.returncode == 2 and len(lines) == 1, job.stderr
    assert "input columns h (" in lines[0] and "column h is missing; found columns t, zsdd, " \
        "zudd, road" in lines[0] and "problem.reference.columns={h:<column>}" in lines[0]
    job = run_cli([*base, f"problem.reference.file={path}", "problem.reference.columns={h:road}",
                   "problem.reference.input=record", "problem=ride_quarter",
                   "problem.sensors=body"], cwd=tmp_path)
    lines = job.stderr.strip().splitlines()
    assert job.returncode == 2 and len(lines) == 1, job.stderr
    assert "column 'zudd' is not used" in lines[0] and "problem.reference.ignore" in lines[0]
    assert not list(tmp_path.rglob("records"))
