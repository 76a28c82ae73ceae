"""What the end-of-job analysis (each instance's optimum, the Cramér–Rao bounds) costs beside
the runs, on the paper experiment.

Runs the jobs of ``vpid-bench -m optimizer=<all> problem.ps=20,30`` in this process (the
function the command calls per job, :func:`vpid_bench.experiment.run_from_config`), twice side
by side:

* ``per-job``: each job polishes its instances' optima in its own ``<job>/optima`` folder;
* ``shared``: all jobs share one ``<sweep>/optima`` folder (each instance is polished from its
  truth once per sweep; later jobs only polish their own near-optimal run bests).

For each it prints the time spent in the runs, in the analysis (timed around
``experiment.analyse_job``), their ratio, and the number of polishes. Only the ratios mean
anything on a shared machine. Quick version:
``python benchmarks/bench_analysis.py --runs 5 --optimizers de1,ga``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from _shared import compose, registry_with_configs

PAPER = "de1,de2,de3,de4,de5,de6,de7,de8,ga,random"


def sweep(root: Path, optimizers: list[str], ps_values: list[int], runs: int, shared: bool,
          extra: list[str]) -> dict[str, float]:
    """Run the jobs; return seconds in runs, seconds in the analysis and polish counts."""
    from vpid_bench import experiment
    from vpid_bench.analysis import optimum

    registry = registry_with_configs()
    spent = {"analysis_s": 0.0, "polishes": 0}
    analyse, polish = experiment.analyse_job, optimum.polish

    def timed_analyse(*a, **k):
        t0 = time.perf_counter()
        try:
            return analyse(*a, **k)
        finally:
            spent["analysis_s"] += time.perf_counter() - t0

    def counted_polish(*a, **k):
        spent["polishes"] += 1
        return polish(*a, **k)

    experiment.analyse_job, optimum.polish = timed_analyse, counted_polish
    from vpid_bench.build import ProblemCache

    problems = ProblemCache()
    total = 0.0
    try:
        for ps in ps_values:
            for name in optimizers:
                cfg = compose([f"optimizer={name}", f"problem.ps={ps}", f"runs={runs}",
                                "progress=false", "report=false", *extra])
                job_dir = root / f"{name}-ps{ps}"
                t0 = time.perf_counter()
                experiment.run_from_config(cfg, job_dir, registry, problems,
                                           optima_dir=root / "optima" if shared else None)
                total += time.perf_counter() - t0
    finally:
        experiment.analyse_job, optimum.polish = analyse, polish
    return {"runs_s": total - spent["analysis_s"], **spent}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--optimizers", default=PAPER)
    parser.add_argument("--ps", default="20,30")
    parser.add_argument("overrides", nargs="*",
                        help="more overrides, e.g. problem.noise.per_run=false")
    args = parser.parse_args()
    os.environ.setdefault("MPLBACKEND", "Agg")
    optimizers = args.optimizers.split(",")
    ps_values = [int(v) for v in args.ps.split(",")]
    print(f"command: python benchmarks/bench_analysis.py --runs {args.runs} "
          f"--optimizers {args.optimizers} --ps {args.ps} {' '.join(args.overrides)}")
    with tempfile.TemporaryDirectory(prefix="vpid-analysis-") as tmp:  # compile, untimed
        sweep(Path(tmp), optimizers[:1], ps_values[:1], 1, True, args.overrides)
    for shared in (False, True):
        with tempfile.TemporaryDirectory(prefix="vpid-analysis-") as tmp:
            out = sweep(Path(tmp), optimizers, ps_values, args.runs, shared, args.overrides)
        label = "shared <sweep>/optima" if shared else "per-job <job>/optima"
        print(f"{label:24s} runs {out['runs_s']:7.1f} s  analysis {out['analysis_s']:7.1f} s  "
              f"analysis/runs {out['analysis_s'] / out['runs_s']:5.2f}  "
              f"polishes {out['polishes']}")


if __name__ == "__main__":
    main()
