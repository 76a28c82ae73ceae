"""Round five's command-line failures (issue 44), each named by its id: N17 (an override of a key
that no optimizer of a sweep has was Hydra's raw ConfigCompositionException text), N19 (a sweep
function nested in a list sweep ended in a 20-line omegaconf traceback) and round four's #17
(``vpid-bench-design`` refused without the ``error:`` prefix). Each is refused in exactly one
``error:`` line with exit status 2, before any job runs (in-process, so nothing is launched)."""

from __future__ import annotations

import pytest
from hostile_helpers import error_lines, main_in_process

BASE = ["runs=1", "problem.iterations=2", "progress=false", "report=false"]


@pytest.mark.parametrize("override", ["optimizer.tag='x'", "+optimizer.tag=x",
                                      "++optimizer.tag=x"])
def test_n17_a_key_no_optimizer_of_the_sweep_has_is_one_line(override, in_tmp, capsys):
    code, err = main_in_process(["-m", "optimizer=de1,de4", override, *BASE], capsys)
    assert code == 2, err
    assert "Traceback" not in err and "ConfigCompositionException" not in err
    lines = error_lines(err)
    assert len(lines) == 1 and "optimizer.tag" in lines[0] and "CR, F" in lines[0], err


@pytest.mark.parametrize("override", ["problem.newmark.gamma=de1,choice(-1,1)",
                                      "problem.ps=20,range(1,3)", "optimizer=de1,glob(de*)",
                                      "problem.ps=20,interval(1,3)"])
def test_n19_a_sweep_function_inside_a_list_is_one_line(override, in_tmp, capsys):
    code, err = main_in_process(["-m", override, *BASE], capsys)
    assert code == 2, err
    assert "Traceback" not in err and "ValidationError" not in err
    lines = error_lines(err)
    assert len(lines) == 1 and "not one inside a list" in lines[0], err
    assert err.strip().endswith(lines[0])


def test_n19_a_plain_list_beside_a_list_value_is_still_a_sweep(in_tmp, capsys):
    """Only a sweep function inside a list is refused: ``a,[1,2]`` stays two plain values."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    from vpid_bench.shell.preflight import _refuse_nested_sweep

    o = OverridesParser.create().parse_overrides(["problem.ps=20,[1,2]"])[0]
    _refuse_nested_sweep(o, o.value())  # no error


def test_round4_17_design_refusal_has_the_error_prefix(capsys):
    from vpid_bench.design import main

    assert main(["functions"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines[-1].startswith("error: ") and "problem='problem'" in lines[-1], lines
