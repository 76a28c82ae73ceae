"""Cost of one GA generation with each ``optimizer.mutation``, against the vehicle objective.

One generation is ``ask()`` + ``tell()`` with objective values computed beforehand (the
objective is not timed), as in ``bench_optimizers.py``. The reference is one call of
``problem.evaluate`` on a population of PS rows of ``problem=vehicle``. All three are timed in
one process, interleaved, best of several repeats; the script prints RATIOS, which hold on a
busy machine where absolute times do not.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_ga_mutation.py [--ps 20] [--repeats 7]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.plugins import Registry

MUTATIONS = ("adaptfeasible", "scaled_halving")


def generation_step(registry: Registry, mutation: str, problem, ps: int):
    """A zero-argument callable doing one GA generation without the objective."""
    cls, params = optimizer_params(registry, {"name": "ga", "ps": ps, "iterations": 10**9,
                                              "mutation": mutation})
    opt = cls(params, problem.bounds, np.random.default_rng(0))
    X = opt.ask()
    opt.tell(X, problem.evaluate(X))
    X = opt.ask()
    f = problem.evaluate(X)  # reused every call: the objective is not timed
    opt.tell(X, f)

    def step() -> None:
        opt.tell(opt.ask(), f)

    return step


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ps", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--number", type=int, default=100)
    args = parser.parse_args(argv)
    registry = Registry()
    problem = build_problem(registry, {"name": "vehicle", "ps": args.ps})
    X = problem.bounds.sample(np.random.default_rng(1), args.ps)
    calls = {"objective": lambda: problem.evaluate(X)}
    calls.update({m: generation_step(registry, m, problem, args.ps) for m in MUTATIONS})
    best = dict.fromkeys(calls, np.inf)
    for _ in range(args.repeats):  # interleaved, so load changes hit all of them alike
        for name, fn in calls.items():
            t = min(timeit.repeat(fn, repeat=1, number=args.number)) / args.number
            best[name] = min(best[name], t)
    print(f"objective: problem=vehicle, one population of PS={args.ps}: "
          f"{best['objective'] * 1e6:.1f} us")
    print("ga mutation      generation (us)   ratio to objective")
    for m in MUTATIONS:
        print(f"{m:<16} {best[m] * 1e6:15.1f} {best[m] / best['objective']:19.1%}")
    print(f"adaptfeasible / scaled_halving: {best['adaptfeasible'] / best['scaled_halving']:.2f}")


if __name__ == "__main__":
    main()
