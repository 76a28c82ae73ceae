"""The paper experiment through the real CLI, timed end to end, with the framework's overhead.

Runs ``vpid-bench -m optimizer=<all> problem.ps=20,30 runs=30`` (the paper's protocol; the
report included) with the basic launcher and, side by side in the same invocation of this
script, with the joblib launcher on 2 processes. Then measures, in this process, what the
objective alone costs per evaluation at each population size, and prints

* wall time of each launcher and their ratio (joblib speed-up),
* evaluations per second (counted from the records),
* the objective's own cost per evaluation and the sweep's time per evaluation,
* their ratio: how many times the bare evaluations the whole chain takes (target <= 4),
* the start-up of a single-job command against ``python -c pass``.

Only ratios measured in one run mean anything on a shared machine. Quick version:
``python benchmarks/paper_experiment.py --runs 3 --optimizers de1,ga``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _shared import CLI, cli_env, run_timed


def run_sweep(args: list[str], cwd: Path) -> float:
    """Wall time of one CLI invocation (it must succeed)."""
    return run_timed([*CLI, *args], cwd)[0]


def count_evaluations(sweep_dir: Path) -> dict[int, int]:
    """Evaluations recorded below ``sweep_dir``, per population size."""
    out: dict[int, int] = {}
    for path in sweep_dir.rglob("records/run-*.json"):
        record = json.loads(path.read_text())
        ps = int(record["problem"]["config"]["ps"])
        out[ps] = out.get(ps, 0) + int(record["result"]["evaluations"])
    return out


def objective_cost(problem: str, ps: int, seconds: float = 1.0) -> float:
    """Seconds per evaluation of the objective alone, on batches of ``ps`` random candidates."""
    import numpy as np

    from vpid_bench.build import build_problem
    from vpid_bench.params import dataclass_defaults
    from vpid_bench.plugins import Registry

    registry = Registry()
    cfg = dataclass_defaults(registry.problem(problem).Config) | {"name": problem, "ps": ps}
    prob = build_problem(registry, cfg)
    rng = np.random.default_rng(0)
    batches = [prob.bounds.sample(rng, ps) for _ in range(64)]
    prob.evaluate(batches[0])  # compile / warm caches
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        for X in batches:
            prob.evaluate(X)
        n += len(batches) * ps
    return (time.perf_counter() - t0) / n


def startup(repeat: int = 3) -> tuple[float, float, float]:
    """Best-of wall times: ``python -c pass``, a one-run job with and without its report."""
    def best(cmd: list[str], cwd: Path) -> float:
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            subprocess.run(cmd, cwd=cwd, env=cli_env(), capture_output=True, check=True)
            times.append(time.perf_counter() - t0)
        return min(times)

    with tempfile.TemporaryDirectory() as tmp:
        job = [*CLI, "problem=functions", "optimizer=random", "runs=1", "progress=false"]
        return (best([sys.executable, "-c", "pass"], Path(tmp)), best(job, Path(tmp)),
                best([*job, "report=false"], Path(tmp)))


def main() -> None:
    from vpid_bench.plugins import Registry

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problem", default="vehicle")
    parser.add_argument("--optimizers", default=None,
                        help="comma-separated; default: de1..de8 and ga (those registered)")
    parser.add_argument("--ps", default="20,30")
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--launchers", default="basic,joblib")
    parser.add_argument("--keep", type=Path, default=None, help="keep outputs in this folder")
    parser.add_argument("--no-report", action="store_true",
                        help="sweeps without their report (isolates the launchers' share)")
    args = parser.parse_args()

    registry = Registry()
    wanted = args.optimizers.split(",") if args.optimizers else [
        *(f"de{i}" for i in range(1, 9)), "ga"]
    optimizers = [o for o in wanted if o in registry.optimizers]
    if not optimizers:
        sys.exit(f"none of {wanted} is registered")
    sizes = [int(s) for s in args.ps.split(",")]
    sweep = ["-m", f"problem={args.problem}", "optimizer=" + ",".join(optimizers),
             "problem.ps=" + args.ps, f"runs={args.runs}", "progress=false",
             *(["report=false"] if args.no_report else [])]
    launcher_args = {"basic": [], "joblib": ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"]}
    root = args.keep or Path(tempfile.mkdtemp(prefix="vpid-paper-"))
    root.mkdir(parents=True, exist_ok=True)
    print("command: vpid-bench " + " ".join(sweep))
    walls: dict[str, float] = {}
    evaluations: dict[int, int] = {}
    for name in args.launchers.split(","):
        sweep_dir = root / name
        walls[name] = run_sweep([*sweep, *launcher_args[name], f"hydra.sweep.dir={sweep_dir}"],
                                root)
        evaluations = count_evaluations(sweep_dir)
        print(f"  {name:7s} launcher: {walls[name]:8.2f} s wall "
              f"({'no report' if args.no_report else 'report included'})")
    costs = {ps: objective_cost(args.problem, ps) for ps in sizes}
    total_evals = sum(evaluations.values())
    bare = sum(evaluations[ps] * costs[ps] for ps in evaluations)
    cpu_count = os.cpu_count() or 1
    print(f"jobs: {len(optimizers) * len(sizes)}, runs: {len(optimizers) * len(sizes) * args.runs},"
          f" evaluations: {total_evals}, cores: {cpu_count}")
    for ps in sizes:
        print(f"  objective alone, ps={ps}: {costs[ps] * 1e6:8.2f} us per evaluation")
    print(f"  objective alone, all evaluations: {bare:8.2f} s")
    for name, wall in walls.items():
        print(f"  {name:7s}: {total_evals / wall:10.0f} evaluations/s, "
              f"{wall / total_evals * 1e6:8.2f} us per evaluation, "
              f"wall / objective-alone = {wall / bare:6.2f}  (target <= 4 for basic)")
    if "basic" in walls and "joblib" in walls:
        print(f"  joblib speed-up over basic: {walls['basic'] / walls['joblib']:.2f}x "
              "(target >= 1.6 on 2 cores)")
    py, job, job_noreport = startup()
    print(f"start-up: python -c pass {py:.2f} s; single job (runs=1) {job:.2f} s with its "
          f"report, {job_noreport:.2f} s with report=false (target < 1.5 s)")
    print(f"outputs: {root}")


if __name__ == "__main__":
    main()
