"""Two archives of one problem at different budgets (``archive/vpid1`` at 1,000·D and
``archive/vpid1_long`` at 10,000·D): a report's runs take their peers from the archive with
their own settings, with no note about the other; with settings no archive holds, one note
per archive names the budgets it does hold."""

from __future__ import annotations

from pathlib import Path

from vpid_bench.report.archive import merge
from vpid_bench.store.archive_records import Archive


def _record(optimizer: str, budget: int, instance: str = "i0") -> dict:
    return {"problem": {"name": "vpid1_q_golden_hump", "config": {"seed": 1},
                        "plugin": {"distribution": "vpid-bench", "version": "1"},
                        "info": {"f_at_true": 0.5}},
            "parameters": {"names": ["ms", "mu", "ks", "cs"], "true": [1.0, 2.0, 3.0, 4.0]},
            "instance": {"id": instance}, "budget": budget,
            "optimizer": {"name": optimizer}}


def _archive(suite: str, budget: int) -> Archive:
    return Archive(Path(suite), suite, {"commit": "abc"},
                   [_record("de1", budget), _record("cmaes", budget)], [])


ARCHIVES = [_archive("vpid1", 4_000), _archive("vpid1_long", 40_000)]


def test_the_matching_archive_serves_and_the_other_says_nothing():
    for budget, suite in ((4_000, "vpid1"), (40_000, "vpid1_long")):
        merged = merge([_record("mine", budget)], ARCHIVES)
        assert sorted(r["optimizer"]["name"] for r in merged.records) == ["cmaes", "de1"]
        assert {r["budget"] for r in merged.records} == {budget}
        assert merged.refused == []
        (used,) = merged.used
        assert f"archive of suite {suite}" in used


def test_settings_no_archive_holds_are_named_once_per_archive():
    merged = merge([_record("mine", 8_000)], ARCHIVES)
    assert merged.records == []
    assert len(merged.refused) == 2
    assert "no archived runs of vpid1_q_golden_hump with these settings" in merged.refused[0]
    assert merged.refused[0].endswith("at 1,000·D)")
    assert merged.refused[1].endswith("at 10,000·D)")
