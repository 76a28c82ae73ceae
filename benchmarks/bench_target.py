"""The 10x study of docs/study.md with and without stop at the final target, side by side.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_target.py [--runs 30] [--optimizers ...]

Runs the study's sweep (both record designs, 10x the paper's budget) twice into fresh folders,
report included: as committed, and with ``target=1e-8`` (each run ends once within 1e-8 of its
instance's optimum, certified in advance by ``archive/paper``). Prints each wall time, their
ratio, the evaluations each used, and checks that the fixed-target results (the report's
``tables/ert.csv``, in evaluations) are the same in both.
"""

from __future__ import annotations

import argparse
import csv
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


def evaluations(folder: Path) -> int:
    with open(folder / "report" / "runs.csv", encoding="utf-8") as fh:
        return sum(int(float(r["evaluations"])) for r in csv.DictReader(fh)
                   if r["status"] == "ok")


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
        e_whole, e_cut = evaluations(whole), evaluations(cut)
    print(f"10x study, {args.runs} runs per job, optimizers {args.optimizers}")
    print(f"  whole budget:        {t_whole:7.1f} s, {e_whole:,} evaluations")
    print(f"  stop at 1e-8:        {t_cut:7.1f} s, {e_cut:,} evaluations")
    print(f"  ratio (whole / stop): {t_whole / t_cut:.2f}x in time, "
          f"{e_whole / e_cut:.2f}x in evaluations")
    print(f"  fixed-target results (ert.csv, evaluations) identical: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
