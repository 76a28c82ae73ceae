"""What an archive build costs, per member and per optimizer, measured on a slice of it and set
beside the kernel-only time of the same evaluations, side by side in one run.

    MPLBACKEND=Agg .venv/bin/python tools/archive_cost.py --suite vpid1 --runs 1 \\
        --full-runs 15 --target 1e-8 [--problems a,b] [--optimizers x,y] [--sweep DIR]
    MPLBACKEND=Agg .venv/bin/python tools/archive_cost.py \\
        --built outputs/archive-vpid1 [--wall-s SECONDS]   # a finished build, nothing run

The slice's build (:func:`build_archive.build`, every stage into ``--out``), its wall and
CPU time per stage, beside the kernel-only time of the same evaluations (each member's µs
per candidate, :func:`_shared.kernel_us`, timed before and after the build: their mean),
per member and per optimizer, and extrapolated to ``--full-runs`` instances (the method
and the measurements: docs/sweeps.md, what the vpid1 build costs). Timings on a shared
machine move by up to 2x between invocations: compare the columns of one invocation.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from build_archive import ROOT, build, parse_args

from vpid_bench.machine import available_cores
from vpid_bench.plugins import Registry

sys.path.insert(0, str(ROOT / "benchmarks"))
from _shared import kernel_us  # noqa: E402  (the benchmarks' timer, one home)


def cpu_seconds() -> float:
    """CPU seconds (user + system) of this process and of its children that ended."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), \
        resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def yardstick(args: argparse.Namespace, seconds: float) -> dict[str, tuple[float, float]]:
    """:func:`kernel_us` of every member the build will sweep, timed before it starts."""
    names = (args.problems.split(",") if args.problems
             else sorted(Registry().suites().get(args.suite, ())))
    return {m: kernel_us({"name": m}, seconds) for m in names}


def read_jobs(runs_dir: Path) -> list[dict[str, Any]]:
    """Per job folder: problem, optimizer, its wall time (``job.json``), and per record
    ``(evaluations, run_time_s, stopped_by)``."""
    jobs = []
    for job_json in sorted(runs_dir.glob("*/job.json")):
        detail = json.loads(job_json.read_text(encoding="utf-8")).get("detail") or {}
        runs = []
        for path in sorted((job_json.parent / "records").glob("run-*.json")):
            rec = json.loads(path.read_text(encoding="utf-8"))
            res, timing = rec.get("result") or {}, rec.get("timing") or {}
            runs.append((int(res.get("evaluations") or 0), float(timing.get("run_time_s") or 0),
                         res.get("stopped_by")))
        jobs.append({"problem": detail.get("problem"), "optimizer": detail.get("optimizer"),
                     "wall": float(detail.get("wall_time_s") or 0.0), "runs": runs})
    return jobs


def table(title: str, key: str, jobs: list[dict[str, Any]], us: dict[str, float],
          scale: float, workers: int) -> None:
    """One row per ``key`` (``problem`` or ``optimizer``), largest extrapolated cost first."""
    rows: dict[str, dict[str, float]] = defaultdict(lambda: defaultdict(float))
    for j in jobs:
        r = rows[j[key]]
        evals = sum(e for e, _, _ in j["runs"])
        run_s = sum(t for _, t, _ in j["runs"])
        r["runs"] += len(j["runs"])
        r["evals"] += evals
        r["run_s"] += run_s
        r["kernel_s"] += evals * us[j["problem"]] * 1e-6
        r["analysis_s"] += max(0.0, j["wall"] - run_s / max(1, min(len(j["runs"]), workers)))
        r["reached"] += sum(1 for _, _, s in j["runs"] if s == "target")
    total = sum(r["run_s"] / workers + r["analysis_s"] for r in rows.values()) * scale
    print(f"\n{title} (extrapolated to x{scale:g} the runs; s of wall on {workers} worker(s))")
    print(f"| {key} | runs | stopped at target | evaluations (M) | runs' own time (s) | "
          "kernel only (s) | runs / kernel | analysis (s) | extrapolated wall (s) | share |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    order = sorted(rows.items(), key=lambda kv: -(kv[1]["run_s"] / workers + kv[1]["analysis_s"]))
    for name, r in order:
        wall = (r["run_s"] / workers + r["analysis_s"]) * scale
        print(f"| {name} | {r['runs']:.0f} | {r['reached']:.0f} | {r['evals'] / 1e6:.3f} | "
              f"{r['run_s']:.1f} | {r['kernel_s']:.1f} | "
              f"{r['run_s'] / max(r['kernel_s'], 1e-9):.1f} | {r['analysis_s']:.1f} | "
              f"{wall:.0f} | {100 * wall / max(total, 1e-9):.1f} % |")


def built_report(runs_dir: Path, wall_s: float | None, kernel_seconds: float) -> None:
    """A finished build (every job of ``runs_dir``) beside the kernel-only time of its
    evaluations (the runs' own time against the kernel's: a build in several sittings has
    no single CPU figure), and the build's wall time when given."""
    jobs = read_jobs(runs_dir)
    if not jobs:
        raise SystemExit(f"error: no job.json below {runs_dir}")
    us = {m: kernel_us({"name": m}, kernel_seconds)[0] for m in {j["problem"] for j in jobs}}
    workers = available_cores()
    evals = sum(e for j in jobs for e, _, _ in j["runs"])
    kernel_1 = sum(e * us[j["problem"]] for j in jobs for e, _, _ in j["runs"]) * 1e-6
    run_s = sum(t for j in jobs for _, t, _ in j["runs"])
    print(f"build: {sum(len(j['runs']) for j in jobs)} runs in {len(jobs)} jobs, "
          f"{evals:,} evaluations")
    print(f"kernel only, the same evaluations: {kernel_1:.1f} s on one core, "
          f"{kernel_1 / workers:.1f} s on {workers} cores")
    print(f"runs' own time (the optimizers and their evaluations, summed over runs): "
          f"{run_s:.1f} s, {run_s / max(kernel_1, 1e-9):.2f}x the kernel's")
    if wall_s is not None:
        print(f"build wall {wall_s:.0f} s / kernel only on {workers} cores: "
              f"{wall_s / max(kernel_1 / workers, 1e-9):.2f}x")
    for title, key in (("Per member", "problem"), ("Per optimizer", "optimizer")):
        table(title, key, jobs, us, 1.0, workers)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--full-runs", type=int, default=15,
                    help="the instances of the full build, for the extrapolation")
    ap.add_argument("--kernel-seconds", type=float, default=1.0,
                    help="timing per member for its kernel's microseconds per candidate")
    ap.add_argument("--built", type=Path, default=None,
                    help="a finished build's sweep folder (its runs/): no build, its runs "
                         "set beside the kernel-only time of their evaluations")
    ap.add_argument("--wall-s", type=float, default=None,
                    help="with --built: the build's wall time as measured (s), for the ratio")
    own, rest = ap.parse_known_args()
    if own.built is not None:
        built_report(own.built / "runs", own.wall_s, own.kernel_seconds)
        return
    args = parse_args(rest)
    if args.out is None:
        raise SystemExit("error: --out is required (a slice is never packed into archive/)")
    before = yardstick(args, own.kernel_seconds)
    t0, c0 = time.perf_counter(), cpu_seconds()
    built = build(args)
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
    if not built.ok:
        raise SystemExit("error: the build did not end clean")
    jobs = read_jobs(built.runs_dir)
    members = sorted({j["problem"] for j in jobs})
    after = {m: kernel_us({"name": m}, own.kernel_seconds) for m in members}
    measured = {m: tuple((a + b) / 2 for a, b in zip(after[m], before.get(m, after[m])))
                for m in members}
    us = {m: w for m, (w, _) in measured.items()}
    cpu_us = {m: c for m, (_, c) in measured.items()}
    workers = available_cores()
    evals = {m: sum(e for j in jobs if j["problem"] == m for e, _, _ in j["runs"]) for m in members}
    kernel_1 = sum(evals[m] * us[m] for m in members) * 1e-6
    print(f"\nbuild of the slice: {wall:.1f} s wall ("
          + ", ".join(f"{k} {v:.1f} s" for k, v in built.seconds.items()) + f"); "
          f"{sum(len(j['runs']) for j in jobs)} runs in {len(jobs)} jobs, "
          f"{sum(evals.values()):,} evaluations")
    print(f"kernel only, the same evaluations: {kernel_1:.1f} s on one core, "
          f"{kernel_1 / workers:.1f} s on {workers} cores (the mean of its timings before "
          "and after the build; " + ", ".join(
              f"{when} {sum(evals[m] * t[m][0] for m in members) * 1e-6:.1f} s"
              for when, t in (("before", before), ("after", after)) if set(t) >= set(members))
          + " on one core)")
    print(f"build / kernel only on {workers} cores: {wall / max(kernel_1 / workers, 1e-9):.2f}x"
          f" (the runs stage alone: {built.seconds['runs'] / max(kernel_1 / workers, 1e-9):.2f}x)")
    kernel_cpu = sum(evals[m] * cpu_us[m] for m in members) * 1e-6
    print(f"in CPU seconds (what other programs on the machine do not inflate): build "
          f"{cpu:.1f} s, kernel only {kernel_cpu:.1f} s: {cpu / max(kernel_cpu, 1e-9):.2f}x")
    print("kernel us per candidate (batch 20, one thread): "
          + ", ".join(f"{m} {us[m]:.0f}" for m in members))
    scale = own.full_runs / args.runs
    jobs_wall = sum(j["wall"] for j in jobs)
    fixed = built.seconds["runs"] - jobs_wall  # Hydra, start-up, warm-ups: once per job
    runs_part = sum(sum(t for _, t, _ in j["runs"]) for j in jobs) / workers
    analysis = jobs_wall - sum(sum(t for _, t, _ in j["runs"]) / max(1, min(len(j["runs"]),
                                                                          workers)) for j in jobs)
    other = sum(v for k, v in built.seconds.items() if k != "runs")
    predicted = (runs_part + max(analysis, 0.0)) * scale + fixed + other
    print(f"extrapolated to {own.full_runs} instances: {predicted / 60:.1f} min "
          f"(runs {runs_part * scale:.0f} s + analysis {max(analysis, 0) * scale:.0f} s, "
          f"scaled x{scale:g}; outside the jobs {fixed:.0f} s and other stages {other:.0f} s, "
          "as measured)")
    for title, key in (("Per member", "problem"), ("Per optimizer", "optimizer")):
        table(title, key, jobs, us, scale, workers)


if __name__ == "__main__":
    main()
