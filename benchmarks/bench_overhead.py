"""Per-evaluation overhead of every registered optimizer, against the kernel time of the same
evaluations, measured side by side in one run (issue: studies at kernel speed).

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_overhead.py [--budget 4200] [--repeat 5] \\
        [--skip nevergrad] [--only random lsq] [--problem smoke_quarter]

Per optimizer, one run on ``--problem`` (PS 20) through the run loop against its own batches
evaluated again alone, the rest split into its ``ask`` and ``tell`` and the run loop's share;
the medians over ``--repeat`` runs (the method and the measurements: docs/sweeps.md, each
optimizer's overhead per evaluation).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from vpid_bench import ConfigError
from vpid_bench.build import build_problem, optimizer_params, run_rng
from vpid_bench.plugins import Registry
from vpid_bench.runner import run


class Recorder:
    """Records the batches the run loop hands the problem (as values or with residuals)."""

    def __init__(self, problem) -> None:
        self.problem, self.batches = problem, []
        for name in ("evaluate", "evaluate_instances", "evaluate_with_residuals"):
            setattr(problem, name, self._wrap(name, getattr(problem, name)))
        self._depth = 0

    def _wrap(self, name, fn):
        def wrapped(X, *args):
            if self._depth == 0:
                self.batches.append((name, np.array(X, copy=True), args))
            self._depth += 1
            try:
                return fn(X, *args)
            finally:
                self._depth -= 1
        return wrapped


def measure(registry: Registry, name: str, budget: int, problem_name: str = "vehicle"
            ) -> dict[str, float]:
    """One run's wall time against the kernel time of its batches (after a short warm-up
    run of the same optimizer, so compilation and first-call set-up are not counted)."""
    spec = {"name": problem_name, "ps": 20}
    warm = build_problem(registry, spec)
    cls, params = optimizer_params(registry, {"name": name, "ps": 20, "budget": 200})
    run(warm, cls(params, warm.bounds, run_rng(1, 0)), 200)
    problem = build_problem(registry, spec)
    clean = build_problem(registry, spec)
    rec = Recorder(problem)
    cls, params = optimizer_params(registry, {"name": name, "ps": 20, "budget": budget})
    optimizer = cls(params, problem.bounds, run_rng(0, 0))
    own = _time_ask_tell(optimizer)
    t0 = time.perf_counter()
    result = run(problem, optimizer, budget)
    wall = time.perf_counter() - t0
    evaluations = result.evaluations
    t0 = time.perf_counter()
    for method, X, args in rec.batches:
        getattr(clean, method)(X, *args)
    kernel = time.perf_counter() - t0
    loop = wall - own[0] - kernel
    return {"wall_us": 1e6 * wall / evaluations, "kernel_us": 1e6 * kernel / evaluations,
            "own_us": 1e6 * own[0] / evaluations, "loop_us": 1e6 * loop / evaluations,
            "ratio": wall / kernel if kernel > 0 else float("inf"),
            "batches": len(rec.batches), "evaluations": evaluations}


def _time_ask_tell(optimizer) -> list[float]:
    """Time the optimizer's own ``ask`` and ``tell`` from now on; returns a one-element list
    that accumulates their seconds (an evaluation inside ``tell``, as a least-squares method
    makes, counts as the optimizer's own)."""
    spent = [0.0]
    for name in ("ask", "tell"):
        method = getattr(optimizer, name)

        def timed(*args, _method=method, **kwargs):
            t0 = time.perf_counter()
            try:
                return _method(*args, **kwargs)
            finally:
                spent[0] += time.perf_counter() - t0

        setattr(optimizer, name, timed)
    return spent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--budget", type=int, default=4200)
    ap.add_argument("--skip", nargs="*", default=[])
    ap.add_argument("--only", nargs="*", default=None, help="these optimizers only")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--problem", default="vehicle",
                    help="a problem at its defaults, e.g. a suite member (smoke_quarter)")
    args = ap.parse_args()
    registry = Registry()
    try:  # a mistyped problem: one line before any measurement, not a failed row each
        build_problem(registry, {"name": args.problem, "ps": 20})
    except ConfigError as exc:
        ap.exit(2, f"error: {exc}\n")
    unknown = sorted(set(args.only or ()) - set(registry.optimizers))
    if unknown:
        ap.exit(2, f"error: --only {', '.join(unknown)}: not an optimizer; one of "
                   f"{', '.join(sorted(registry.optimizers))}\n")
    print(f"command: benchmarks/bench_overhead.py --budget {args.budget} --repeat {args.repeat} "
          f"--problem {args.problem} (medians)")
    print("| optimizer | µs per evaluation | kernel µs per evaluation | overhead (×) | "
          "ask + tell µs per evaluation | run loop µs per evaluation | batches | evaluations |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in sorted(registry.optimizers):
        if name in args.skip or (args.only is not None and name not in args.only):
            continue
        try:
            runs = [measure(registry, name, args.budget, args.problem) for _ in range(args.repeat)]
            m = {key: statistics.median(r[key] for r in runs) for key in runs[0]}
        except Exception as exc:  # noqa: BLE001 - a benchmark line per optimizer
            print(f"| {name} | failed: {type(exc).__name__}: {exc} | | | | | | |")
            continue
        print(f"| {name} | {m['wall_us']:.1f} | {m['kernel_us']:.1f} | {m['ratio']:.1f} | "
              f"{m['own_us']:.1f} | {m['loop_us']:.1f} | {m['batches']} | {m['evaluations']} |",
              flush=True)


if __name__ == "__main__":
    main()
