"""The measured and third-party problems' evaluation (docs/measured.md), side by side in one
run: µs per candidate of ``evaluate`` for one candidate at a time and for a population, and
their ratio (what evaluating a population at once saves per candidate).

Problems at their defaults: ``emps`` (24,841 samples of the closed loop), ``bayesrace``
(1,001 samples, RK4 at 2 ms), ``racecar`` with linear and Magic Formula tyres (the fitted
windows, RK4 at 10 ms). Candidates: uniform in the box from one seed; the median over rounds.

    .venv/bin/python benchmarks/bench_measured.py [--rounds 5] [--batch 32]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from vpid_bench.build import build_problem
from vpid_bench.plugins import Registry

PROBLEMS = ({"name": "emps"}, {"name": "bayesrace"}, {"name": "racecar"},
            {"name": "racecar", "tyres": "magic_formula"})


def per_candidate_us(problem, X: np.ndarray, batch: int, rounds: int) -> float:
    """Median over rounds of the time per candidate (µs) evaluating ``X`` in batches."""
    times = []
    for _ in range(rounds):
        began = time.perf_counter()
        for i in range(0, X.shape[0], batch):
            problem.evaluate(X[i:i + batch])
        times.append((time.perf_counter() - began) / X.shape[0] * 1e6)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--batch", type=int, default=32)
    args = ap.parse_args()
    registry = Registry()
    print(f"{'problem':<28} {'1 at a time (µs)':>17} {f'{args.batch} at once (µs)':>17} "
          f"{'ratio':>6}")
    for cfg in PROBLEMS:
        problem = build_problem(registry, cfg)
        b = problem.bounds
        X = b.lower + (b.upper - b.lower) * np.random.default_rng(0).random((args.batch, b.dim))
        problem.evaluate(X[:2])  # compile or load the kernels first
        one = per_candidate_us(problem, X, 1, args.rounds)
        many = per_candidate_us(problem, X, args.batch, args.rounds)
        label = " ".join(f"{k}={v}" if k != "name" else v for k, v in cfg.items())
        print(f"{label:<28} {one:>17.0f} {many:>17.0f} {one / many:>6.2f}")


if __name__ == "__main__":
    main()
