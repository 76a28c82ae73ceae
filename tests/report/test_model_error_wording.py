"""The committed advice never reads a model-error artefact as a search failure (issue 43,
item 3): in docs/study.md and the archives' committed advice, no sentence about the
model-error members (or model error, or a record made by a richer model) says that runs
"stopped short" or calls the outcome a search failure."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ADVICE = [ROOT / "docs" / "study.md",
          *sorted((ROOT / "docs" / "study").glob("*/advice.md"))]
#: What marks a sentence as being about model error.
ABOUT = re.compile(r"model error|model-error|richer model|vpid1_q_golden_bilinear|"
                   r"vpid1_h_gokdag_seat_iso_c|vpid1_l_civic_model_error|golden_bilinear|"
                   r"seat_iso_c|civic_model_error", re.IGNORECASE)
#: Readings of the outcome as a search failure.
SEARCH_FAILURE = re.compile(r"stopped short|stop short|stops short|search failure|"
                            r"failed to (?:reach|converge)|more search would", re.IGNORECASE)


def sentences(text: str) -> list[str]:
    """The text's sentences (list items and paragraphs split at '. ', '; ' and ': ')."""
    flat = re.sub(r"\s+", " ", text)
    return [s for s in re.split(r"(?<=[.;:])\s+|\s+-\s+", flat) if s.strip()]


def failure_readings(text: str) -> list[str]:
    """The sentences that read a failure of search, in paragraphs about model error."""
    return [s for para in re.split(r"\n\s*\n", text) if ABOUT.search(para)
            for s in sentences(para) if SEARCH_FAILURE.search(s)]


def test_a_planted_failure_reading_is_found_and_a_plain_one_is_not():
    planted = ("- the same on `vpid1_q_golden_bilinear`, whose record a richer model made;\n"
               "  runs that end nearer the truth stopped short of the optimum.")
    assert failure_readings(planted) == ["runs that end nearer the truth stopped short of "
                                         "the optimum."]
    elsewhere = "On vpid1_f_jazar_hump the runs stopped short of the optimum."
    assert failure_readings(elsewhere) == []


@pytest.mark.parametrize("path", ADVICE, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_model_error_artefact_is_read_as_a_search_failure(path):
    bad = failure_readings(path.read_text(encoding="utf-8"))
    assert bad == [], bad
