"""The whole chain against its runs alone: the paper experiment through the CLI, report
included, and the same runs in this process with nothing around them.

Measures, side by side in one invocation (only ratios mean anything on a shared machine):

* ``runs alone``: every job's runs in this process (problem built and kernel compiled
  beforehand, untimed), in lockstep as the command runs them; no records, no analysis
  (and, for comparison, the same runs one after another);
* ``CLI, no report``: ``vpid-bench -m ... report=false`` (composition, pre-flight, problem
  build, warm-up, records, the optimum/identifiability analysis);
* ``CLI, report``: the same with the report at the end (what a user runs);
* ``report alone``: ``vpid-bench-report`` on the records of the previous sweep;
* ``fixed start``: a sweep of one job with one run of one generation, report off: what every
  command pays before and after its jobs (interpreter, imports, Hydra, the pre-flight, the
  kernel's compiled code loaded from numba's cache), whatever the size of the study.

and prints chain / runs (target <= 2) and each part's share. Quick version:
``python benchmarks/bench_chain.py --optimizers de1,ga --runs 10``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from _shared import CLI, REPORT, compose, registry_with_configs, run_timed

#: CPU seconds (user + system) of each measurement, beside its wall time: on a machine shared
#: with other work the CPU time varies much less than the wall time.
CPU: dict[str, float] = {}


def timed(cmd: list[str], cwd: Path, name: str) -> float:
    """Wall time of one command (it must succeed); its CPU time goes to ``CPU[name]``."""
    wall, CPU[name] = run_timed(cmd, cwd)
    return wall


def runs_alone(overrides: list[list[str]], lockstep: bool = True) -> tuple[float, int]:
    """Seconds the runs of the given jobs take in this process, and their evaluations
    (``lockstep=False``: one run after another, as before lockstep)."""
    import numpy as np

    from vpid_bench.build import ProblemCache, run_rng
    from vpid_bench.job_runs import joins_lockstep
    from vpid_bench.machine import available_cores
    from vpid_bench.runner import Lane, run, run_many
    from vpid_bench.spec import parse_job

    registry = registry_with_configs()
    cache = ProblemCache()
    total, evaluations = 0.0, 0
    for job_overrides in overrides:
        job = parse_job(compose(job_overrides), registry)
        problem = cache.get(job)
        problem.set_threads(job.spec.threads or available_cores())
        X = problem.bounds.sample(np.random.default_rng(0), 2)
        problem.evaluate(X)  # compile outside the clock
        problem.evaluate_instances(X, np.array([0, 1]))
        optimizers = [job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, i))
                      for i in range(job.spec.runs)]
        t0, c0 = time.perf_counter(), time.process_time()
        if lockstep and joins_lockstep(job, problem):
            results = run_many(problem, [Lane(problem.instance(i), o, job.budget, i)
                                         for i, o in enumerate(optimizers)])
        else:
            results = [run(problem.instance(i), o, job.budget) for i, o in enumerate(optimizers)]
        total += time.perf_counter() - t0
        CPU["lockstep" if lockstep else "one by one"] = (
            CPU.get("lockstep" if lockstep else "one by one", 0.0) + time.process_time() - c0)
        evaluations += sum(r.evaluations for r in results)
    return total, evaluations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problem", default="vehicle")
    parser.add_argument("--optimizers", default="de1,de2,de3,de4,de5,de6,de7,de8,ga")
    parser.add_argument("--ps", default="20,30")
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--extra", default="", help="more overrides, comma-free, space-separated")
    parser.add_argument("--keep", type=Path, default=None, help="keep outputs in this folder")
    args = parser.parse_args()

    optimizers, sizes = args.optimizers.split(","), args.ps.split(",")
    extra = args.extra.split()
    sweep = ["-m", f"problem={args.problem}", f"optimizer={args.optimizers}",
             f"problem.ps={args.ps}", f"runs={args.runs}", "progress=false", *extra]
    root = args.keep or Path(tempfile.mkdtemp(prefix="vpid-chain-"))
    root.mkdir(parents=True, exist_ok=True)
    print("command: vpid-bench " + " ".join(sweep))
    jobs = [[f"problem={args.problem}", f"optimizer={o}", f"problem.ps={ps}",
             f"runs={args.runs}", *extra] for o in optimizers for ps in sizes]
    alone, evaluations = runs_alone(jobs)
    one_by_one, _ = runs_alone(jobs, lockstep=False)
    no_report = timed([*CLI, *sweep, "report=false", f"hydra.sweep.dir={root / 'noreport'}"],
                      root, "no report")
    chain = timed([*CLI, *sweep, f"hydra.sweep.dir={root / 'chain'}"], root, "chain")
    report = timed([*REPORT, str(root / "noreport"), "-o", str(root / "report")], root,
                   "report")
    fixed = timed([*CLI, "-m", f"problem={args.problem}", f"optimizer={optimizers[0]}",
                   "runs=1", "problem.iterations=1", "progress=false", "report=false", *extra,
                   f"hydra.sweep.dir={root / 'fixed'}"], root, "fixed")
    print(f"jobs: {len(jobs)}, runs: {len(jobs) * args.runs}, evaluations: {evaluations}")
    print(f"  runs alone (in process, lockstep): {alone:7.2f} s "
          f"({evaluations / alone:,.0f} evaluations/s)")
    print(f"  runs alone, one after another:     {one_by_one:7.2f} s  (lockstep speed-up "
          f"{one_by_one / alone:.2f}x)")
    print(f"  CLI, report=false:                 {no_report:7.2f} s  = "
          f"{no_report / alone:5.2f}x runs")
    print(f"  CLI, report included (the chain):  {chain:7.2f} s  = {chain / alone:5.2f}x runs "
          "(target <= 2)")
    print(f"  vpid-bench-report alone:           {report:7.2f} s  (its own process, imports "
          "included)")
    print(f"  fixed start (1 job, 1 run, 1 generation): {fixed:6.2f} s")
    print(f"  per job outside the runs (no report): {(no_report - alone) / len(jobs):.3f} s, "
          f"without the fixed start {(no_report - fixed - alone) / len(jobs):.3f} s")
    cpu = CPU
    print(f"CPU seconds: runs alone {cpu['lockstep']:.2f} (one by one {cpu['one by one']:.2f}), "
          f"CLI report=false {cpu['no report']:.2f} = {cpu['no report'] / cpu['lockstep']:.2f}x, "
          f"chain {cpu['chain']:.2f} = {cpu['chain'] / cpu['lockstep']:.2f}x, "
          f"report alone {cpu['report']:.2f}")
    print(f"outputs: {root}")


if __name__ == "__main__":
    main()
