"""What the instance optima cost: polishing one at two inner tolerances, and reading the
certified ones from the shipped archives, each side by side in one run.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_optima.py polish [--runs 30]
    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_optima.py read \\
        [--problem vpid1_q_golden_hump] [--repeat 3]

``polish``: the best of a DE1 run and the truth of each instance polished with scipy
tolerances ``1e-15`` (before round two) and :data:`vpid_bench.analysis.optimum.INNER_TOL`.
``read``: the whole archives holding ``--problem`` (records parsed and checked) against
their optima alone (what ``target=`` reads, once in the pre-flight and once per job).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from _shared import compose, registry_with_configs

from vpid_bench.analysis.optimum import INNER_TOL, polish
from vpid_bench.build import ProblemCache, run_rng
from vpid_bench.runner import run
from vpid_bench.spec import parse_job
from vpid_bench.store.archive_records import load_all


def polish_part(runs: int) -> None:
    registry = registry_with_configs()  # before compose: it stores the config nodes
    job = parse_job(compose(["optimizer=de1", f"runs={runs}"]), registry)
    problem = ProblemCache().get(job)
    problem.set_threads(1)
    starts = []
    for i in range(runs):  # run i fits instance i, as in a job
        inst = problem.instance(i)
        optimizer = job.optimizer_cls(job.params, inst.bounds, run_rng(job.spec.seed, i))
        starts += [(inst, run(inst, optimizer, job.budget).x_best), (inst, problem.x_true)]
    polish(*starts[0])  # compile outside the clock
    values, seconds = {}, {}
    for tol in (1e-15, INNER_TOL):
        t0 = time.perf_counter()
        values[tol] = np.array([polish(inst, x, inner_tol=tol)[1] for inst, x in starts])
        seconds[tol] = (time.perf_counter() - t0) / len(starts)
    old, new = values[1e-15], values[INNER_TOL]
    rel = (new - old) / old
    print(f"{len(starts)} polishes (a DE1 run best and the truth of {runs} instances)")
    print(f"  inner tolerance 1e-15:    {seconds[1e-15] * 1e3:6.1f} ms per polish")
    print(f"  inner tolerance {INNER_TOL:g}:   {seconds[INNER_TOL] * 1e3:6.1f} ms per polish "
          f"({seconds[1e-15] / seconds[INNER_TOL]:.2f}x faster)")
    print(f"  f* relative difference (new - old) / old: max {rel.max():.2e}, min {rel.min():.2e}")


def read_part(problem: str, repeat: int) -> None:
    rows = {}
    for name, optima_only in (("whole archives", False), ("optima alone", True)):
        seconds = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            archives, _ = load_all(None, {problem}, optima_only=optima_only)
            seconds.append(time.perf_counter() - t0)
        rows[name] = (statistics.median(seconds), sum(len(a.records) for a in archives),
                      sum(len(a.optima) for a in archives))
    print("| read | s (median) | records | optima |")
    print("| --- | --- | --- | --- |")
    for name, (s, records, optima) in rows.items():
        print(f"| {name} | {s:.3f} | {records:,} | {optima} |")
    print(f"ratio: {rows['whole archives'][0] / max(rows['optima alone'][0], 1e-9):.0f}x")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("part", choices=("polish", "read"))
    ap.add_argument("--runs", type=int, default=30, help="polish: instances (a DE1 run each)")
    ap.add_argument("--problem", default="vpid1_q_golden_hump", help="read: whose archives")
    ap.add_argument("--repeat", type=int, default=3, help="read: timings of each")
    args = ap.parse_args()
    if args.part == "polish":
        polish_part(args.runs)
    else:
        read_part(args.problem, args.repeat)


if __name__ == "__main__":
    main()
