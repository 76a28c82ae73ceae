"""Cost of one optimizer generation, excluding the objective, against the vehicle objective.

For each optimizer, one generation is ``ask()`` (mutation, crossover, bounds rule, index
drawing; or the GA's scaling, selection, crossover, mutation) plus ``tell()`` (selection and
bookkeeping) with objective values computed beforehand, so no objective time is included. The
reference is ``problem.evaluate`` of one population of PS = 20 on ``problem=vehicle`` (falls
back to ``problem=functions`` with a notice if the vehicle problem is not registered). Both
are timed in the same process, interleaved, best of several repeats, and the script prints
RATIOS, so the result holds on a busy machine. Target: a DE generation under 10% of the
vehicle objective at PS = 20.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_optimizers.py [--ps 20] [--repeats 7]
"""

from __future__ import annotations

import argparse
import timeit

import numpy as np

from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.plugins import Registry

OPTIMIZERS = ("de1", "de2", "de3", "de4", "de5", "de6", "de7", "de8", "ga", "random")


def best_per_call(fn, repeats: int, number: int) -> float:
    """Best wall time per call (s) over ``repeats`` timings of ``number`` calls (stdlib timeit)."""
    return min(timeit.repeat(fn, repeat=repeats, number=number)) / number


def make_problem(registry: Registry, ps: int):
    if "vehicle" in registry.problems:
        return build_problem(registry, {"name": "vehicle", "ps": ps}), "vehicle"
    print("NOTICE: problem=vehicle is not registered; measuring against problem=functions")
    return build_problem(registry, {"name": "functions", "dim": 9, "ps": ps}), "functions"


def generation_step(registry: Registry, name: str, problem, ps: int, seed: int = 0):
    """A zero-argument callable doing one generation of ``name`` without the objective."""
    cls, params = optimizer_params(registry, {"name": name, "ps": ps, "iterations": 10**9})
    opt = cls(params, problem.bounds, np.random.default_rng(seed))
    X0 = opt.ask()
    f0 = problem.evaluate(X0)
    opt.tell(X0, f0)
    X1 = opt.ask()
    f1 = problem.evaluate(X1)  # values reused every call: the objective is not timed
    opt.tell(X1, f1)
    f_gen = np.resize(f1, len(X1))

    def step() -> None:
        X = opt.ask()
        opt.tell(X, f_gen[: len(X)])

    return step


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ps", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--number", type=int, default=50)
    args = parser.parse_args(argv)

    registry = Registry()
    problem, pname = make_problem(registry, args.ps)
    X = problem.bounds.sample(np.random.default_rng(1), args.ps)
    problem.evaluate(X)  # warm-up (compiles the vehicle kernel)
    names = [n for n in OPTIMIZERS if n in registry.optimizers]
    steps = {n: generation_step(registry, n, problem, args.ps) for n in names}
    for step in steps.values():
        step()  # warm-up
    t_obj, t_gen = [], {n: [] for n in names}
    for _ in range(args.repeats):  # interleave: objective, then each optimizer, repeatedly
        t_obj.append(best_per_call(lambda: problem.evaluate(X), 1, args.number))
        for n in names:
            t_gen[n].append(best_per_call(steps[n], 1, args.number))
    obj = min(t_obj)
    print(f"objective: problem={pname}, one population of PS={args.ps}: {obj * 1e6:.1f} us")
    print(f"{'optimizer':<10} {'generation (us)':>16} {'ratio to objective':>20}")
    for n in names:
        g = min(t_gen[n])
        print(f"{n:<10} {g * 1e6:>16.1f} {g / obj:>19.1%}")


if __name__ == "__main__":
    main()
