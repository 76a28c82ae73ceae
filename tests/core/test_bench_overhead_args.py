"""``benchmarks/bench_overhead.py`` refuses a mistyped problem or optimizer in one line, exit
2, before it measures anything (it once printed a failed row per optimizer)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from extras import limit

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "bench_overhead.py"


@pytest.mark.parametrize("args, names", [
    (["--problem", "smoke_quartr"], ["smoke_quartr", "smoke_quarter"]),
    (["--only", "random", "randm"], ["--only randm", "random"]),
])
def test_a_mistyped_name_is_one_line_naming_it_and_the_allowed_ones(args, names):
    out = subprocess.run([sys.executable, str(SCRIPT), "--repeat", "1", *args],
                         capture_output=True, text=True, timeout=limit(120),
                         env={"MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"})
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in out.stderr
    assert all(n in lines[0] for n in names)
    assert "|" not in out.stdout  # no table row: nothing was measured
