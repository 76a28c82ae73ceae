"""A large study: 10 optimizers x 30 instances (runs) x 2 record designs at the paper's budget.

One sweep through the CLI (report off, then the report alone on its records), printing wall
time and evaluations per second. The designs are the paper's record (``problem=vehicle``) and
the longer one (``problem=vehicle_long_record``); the budget is the paper's protocol at
``problem.ps=20`` (1,020 evaluations per run). Optimizers that ask and tell join the job's
lockstep; the loop-owning ``scipy_de`` runs its runs one after another (it shows what
lockstep is worth). Quick version: ``--optimizers de1,ga --runs 5``.
Launcher: ``--launcher joblib`` adds ``hydra/launcher=joblib hydra.launcher.n_jobs=2``.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from _shared import CLI, REPORT, run_timed

OPTIMIZERS = "de1,de2,de4,de8,jade,shade,lshade,ga,cmaes,scipy_de"
LAUNCHERS = {"basic": [], "joblib": ["hydra/launcher=joblib", "hydra.launcher.n_jobs=2"]}


def timed(cmd: list[str], cwd: Path) -> float:
    """Wall time of one command (it must succeed)."""
    return run_timed(cmd, cwd)[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--optimizers", default=OPTIMIZERS)
    parser.add_argument("--designs", default="vehicle,vehicle_long_record")
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--launcher", default="basic", choices=sorted(LAUNCHERS))
    parser.add_argument("--keep", type=Path, default=None)
    args = parser.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="vpid-study-"))
    root.mkdir(parents=True, exist_ok=True)
    sweep = ["-m", f"problem={args.designs}", f"optimizer={args.optimizers}", "problem.ps=20",
             f"runs={args.runs}", "progress=false", "report=false", *LAUNCHERS[args.launcher]]
    print("command: vpid-bench " + " ".join(sweep))
    wall = timed([*CLI, *sweep, f"hydra.sweep.dir={root / 'sweep'}"], root)
    report = timed([*REPORT, str(root / "sweep"), "-o", str(root / "report")], root)
    evaluations, runs, run_seconds = 0, 0, 0.0
    for path in (root / "sweep").rglob("records/run-*.json"):
        record = json.loads(path.read_text())
        runs += 1
        evaluations += int(record["result"]["evaluations"])
        run_seconds += float(record["timing"]["wall_time_s"])
    jobs = len(args.optimizers.split(",")) * len(args.designs.split(","))
    print(f"jobs: {jobs}, runs: {runs}, evaluations: {evaluations:,}")
    print(f"  sweep ({args.launcher}, report off): {wall:8.2f} s wall, "
          f"{evaluations / wall:,.0f} evaluations/s")
    print(f"  the runs' own time (sum of records' timing): {run_seconds:8.2f} s")
    print(f"  report alone (vpid-bench-report):      {report:8.2f} s")
    print(f"  whole study: {wall + report:8.2f} s")
    print(f"outputs: {root}")


if __name__ == "__main__":
    main()
