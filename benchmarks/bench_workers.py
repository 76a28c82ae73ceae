"""A sweep in this process against the same sweep in supervised worker processes.

Runs one ``vpid-bench -m`` sweep four ways, report off, side by side in one invocation:
``isolation=none threads=1`` (every run in the command's process on one core),
``workers=1 threads=1`` (one worker process: what isolation costs), ``isolation=none`` (in the
command's process, the kernel's threads on every core: the default before worker processes),
and the default (``isolation=auto``: a worker process per core). Prints wall times,
evaluations per second, the speed-ups over the first, and whether the records are the same
(fingerprints without timing).
Quick version: ``python benchmarks/bench_workers.py --optimizers de1,lsq --iterations 50``;
the 10x study of docs/study.md on one core and by default: ``--optimizers
de1,de4,de6,jade,shade,lshade,ga,scipy_de,cmaes,lsq,de_lsq,random --problems
vehicle,vehicle_long_record --iterations 509 --ways none,default``;
the paper experiment: ``--optimizers de1,de2,de3,de4,de5,de6,de7,de8,ga --ps 20,30
--iterations 50``.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

from _shared import CLI, run_timed
from bench_threads_sweep import fingerprints

WAYS = (("in-process, 1 core", ["isolation=none", "threads=1"], "none"),
        ("1 worker process", ["workers=1", "threads=1"], "one"),
        ("in-process, kernel threads", ["isolation=none"], "threads"),
        ("default (a worker per core)", [], "default"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--optimizers", default="de1,de4,ga,random,cmaes,lsq")
    parser.add_argument("--ps", default="20")
    parser.add_argument("--iterations", type=int, default=200)
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--problems", default="vehicle")
    parser.add_argument("--ways", default="none,one,threads,default",
                        help="which of: none (in-process, 1 core), one (1 worker), threads "
                             "(in-process, kernel threads), default; 'none' always runs")
    args = parser.parse_args()
    chosen = {"none", *args.ways.split(",")}
    ways = [w for w in WAYS if w[2] in chosen]
    base = ["-m", f"problem={args.problems}", f"optimizer={args.optimizers}",
            f"problem.ps={args.ps}",
            f"problem.iterations={args.iterations}", f"runs={args.runs}", "progress=false",
            "report=false"]
    root = Path(tempfile.mkdtemp(prefix="vpid-workers-"))
    print("command: vpid-bench " + " ".join(base) + " [isolation=none threads=1 | workers=1]")
    walls = {}
    for name, extra, folder in ways:
        walls[name] = run_timed([*CLI, *base, *extra, f"hydra.sweep.dir={root / folder}"],
                                root)[0]
    prints = {folder: fingerprints(root / folder) for _, _, folder in ways}
    evaluations = prints["none"][1]
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"cores: {cores}, evaluations: {evaluations}")
    first = walls[WAYS[0][0]]
    for name, wall in walls.items():
        print(f"  {name:28s}: {wall:8.2f} s wall, {evaluations / wall:12,.0f} evaluations/s, "
              f"{first / wall:.2f}x")
    same = all(p[0] == prints["none"][0] for p in prints.values())
    print(f"  records identical (without timing): {same} ({len(prints['none'][0])} records)")
    print(json.dumps({"walls": walls, "evaluations": evaluations}))
    print(f"outputs: {root}")


if __name__ == "__main__":
    main()
