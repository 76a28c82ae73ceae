"""How many evaluations lsq needs to reach each record's optimum, and what the bridge costs.

Part ``lsq`` (issue 11's target: >= 27 of 30 runs within 300 evaluations on the paper's
window, >= 28 of 30 within 150 with ``problem.record.extra=0.5``): evaluations to each
record's optimum, how it is found: docs/peers.md, evaluations to each record's optimum.
Part ``bridge``: wall time per batch of a loop-owning optimizer (``LoopOptimizer``'s worker
thread) beside ask/tell ones on the 9-D sphere: ``scipy_de`` vs ``de1``, and a do-nothing
library loop vs random search (the hand-over alone).

    .venv/bin/python benchmarks/bench_lsq.py [--part lsq|bridge|all] [--runs 30] [--budget 600]
    .venv/bin/python benchmarks/bench_lsq.py --part lsq --variant broyden=false,inner=3
"""

from __future__ import annotations

import argparse
import time
import timeit

import numpy as np
from _shared import parse_keys
from scipy.optimize import least_squares
from vpid_peers.coordinates import Coordinates
from vpid_peers.solver import Solver, SolverSettings

from vpid_bench.api import LoopOptimizer, OptimizerParams
from vpid_bench.build import build_problem, optimizer_params, run_rng
from vpid_bench.plugins import Registry
from vpid_bench.runner import run

GAP = 1e-6
WINDOWS = (("paper window", 0.0, 300, 27), ("record.extra=0.5", 0.5, 150, 28))


def polish_own(problem) -> float:
    """f at the end of a descent from the truth with a fresh Jacobian at every step."""
    coords = Coordinates(problem.bounds, "log")
    solver = Solver(problem.evaluate_with_residuals, coords, problem.residual_groups(),
                    SolverSettings(broyden=False, ftol=1e-15, inner=5))
    d = solver.descend(coords.to_u(problem.x_true))
    return float(problem.evaluate(coords.to_x(d.u)[None])[0])


def polish_scipy(problem, rounds: int = 20) -> float:
    """IRLS between full solves: scipy's least_squares on the group-weighted residuals,
    weights 1/sqrt(||r_g||) refreshed after each solve, from the truth (log coordinates)."""
    groups = problem.residual_groups()
    x = problem.x_true.copy()
    lo, hi = np.log(problem.bounds.lower), np.log(problem.bounds.upper)
    for _ in range(rounds):
        r = problem.residuals(x[None])[0]
        norms = np.array([np.linalg.norm(r[groups == g]) for g in range(groups.max() + 1)])
        w = 1.0 / np.sqrt(norms[groups])
        res = least_squares(lambda z, w=w: w * problem.residuals(np.exp(z)[None])[0], np.log(x),
                            bounds=(lo, hi), method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15)
        x = np.clip(np.exp(res.x), problem.bounds.lower, problem.bounds.upper)
    return float(problem.evaluate(x[None])[0])


def evaluations_to_optimum(trace_n, trace_best, f_opt: float) -> float:
    """The first evaluation count at which the best-so-far is within GAP of f_opt."""
    for n, best in zip(trace_n, trace_best):
        if (best - f_opt) / f_opt <= GAP:
            return float(n)
    return float("inf")


def part_lsq(registry: Registry, runs: int, budget: int, variant: dict) -> None:
    print(f"lsq keys: {variant or 'defaults'}; {runs} runs, budget {budget}, gap {GAP:g}")
    for label, extra, limit, target in WINDOWS:
        counts, polish_diff = [], []
        t0 = time.perf_counter()
        for i in range(runs):
            problem = build_problem(registry, {"name": "vehicle", "noise": {"seed": i},
                                               "record": {"extra": extra}})
            cls, params = optimizer_params(registry, {"name": "lsq", **variant})
            result = run(problem, cls(params, problem.bounds, run_rng(0, i)), budget)
            own, other = polish_own(problem), polish_scipy(problem)
            polish_diff.append(abs(own - other) / other)
            f_opt = min(own, other, result.f_best)
            counts.append(evaluations_to_optimum(result.trace_evaluations,
                                                 result.trace_best, f_opt))
        c = np.array(counts)
        within = int(np.sum(c <= limit))
        print(f"  {label}: {within}/{runs} within {limit} (target >= {target}); "
              f"median {np.median(c):g}, 90th percentile {np.percentile(c, 90):g}, "
              f"max {c.max():g}; never reached within {budget}: {int(np.sum(np.isinf(c)))}; "
              f"polishes differ by <= {max(polish_diff):.1e} (relative); "
              f"{time.perf_counter() - t0:.0f} s")
        print(f"    counts: {sorted(int(x) if np.isfinite(x) else -1 for x in c)}")


class IdleLoop(LoopOptimizer):
    """A library loop that does nothing but ask batches of ps uniform rows."""

    def minimize(self, evaluate):
        while True:
            evaluate(self.bounds.sample(self.rng, self.params.ps))


def part_bridge(registry: Registry, repeats: int, iterations: int) -> None:
    ps = 20
    problem = build_problem(registry, {"name": "functions", "function": "sphere", "dim": 9,
                                       "ps": ps, "iterations": iterations})
    budget = ps * (iterations + 1)

    def runner(name: str | None):
        cls, params = (IdleLoop, OptimizerParams(ps=ps, iterations=iterations)) if name is None \
            else optimizer_params(registry, {"name": name, "ps": ps, "iterations": iterations})
        return lambda: run(problem, cls(params, problem.bounds, np.random.default_rng(0)), budget)

    runner("de1")()  # compile / warm up
    cases = {"scipy_de": runner("scipy_de"), "de1": runner("de1"),
             "idle loop (bridge)": runner(None), "random (ask/tell)": runner("random")}
    per_batch = {k: 1e6 * min(timeit.repeat(fn, repeat=repeats, number=1)) / (iterations + 1)
                 for k, fn in cases.items()}
    print(f"bridge: sphere 9-D, batches of {ps}, {iterations + 1} batches per run, best of "
          f"{repeats}; wall time per batch (us), objective and run loop included")
    for k, v in per_batch.items():
        print(f"  {k:20s} {v:8.1f}")
    print(f"  ratio scipy_de / de1: {per_batch['scipy_de'] / per_batch['de1']:.2f}; "
          f"hand-over cost per batch (idle loop - random): "
          f"{per_batch['idle loop (bridge)'] - per_batch['random (ask/tell)']:.1f} us")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("lsq", "bridge", "all"), default="all")
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--budget", type=int, default=600)
    parser.add_argument("--variant", default="", help="lsq keys, e.g. broyden=false,inner=3")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--iterations", type=int, default=200)
    args = parser.parse_args(argv)
    registry = Registry()
    if args.part in ("bridge", "all"):
        part_bridge(registry, args.repeats, args.iterations)
    if args.part in ("lsq", "all"):
        part_lsq(registry, args.runs, args.budget, parse_keys(args.variant))


if __name__ == "__main__":
    main()
