"""One sweep through the CLI several ways, side by side in one invocation: what worker
processes, threads, a launcher, the report or the stop at the target cost or give.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_sweeps.py [--ways none,one,threads,default]
        [--optimizers ...] [--problems vehicle] [--ps 20] [--iterations 200] [--runs 30]
        [--runs-alone] [--kernel] [--report-alone] [--fixed-start]

Each way (:data:`WAYS`) runs the same ``vpid-bench -m`` sweep into its own folder. Per way:
wall and CPU seconds, evaluations per second, the speed-up over the first way, the runs' own
time, whether its records (fingerprints without timing) and ``tables/ert.csv`` are the first
way's, each beside the yardsticks the flags ask for, timed in the same invocation (what each
is, and the measurements: docs/sweeps.md, speed at scale).
"""

from __future__ import annotations

import argparse
import csv
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from _shared import CLI, REPORT, compose, kernel_us, registry_with_configs, run_timed

from vpid_bench.build import ProblemCache, run_rng
from vpid_bench.job_runs import joins_lockstep
from vpid_bench.machine import available_cores
from vpid_bench.runner import Lane, run, run_many
from vpid_bench.spec import parse_job
from vpid_bench.store import records as rec

#: name: (what it is, its overrides); a way without ``report=`` runs ``report=false``
WAYS = {
    "none": ("in-process, 1 core", ["isolation=none", "threads=1"]),
    "one": ("1 worker process", ["workers=1", "threads=1"]),
    "threads": ("in-process, kernel threads", ["isolation=none"]),
    "default": ("default (a worker per core)", []),
    "joblib": ("joblib launcher, 2 jobs", ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"]),
    "report": ("default, report included", ["report=true"]),
    "target": ("target=1e-8, report included", ["target=1e-8", "report=true"]),
}


def summary(folder: Path) -> dict:
    """The sweep's record fingerprints, evaluations per problem config, runs' own time and
    fixed-target table (``None`` without a report)."""
    prints, evaluations, run_s = {}, {}, 0.0
    for path in rec.iter_record_files([folder]):
        record = rec.read_record(path)
        prints[str(path.relative_to(folder))] = rec.fingerprint(record)
        key = json.dumps({"name": record["problem"]["name"], **record["problem"]["config"]},
                         sort_keys=True)
        evaluations[key] = evaluations.get(key, 0) + int(record["result"]["evaluations"])
        run_s += float(record["timing"]["run_time_s"])
    ert = folder / "report" / "tables" / "ert.csv"
    if ert.is_file():
        with open(ert, encoding="utf-8") as fh:
            ert = {(r["context"], r["algorithm"], r["target_rel_gap"]): r["ert"]
                   for r in csv.DictReader(fh)}
    return {"prints": prints, "evaluations": evaluations, "run_s": run_s,
            "ert": ert if isinstance(ert, dict) else None}


def runs_alone(jobs: list[list[str]], lockstep: bool) -> float:
    """Seconds the runs of the given jobs take in this process, nothing around them
    (``lockstep=False``: one run after another)."""
    registry, cache, total = registry_with_configs(), ProblemCache(), 0.0
    for overrides in jobs:
        job = parse_job(compose(overrides), registry)
        problem = cache.get(job)
        problem.set_threads(job.spec.threads or available_cores())
        X = problem.bounds.sample(np.random.default_rng(0), 2)
        problem.evaluate(X)  # compile outside the clock
        problem.evaluate_instances(X, np.array([0, 1]))
        optimizers = [job.optimizer_cls(job.params, problem.bounds, run_rng(job.spec.seed, i))
                      for i in range(job.spec.runs)]
        t0 = time.perf_counter()
        if lockstep and joins_lockstep(job, problem):
            run_many(problem, [Lane(problem.instance(i), o, job.budget, i)
                               for i, o in enumerate(optimizers)])
        else:
            for i, o in enumerate(optimizers):
                run(problem.instance(i), o, job.budget)
        total += time.perf_counter() - t0
    return total


def parse_args() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ways", default="none,one,threads,default",
                    help=f"comma-separated, the first the reference: {', '.join(WAYS)}")
    ap.add_argument("--optimizers", default="de1,de4,ga,random,cmaes,lsq")
    ap.add_argument("--problems", default="vehicle")
    ap.add_argument("--ps", default="20")
    ap.add_argument("--iterations", type=int, default=200)
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--extra", default="", help="more overrides, space-separated")
    ap.add_argument("--runs-alone", action="store_true")
    ap.add_argument("--kernel", action="store_true")
    ap.add_argument("--report-alone", action="store_true")
    ap.add_argument("--fixed-start", action="store_true")
    ap.add_argument("--keep", type=Path, default=None, help="keep outputs in this folder")
    args = ap.parse_args()
    unknown = [w for w in args.ways.split(",") if w not in WAYS]
    if unknown:
        ap.exit(2, f"error: --ways {unknown[0]}: one of {', '.join(WAYS)}\n")
    return args


def main() -> None:
    args = parse_args()
    ways = args.ways.split(",")
    first_problem, first_optimizer = args.problems.split(",")[0], args.optimizers.split(",")[0]
    common = [f"problem.iterations={args.iterations}", f"runs={args.runs}", *args.extra.split()]
    sweep = ["-m", f"problem={args.problems}", f"optimizer={args.optimizers}",
             f"problem.ps={args.ps}", *common, "progress=false"]
    root = args.keep or Path(tempfile.mkdtemp(prefix="vpid-sweeps-"))
    root.mkdir(parents=True, exist_ok=True)
    print("command: vpid-bench " + " ".join(sweep) + " [each way's overrides]")
    walls, cpus, made = {}, {}, {}
    for way in ways:
        overrides = WAYS[way][1]
        if not any(o.startswith("report=") for o in overrides):
            overrides = [*overrides, "report=false"]
        walls[way], cpus[way] = run_timed([*CLI, *sweep, *overrides,
                                           f"hydra.sweep.dir={root / way}"], root)
        made[way] = summary(root / way)
    yard: dict[str, float] = {}
    first = made[ways[0]]
    if args.runs_alone:
        jobs = [[f"problem={p}", f"optimizer={o}", f"problem.ps={ps}", *common]
                for p in args.problems.split(",") for o in args.optimizers.split(",")
                for ps in args.ps.split(",")]
        yard["runs alone"] = runs_alone(jobs, lockstep=True)
        one_by_one = runs_alone(jobs, lockstep=False)
        print(f"runs alone (in process, lockstep): {yard['runs alone']:.2f} s; one after "
              f"another {one_by_one:.2f} s (lockstep speed-up "
              f"{one_by_one / yard['runs alone']:.2f}x)")
    if args.kernel:
        us = {key: kernel_us(json.loads(key))[0] for key in first["evaluations"]}
        yard["kernel, 1 core"] = sum(first["evaluations"][k] * us[k] for k in us) * 1e-6
        yard["kernel, every core"] = yard["kernel, 1 core"] / available_cores()
        for key, value in us.items():
            cfg = json.loads(key)
            extra = (cfg.get("record") or {}).get("extra")
            print(f"kernel: {value:.2f} us per candidate (one thread, batches of 20) x "
                  f"{first['evaluations'][key]:,} evaluations of {cfg['name']} ps={cfg['ps']}"
                  + (f" record.extra={extra}" if extra is not None else ""))
    cores = available_cores()
    n_first = sum(first["evaluations"].values())
    print(f"cores: {cores}, records: {len(first['prints'])}, evaluations: {n_first:,} "
          "(first way)" + "".join(f", {k} {v:.2f} s" for k, v in yard.items()))
    reported = next((made[w]["ert"] for w in ways if made[w]["ert"] is not None), None)
    for way in ways:
        m, wall = made[way], walls[way]
        ert = "" if m["ert"] is None else f", ert.csv as the first reported: {m['ert'] == reported}"
        print(f"  {WAYS[way][0]:30s}: {wall:8.2f} s wall, {cpus[way]:8.2f} s CPU, "
              f"{sum(m['evaluations'].values()):,} evaluations "
              f"({sum(m['evaluations'].values()) / wall:,.0f}/s), "
              f"{walls[ways[0]] / wall:.2f}x the first; runs' own time {m['run_s']:.2f} s; "
              f"records as the first: {m['prints'] == first['prints']}{ert}"
              + "".join(f"; {wall / v:.2f}x {k}" for k, v in yard.items()))
    if args.report_alone:
        wall, cpu = run_timed([*REPORT, str(root / ways[0]), "-o", str(root / "report-alone")])
        print(f"vpid-bench-report alone on the first way's records: {wall:.2f} s wall, "
              f"{cpu:.2f} s CPU")
    if args.fixed_start:
        wall, cpu = run_timed([*CLI, "-m", f"problem={first_problem}",
                               f"optimizer={first_optimizer}", "runs=1", "problem.iterations=1",
                               "progress=false", "report=false", *args.extra.split(),
                               f"hydra.sweep.dir={root / 'fixed'}"], root)
        print(f"fixed start (1 job, 1 run, 1 generation): {wall:.2f} s wall, {cpu:.2f} s CPU")
    print(json.dumps({"walls": walls, "cpus": cpus, "yardsticks": yard}))
    print(f"outputs: {root}")


if __name__ == "__main__":
    main()
