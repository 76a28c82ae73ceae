"""The report's Assumed block (vpid_bench/report/assumed.py): the stated quantities, boxes
and input a context's records give (``problem.info.known``, ``box``, ``input``), and the
best run's estimates within 1 % of a bound; untrusted fields of the wrong type left out."""

from __future__ import annotations

from types import SimpleNamespace

from vpid_bench.report import assumed


def _data(*records):
    rows = [{"run_id": r["run_id"], "context": "c"} for r in records]
    return SimpleNamespace(rows=rows, loaded=SimpleNamespace(records=list(records)))


def _record(run_id="a", f=1.0, x=(1.5, 5.0), info=None):
    return {"run_id": run_id,
            "problem": {"info": info if info is not None else {
                "known": [{"name": "kt", "value": 210000.0, "unit": "N/m",
                           "source": "set by you (problem.known.kt)", "what": "tyre stiffness"},
                          {"name": "ct", "value": 0.0, "unit": "N s/m",
                           "source": "parameter set golden_car"}],
                "box": [{"name": "ms", "lower": 1.0, "upper": 2.0, "unit": "kg",
                         "source": "set by you (problem.bounds.ms)"}],
                "input": "the record's h (column road)"}},
            "parameters": {"names": ["ms", "ks"], "units": ["kg", "N/m"],
                           "lower": [1.0, 0.0], "upper": [2.0, 10.0]},
            "result": {"f_best": f, "x_best": list(x)}}


def test_the_block_lists_known_quantities_boxes_and_the_input():
    (text, headers, rows), (used, _, _) = assumed.blocks(_data(_record()), "c")
    assert headers == [] and rows == []
    assert ("stated, not identified: set by you (problem.known.kt): kt = 210000 N/m (tyre "
            "stiffness); parameter set golden_car: ct = 0 N s/m") in text
    assert "Searched within the boxes: set by you (problem.bounds.ms): ms [1, 2] kg." in text
    assert used == "Input used: the record's h (column road)."


def test_an_estimate_within_1_percent_of_a_bound_is_flagged_for_the_best_run():
    """ks = 9.95 lies 0.5 % of the width below its upper bound 10 in the best run (f 0.5);
    the worse run's ms = 1.001 (0.1 % above its lower bound) is not the answer shown."""
    data = _data(_record("a", 1.0, (1.001, 5.0)), _record("b", 0.5, (1.5, 9.95)))
    text = assumed.blocks(data, "c")[-1][0]
    assert text.startswith("On a bound: in the best run, ks = 9.95 is within 1 % of the "
                           "box's width of its upper bound 10 N/m.")
    assert "ms" not in text
    assert assumed.near_bounds(_record(x=(1.02, 5.0))) == []  # 2 % inside: not flagged


def test_records_that_state_nothing_or_hold_junk_get_no_block():
    """A problem that gives no known/box (a third party's), an older record's mapping form,
    and entries of the wrong type: no block, no error; text is escaped and cut."""
    assert assumed.blocks(_data(_record(info={})), "c") == []
    assert assumed.blocks(_data(_record(info={"known": {"kt": 1.0}})), "c") == []
    junk = {"known": [None, 3, {"name": "kt"}, {"name": "x", "value": "1", "unit": "m",
                                                  "source": "s"}], "box": "no"}
    assert assumed.blocks(_data(_record(info=junk)), "c") == []
    odd = {"known": [{"name": "a|b" + "x" * 500, "value": 1.0, "unit": "<m>",
                      "source": "s"}]}
    (text, _, _), = assumed.blocks(_data(_record(info=odd, x=(1.5, 5.0))), "c")
    assert "a\\|b" in text and "&lt;m&gt;" in text and "x" * 100 not in text
