"""A sweep where the runs dominate, with ``threads=1`` and with the default (every core), both
in the command's process (``isolation=none``: what the kernel's threads alone give; worker
processes, one per core, are measured by ``bench_workers.py``).

Runs the paper experiment with ``problem.iterations=500`` (ten times the paper's budget)
through the CLI twice, report off, side by side in one invocation, and prints the speed-up of
the default over ``threads=1`` (target >= 1.7 on 2 cores) and that the records are the same
(fingerprints without timing). Lockstep is what gives the kernel enough candidates per call
to use its threads: a job of 30 runs at ps 20 evaluates 600 candidates per call.
Quick version: ``python benchmarks/bench_threads_sweep.py --optimizers de1,ga --iterations 200``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

from _shared import CLI, run_timed


def sweep(args: list[str], cwd: Path) -> float:
    """Wall time of one ``vpid-bench`` invocation (it must succeed)."""
    return run_timed([*CLI, *args], cwd)[0]


def fingerprints(folder: Path) -> tuple[dict[str, str], int]:
    from vpid_bench.store import records as rec

    out, evaluations = {}, 0
    for p in rec.iter_record_files([folder]):
        record = rec.read_record(p)
        out[str(p.relative_to(folder))] = rec.fingerprint(record)
        evaluations += int(record["result"]["evaluations"])
    return out, evaluations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--optimizers", default="de1,de2,de3,de4,de5,de6,de7,de8,ga")
    parser.add_argument("--ps", default="20,30")
    parser.add_argument("--iterations", type=int, default=500)
    parser.add_argument("--runs", type=int, default=30)
    args = parser.parse_args()
    base = ["-m", "problem=vehicle", f"optimizer={args.optimizers}", f"problem.ps={args.ps}",
            f"problem.iterations={args.iterations}", f"runs={args.runs}", "progress=false",
            "report=false", "isolation=none"]  # threads alone; worker processes: bench_workers
    root = Path(tempfile.mkdtemp(prefix="vpid-threads-"))
    print("command: vpid-bench " + " ".join(base) + " [threads=1]")
    walls = {}
    for name, extra in (("threads=1", ["threads=1"]), ("default", [])):
        walls[name] = sweep([*base, *extra, f"hydra.sweep.dir={root / name.replace('=', '')}"],
                            root)
    one, evaluations = fingerprints(root / "threads1")
    default, _ = fingerprints(root / "default")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"cores: {cores}, evaluations: {evaluations}")
    for name, wall in walls.items():
        print(f"  {name:10s}: {wall:8.2f} s wall, {evaluations / wall:12,.0f} evaluations/s")
    print(f"  speed-up of the default over threads=1: {walls['threads=1'] / walls['default']:.2f}x"
          " (target >= 1.7 on 2 cores)")
    print(f"  records identical (without timing): {one == default} ({len(one)} records)")
    print(json.dumps({"walls": walls, "evaluations": evaluations}))
    print(f"outputs: {root}")


if __name__ == "__main__":
    main()
