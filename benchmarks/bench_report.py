"""The full report's cost: figures drawn serially vs in worker processes, side by side.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_report.py [--records DIR] [--repeats N]
        [--workers N] [--before PATH/TO/OLD/vpid-bench-report]

Without ``--records`` it first runs the paper experiment (9 optimizers x ps 20, 30, 30 runs
each: 540 records) into a temporary folder:

    vpid-bench -m optimizer=de1,de2,de3,de4,de5,de6,de7,de8,ga problem.ps=20,30 runs=30
        progress=false report=false hydra.sweep.dir=<tmp>

Then, ``--repeats`` times and alternately (so both modes see the same machine load):

* ``build_report(..., figures="serial")`` and ``figures="parallel"`` each in a fresh
  interpreter (imports counted), with the wall time of every phase the report measures
  (``Report.timings``: load, stats, figures_submit, sections, tables_md, figures_wait) and
  the CPU time of the process and of its workers;
* ``vpid-bench-report DIR -o OUT``, the command a user runs (``--figures auto``), and, with
  ``--before``, another ``vpid-bench-report`` (e.g. main's, to compare with the previous
  version in the same run).

Prints medians, the serial/parallel ratio, each phase's share of the wall time and the
command to repeat the run. The machine may be shared: only the ratios of one run mean much.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _shared import cli_env

BIN = Path(sys.executable).parent
SWEEP = ["-m", "optimizer=de1,de2,de3,de4,de5,de6,de7,de8,ga", "problem.ps=20,30", "runs=30",
         "progress=false", "report=false"]

#: Runs in a fresh interpreter: times the imports and one build_report, prints JSON.
HARNESS = """
import json, resource, sys, time
t0 = time.perf_counter()
from vpid_bench.report.build import build_report
t1 = time.perf_counter()
if __name__ == "__main__":
    mode, workers = sys.argv[3], (int(sys.argv[4]) if sys.argv[4] != "default" else None)
    r = build_report([sys.argv[1]], sys.argv[2], figures=mode, workers=workers)
    t2 = time.perf_counter()
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    print("JSON" + json.dumps({"imports": t1 - t0, "build": t2 - t1, "wall": t2 - t0,
                               "phases": r.timings, "mode": r.figures_mode,
                               "cpu_main": me.ru_utime + me.ru_stime,
                               "cpu_workers": kids.ru_utime + kids.ru_stime}))
"""


def run_harness(records: Path, out: Path, mode: str, workers: str) -> dict:
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as fh:
        fh.write(HARNESS)
    try:
        res = subprocess.run([sys.executable, fh.name, str(records), str(out), mode, workers],
                             capture_output=True, text=True, check=True, env=cli_env())
    finally:
        os.unlink(fh.name)
    (line,) = [ln for ln in res.stdout.splitlines() if ln.startswith("JSON")]
    return json.loads(line[4:])


def run_command(exe: str, records: Path, out: Path) -> dict:
    """Wall and CPU time (the command and every process it started) of one report command."""
    before = os.times()
    t0 = time.perf_counter()
    res = subprocess.run([exe, str(records), "-o", str(out)], capture_output=True, text=True,
                         env=cli_env())
    wall = time.perf_counter() - t0
    after = os.times()
    if res.returncode not in (0, 1):  # 1: written, with failed runs listed
        raise RuntimeError(f"{exe} failed ({res.returncode}): {res.stderr[-2000:]}")
    cpu = (after.children_user - before.children_user) + (
        after.children_system - before.children_system)
    return {"wall": wall, "cpu": cpu}


def med(xs: list[float]) -> float:
    return statistics.median(xs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--records", type=Path, help="records to report on (default: run the "
                    "paper experiment into a temporary folder first)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--workers", default="default", help="figure workers (default: the "
                    "report's default for this machine)")
    ap.add_argument("--before", help="another vpid-bench-report to time in the same run "
                    "(e.g. /work/main/.venv/bin/vpid-bench-report)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-report-") as tmp:
        tmp_path = Path(tmp)
        records = args.records
        if records is None:
            records = tmp_path / "sweep"
            print(f"running the paper experiment into {records} ...", flush=True)
            t0 = time.perf_counter()
            subprocess.run([str(BIN / "vpid-bench"), *SWEEP, f"hydra.sweep.dir={records}"],
                           check=True, capture_output=True, env=cli_env())
            print(f"  {time.perf_counter() - t0:.1f} s", flush=True)
        results: dict[str, list[dict]] = {"serial": [], "parallel": []}
        cli: dict[str, list[dict]] = {"vpid-bench-report": []}
        if args.before:
            cli["before"] = []
        for i in range(args.repeats):
            for mode in ("serial", "parallel"):
                results[mode].append(run_harness(records, tmp_path / f"{mode}-{i}", mode,
                                                 args.workers))
            cli["vpid-bench-report"].append(run_command(
                str(BIN / "vpid-bench-report"), records, tmp_path / f"cli-{i}"))
            if args.before:
                cli["before"].append(run_command(args.before, records, tmp_path / f"old-{i}"))
        n = args.repeats
        print(f"\nreport of {records} ({n} repeat(s), medians; {os.cpu_count()} cores)\n")
        print(f"{'figures':<24} {'wall s':>7} {'imports':>8} {'build':>7} {'CPU main':>9} "
              f"{'CPU workers':>12}")
        for rs in results.values():
            print(f"{rs[0]['mode']:<24} {med([r['wall'] for r in rs]):7.2f} "
                  f"{med([r['imports'] for r in rs]):8.2f} {med([r['build'] for r in rs]):7.2f} "
                  f"{med([r['cpu_main'] for r in rs]):9.2f} "
                  f"{med([r['cpu_workers'] for r in rs]):12.2f}")
        ws, wp = med([r["wall"] for r in results["serial"]]), med(
            [r["wall"] for r in results["parallel"]])
        print(f"\nserial / parallel wall time: {ws / wp:.2f}x")
        print("\nshare of the wall time (in-process, imports included), per phase:")
        phases = ["imports", "load", "stats", "figures_submit", "sections", "tables_md",
                  "figures_wait"]
        print(f"{'phase':<16}" + "".join(f"{m:>20}" for m in results))
        for ph in phases:
            cells = []
            for rs in results.values():
                v = med([r["imports"] if ph == "imports" else r["phases"].get(ph, 0.0)
                         for r in rs])
                w = med([r["wall"] for r in rs])
                cells.append(f"{v:8.2f} s {100 * v / w:5.1f} %")
            print(f"{ph:<16}" + "".join(f"{c:>20}" for c in cells))
        print("\nthe command a user runs (a fresh process, figures=auto):")
        for name, rs in cli.items():
            walls = ", ".join(f"{r['wall']:.2f}" for r in rs)
            print(f"  {name:<20} wall {med([r['wall'] for r in rs]):5.2f} s   CPU (with workers) "
                  f"{med([r['cpu'] for r in rs]):5.2f} s   (all walls: {walls})")
        if args.before:
            ratio = med([r["wall"] for r in cli["before"]]) / med(
                [r["wall"] for r in cli["vpid-bench-report"]])
            print(f"  before / now: {ratio:.2f}x")
        again = [sys.argv[0], f"--repeats {n}"] + (
            [f"--records {args.records}"] if args.records else []) + (
            [f"--workers {args.workers}"] if args.workers != "default" else []) + (
            [f"--before {args.before}"] if args.before else [])
        print(f"\nrepeat: MPLBACKEND=Agg {sys.executable} {' '.join(again)}")


if __name__ == "__main__":
    main()
