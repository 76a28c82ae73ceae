"""The model-error members state their at-fit model error per instance (issue 43, item 3):
the shipped ratios are what :func:`model_error` computes, and the report's section prints
them per instance of the runs, with the richer structure the suite fits such a record with."""

from __future__ import annotations

import pytest
from vpid_vehicle.model_error_report import model_error_sections
from vpid_vehicle.ride.model_error import (
    FILE_INSTANCES,
    members_with_model_error,
    model_error,
    read_ratios,
)

from vpid_bench import ReportContext

QUARTER = "vpid1_q_golden_bilinear"


def test_the_shipped_ratios_are_the_codes_for_every_member_and_instance():
    shipped = read_ratios()
    assert set(shipped) == {m.name for m in members_with_model_error()}
    for entry in shipped.values():
        assert len(entry["ratio_at_fit"]) == FILE_INSTANCES
        # the fit absorbs part of the difference: never above the misfit at the truth
        assert all(f <= t + 1e-9 for f, t in zip(entry["ratio_at_fit"],
                                                 entry["ratio_at_truth"], strict=True))
    cls = next(m for m in members_with_model_error() if m.name == QUARTER)
    again = model_error(cls(cls.Config()).instance(2))
    assert shipped[QUARTER]["ratio_at_fit"][2] == pytest.approx(again["ratio"], abs=1e-4)
    assert "problem.damper=bilinear" in shipped[QUARTER]["fit_with"]


def _ctx(tmp_path, seed, instances):
    records = tuple({"problem": {"name": QUARTER, "config": {"seed": seed}},
                     "instance": {"index": i}} for i in instances)
    return ReportContext(problem=QUARTER, rows=(), records=records, out_dir=tmp_path,
                         short=False, alpha=0.05)


def test_the_section_prints_the_runs_instances_and_the_richer_structure(tmp_path):
    shipped = read_ratios()[QUARTER]
    out = model_error_sections(_ctx(tmp_path, 0, [0, 3]))
    text = out.sections[0].text
    assert "problem.damper=bilinear" in text and "at the fit" in text
    rows = [line for line in text.splitlines() if line.startswith("|") and "---" not in line]
    assert len(rows) == 3  # header and instances 0 and 3
    assert f"{shipped['ratio_at_fit'][3]:.3g}" in rows[2]


def test_other_settings_get_the_command_not_figures(tmp_path):
    text = model_error_sections(_ctx(tmp_path, 7, [0])).sections[0].text
    assert "Not computed for these runs' seed" in text
    assert model_error_sections(ReportContext(problem="vpid1_q_golden_hump", rows=(),
                                              records=(), out_dir=tmp_path, short=False,
                                              alpha=0.05)) is None
