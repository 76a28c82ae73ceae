"""The optimum polish's inner tolerance: time per polish and how far ``f*`` moves.

Polishes the same starting points (the best vectors of real DE runs on the paper window, one
per instance, and each instance's truth) with scipy tolerances ``1e-15`` (the old setting)
and :data:`vpid_bench.analysis.optimum.INNER_TOL`, side by side in one process, and prints
the milliseconds per polish, their ratio and the largest relative difference of the polished
values. Only the ratio means anything on a shared machine.

    python benchmarks/bench_polish_tolerance.py            # 30 instances
    python benchmarks/bench_polish_tolerance.py --runs 10  # quicker
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _shared import compose, registry_with_configs


def _problem_and_starts(runs: int):
    from vpid_bench.build import ProblemCache, run_rng
    from vpid_bench.runner import run
    from vpid_bench.spec import parse_job

    registry = registry_with_configs()
    job = parse_job(compose(["optimizer=de1", f"runs={runs}"]), registry)
    problem = ProblemCache().get(job)
    problem.set_threads(1)
    starts = []
    for i in range(runs):  # run i fits instance i, as in a job
        inst = problem.instance(i)
        optimizer = job.optimizer_cls(job.params, inst.bounds, run_rng(job.spec.seed, i))
        starts += [(inst, run(inst, optimizer, job.budget).x_best), (inst, problem.x_true)]
    return starts


def main() -> None:
    from vpid_bench.analysis.optimum import INNER_TOL, polish

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=30, help="instances (one DE1 run each)")
    args = parser.parse_args()
    starts = _problem_and_starts(args.runs)
    polish(*starts[0])  # compile outside the clock
    values, seconds = {}, {}
    for tol in (1e-15, INNER_TOL):
        t0 = time.perf_counter()
        values[tol] = np.array([polish(inst, x, inner_tol=tol)[1] for inst, x in starts])
        seconds[tol] = (time.perf_counter() - t0) / len(starts)
    old, new = values[1e-15], values[INNER_TOL]
    rel = (new - old) / old
    print(f"{len(starts)} polishes (a DE1 run best and the truth of {args.runs} instances)")
    print(f"  inner tolerance 1e-15:    {seconds[1e-15] * 1e3:6.1f} ms per polish")
    print(f"  inner tolerance {INNER_TOL:g}:   {seconds[INNER_TOL] * 1e3:6.1f} ms per polish "
          f"({seconds[1e-15] / seconds[INNER_TOL]:.2f}x faster)")
    print(f"  f* relative difference (new - old) / old: max {rel.max():.2e}, min {rel.min():.2e}")


if __name__ == "__main__":
    main()
