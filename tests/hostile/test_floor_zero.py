"""Issue 35, failure 11: a floor of exactly 0 (noise-free records: each instance's optimum is
its truth, so its error is 0) once ended the report in ``ZeroDivisionError`` ("report: not
written", exit 1), for ``vpid-bench optimizer=de4 runs=1 problem.noise.level=0`` and for the
README's own ``problem.noise.level=0,0.05`` sweep. The verdict now says the records allow the
truth itself."""

from __future__ import annotations

import pytest
from hostile_helpers import run_cli

#: The vehicle at a tiny protocol: seconds per job.
SMALL = ["optimizer=de4", "runs=2", "problem.iterations=2", "problem.ps=6", "progress=false"]


@pytest.mark.parametrize("argv", [
    ["problem.noise.level=0"],                        # the single job (short report)
    ["-m", "problem.noise.level=0,0.05"],             # the README's sweep (full report)
], ids=["single-job", "readme-sweep"])
def test_11_a_floor_of_zero_gives_a_report_and_a_verdict(argv, tmp_path):
    done = run_cli([*argv, *SMALL, "archive=false"], tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "not written" not in done.stderr and "ZeroDivisionError" not in done.stderr
    out = " ".join(done.stdout.split())  # the verdict is wrapped to the terminal's width
    assert "the records allow the truth itself" in out
    assert "allow 0 % under" in out  # the floor, stated
    (report,) = [p for p in tmp_path.rglob("report/report.md")]
    assert "the records allow the truth itself" in " ".join(
        report.read_text(encoding="utf-8").split())


def test_11_a_bound_of_zero_is_no_ratio_either():
    """A floor above a Cramér–Rao bound of exactly 0 (a forged or degenerate bound) is not
    divided by it."""
    from vpid_bench.report.first_screen import verdict_text
    from vpid_bench.report.verdicts import Evidence, Method, Search, decide

    def verdict(floor: float, bound: float, median: float) -> str:
        reached = 2 if median == floor else 0  # runs at the optimum end at the floor
        method = Method("a", 2, median, "", Search(reached, 2, 0.0 if reached else 0.5))
        return verdict_text(decide(Evidence("c", "NoRE", "%", (method,), False,
                                            floors={0: floor}, bounds={0: bound})))

    text = verdict(2.0, 0.0, 2.0)
    assert "More search will not help" in text and "×" not in text
    assert "the records allow the truth itself" in verdict(0.0, 0.0, 3.0).replace("\n", " ")
