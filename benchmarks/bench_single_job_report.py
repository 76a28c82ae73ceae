"""Wall time of the single-job command with and without its (short) report, side by side.

    .venv/bin/python benchmarks/bench_single_job_report.py [repeats]

Runs ``vpid-bench runs=30 progress=false`` (DE4 on the vehicle) with ``report=true`` and
``report=false`` alternately, each into a fresh folder, and prints the median wall time of
each and their difference: the cost of the single job's report (imports included). Timings
on a shared machine are noisy; compare the two columns of one run, not across runs.
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXE = Path(sys.executable).with_name("vpid-bench")


def once(report: bool, folder: Path) -> float:
    t0 = time.perf_counter()
    subprocess.run([str(EXE), "runs=30", "progress=false", f"report={str(report).lower()}",
                    f"hydra.run.dir={folder}"], check=True, capture_output=True)
    return time.perf_counter() - t0


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    times: dict[bool, list[float]] = {True: [], False: []}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            for report in (True, False):
                times[report].append(once(report, Path(tmp) / f"{report}-{i}"))
    on, off = statistics.median(times[True]), statistics.median(times[False])
    print(f"command: {EXE} runs=30 progress=false report=true|false ({repeats} repeats each)")
    print(f"report=true   median {on:.2f} s  (all: {', '.join(f'{t:.2f}' for t in times[True])})")
    print(f"report=false  median {off:.2f} s  (all: {', '.join(f'{t:.2f}' for t in times[False])})")
    print(f"the short report costs {on - off:+.2f} s ({on / off:.2f}x)")


if __name__ == "__main__":
    main()
