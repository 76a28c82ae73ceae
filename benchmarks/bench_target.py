"""The 10x study of docs/study.md with and without stop at the final target, side by side.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_target.py [--runs 30] [--optimizers ...]

Runs the study's sweep (both record designs, 10x the paper's budget) twice into fresh folders,
report included: as committed, and with ``target=1e-8`` (each run ends once within 1e-8 of its
instance's optimum, certified in advance by ``archive/paper``). Prints each wall time, their
ratio, the evaluations each used, and checks that the fixed-target results (the report's
``tables/ert.csv``, in evaluations) are the same in both.

Then the yardstick of the issue on studies at kernel speed: the time the kernel alone needs
for the evaluations of the study at its whole budget (each design's evaluations times its
kernel's microseconds per candidate at PS 20 on one thread, measured here), on one core and
spread over every core, and the study's wall time with the stop as a multiple of it.
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BIN = Path(sys.executable).parent
OPTIMIZERS = "de1,de4,de6,jade,shade,lshade,ga,scipy_de,cmaes,lsq,de_lsq,random"


def sweep(folder: Path, runs: int, optimizers: str, extra: list[str]) -> float:
    """Wall time (s) of the study's sweep into ``folder``, report included."""
    argv = [str(BIN / "vpid-bench"), "-m", f"optimizer={optimizers}",
            "problem=vehicle,vehicle_long_record", "problem.iterations=509", f"runs={runs}",
            "progress=false", f"hydra.sweep.dir={folder}", *extra]
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return seconds


def ert_table(folder: Path) -> dict[tuple[str, str, str], str]:
    with open(folder / "report" / "tables" / "ert.csv", encoding="utf-8") as fh:
        return {(r["context"], r["algorithm"], r["target_rel_gap"]): r["ert"]
                for r in csv.DictReader(fh)}


def evaluations(folder: Path) -> dict[float, int]:
    """Evaluations of the successful runs, per design (its ``problem.record.extra``, s)."""
    out: dict[float, int] = {}
    with open(folder / "report" / "runs.csv", encoding="utf-8") as fh:
        for r in csv.DictReader(fh):
            if r["status"] == "ok":
                extra = float(r["problem.record.extra"])
                out[extra] = out.get(extra, 0) + int(float(r["evaluations"]))
    return out


def kernel_us(extra: float, seconds: float = 1.0) -> float:
    """The vehicle kernel's microseconds per candidate on one thread for the design whose
    record extends ``extra`` s past the paper's window (batches of PS 20, random candidates in
    the box, the median of 5 timings of ``seconds / 5`` each)."""
    import statistics

    import numpy as np

    from vpid_bench.build import build_problem
    from vpid_bench.plugins import Registry

    problem = build_problem(Registry(), {"name": "vehicle", "ps": 20,
                                         "record": {"extra": extra}})
    problem.set_threads(1)
    X = problem.bounds.sample(np.random.default_rng(0), 20)
    problem.evaluate(X)  # compiled on first use
    times = []
    for _ in range(5):
        reps, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds / 5:
            problem.evaluate(X)
            reps += 1
        times.append((time.perf_counter() - t0) / reps / 20 * 1e6)
    return statistics.median(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--optimizers", default=OPTIMIZERS)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        whole, cut = Path(tmp) / "whole", Path(tmp) / "target"
        t_whole = sweep(whole, args.runs, args.optimizers, [])
        t_cut = sweep(cut, args.runs, args.optimizers, ["target=1e-8"])
        same = ert_table(whole) == ert_table(cut)
        per_design, e_cut = evaluations(whole), sum(evaluations(cut).values())
    e_whole = sum(per_design.values())
    print(f"10x study, {args.runs} runs per job, optimizers {args.optimizers}")
    print(f"  whole budget:        {t_whole:7.1f} s, {e_whole:,} evaluations")
    print(f"  stop at 1e-8:        {t_cut:7.1f} s, {e_cut:,} evaluations")
    print(f"  ratio (whole / stop): {t_whole / t_cut:.2f}x in time, "
          f"{e_whole / e_cut:.2f}x in evaluations")
    print(f"  fixed-target results (ert.csv, evaluations) identical: {same}")
    us = {name: kernel_us(name) for name in per_design}
    alone = sum(per_design[name] * us[name] for name in per_design) / 1e6
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print("  kernel alone for the whole budget's evaluations: "
          + ", ".join(f"record.extra={name:g}: {us[name]:.2f} us x {per_design[name]:,}"
                      for name in us)
          + f" = {alone:.1f} s on one core, {alone / cores:.1f} s on {cores} cores")
    print(f"  the study with the stop: {t_cut / alone:.2f}x the kernel alone on one core, "
          f"{t_cut / (alone / cores):.2f}x on {cores} cores (target <= 2)")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
