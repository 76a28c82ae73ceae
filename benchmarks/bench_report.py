"""What a report costs: the full report of a sweep and the short report of one job, side by
side with the runs they report on.

    .venv/bin/python benchmarks/bench_report.py [--repeats 3] [--records SWEEP_DIR]

* **Full report**: ``vpid-bench-report SWEEP -o OUT`` in a child process (imports included,
  what a user runs) on the paper experiment's records (9 optimizers x ps 20, 30 x 30 runs;
  made once into a temporary folder unless ``--records`` names an existing sweep), and the
  sweep's own wall time for scale.
* **Short report**: ``vpid-bench runs=30 progress=false`` (DE4 on the vehicle) with
  ``report=true`` and ``report=false`` alternately, each into a fresh folder: the difference
  is what the single job's report adds.

Timings on a shared machine are noisy; compare the columns of one run, not across runs.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from _shared import CLI, REPORT, cli_env

PAPER_SWEEP = ["-m", "optimizer=de1,de2,de3,de4,de5,de6,de7,de8,ga", "problem.ps=20,30",
               "runs=30", "progress=false", "report=false"]


def timed(cmd: list[str]) -> float:
    """Wall seconds of ``cmd`` in a child process (it must succeed)."""
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env=cli_env())
    return time.perf_counter() - t0


def full_report(records: Path | None, repeats: int, tmp: Path) -> None:
    sweep_s = None
    if records is None:
        records = tmp / "sweep"
        sweep_s = timed([*CLI, *PAPER_SWEEP, f"hydra.sweep.dir={records}"])
    times = [timed([*REPORT, str(records), "-o", str(tmp / f"report-{i}")])
             for i in range(repeats)]
    print(f"full report of {records} ({repeats} repeats): median "
          f"{statistics.median(times):.2f} s  (all: {', '.join(f'{t:.2f}' for t in times)})")
    if sweep_s is not None:
        print(f"  the sweep it reports on (540 runs, report=false): {sweep_s:.2f} s")


def short_report(repeats: int, tmp: Path) -> None:
    times: dict[bool, list[float]] = {True: [], False: []}
    for i in range(repeats):
        for report in (True, False):
            times[report].append(timed([*CLI, "runs=30", "progress=false",
                                        f"report={str(report).lower()}",
                                        f"hydra.run.dir={tmp / f'job-{report}-{i}'}"]))
    on, off = statistics.median(times[True]), statistics.median(times[False])
    print(f"single job, runs=30 ({repeats} repeats each): report=true median {on:.2f} s, "
          f"report=false median {off:.2f} s; the short report adds {on - off:+.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--records", type=Path, default=None,
                    help="an existing sweep folder to report on (default: run the paper sweep)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        full_report(args.records, args.repeats, Path(tmp))
        short_report(args.repeats, Path(tmp))


if __name__ == "__main__":
    main()
