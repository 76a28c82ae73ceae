"""Cost of one optimizer generation, excluding the objective, against the vehicle objective;
with ``--quality``, the best objective each reaches at the protocol's budget and at 10x it.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_optimizers.py [--optimizers de1 ... random]
        [--ps 20] [--repeats 7] [--number 50] [--quality [--runs 10]]

An optimizer is ``NAME[:key=value,...]`` (``ga:mutation=scaled_halving``). One generation is
``ask()`` + ``tell()`` with objective values computed beforehand; the reference is one
``problem.evaluate`` of a population of PS on ``problem=vehicle`` (``problem=functions``, with
a notice, without the vehicle). Timed in one process, interleaved, best of ``--repeats``
timings of ``--number`` calls: RATIOS, which hold on a busy machine. Target: a DE generation
under 10% of the vehicle objective at PS = 20. ``--quality`` (deterministic, seeds 0 ..
runs-1): median and max of the best objective over ``--runs`` runs with ``ps * 51`` and
``ps * 510`` evaluations, on the 10-D sphere and on the vehicle.
"""

from __future__ import annotations

import argparse

import numpy as np
from _shared import interleaved, parse_keys

from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.plugins import Registry
from vpid_bench.runner import run

OPTIMIZERS = ("de1", "de2", "de3", "de4", "de5", "de6", "de7", "de8", "ga", "random")


def settings(spec: str) -> dict:
    """``NAME[:key=value,...]`` as the optimizer's config."""
    name, _, keys = spec.partition(":")
    return {"name": name, **parse_keys(keys)}


def generation_step(registry: Registry, spec: str, problem, ps: int):
    """A zero-argument callable doing one generation of ``spec`` without the objective."""
    cls, params = optimizer_params(registry, {**settings(spec), "ps": ps, "iterations": 10**9})
    opt = cls(params, problem.bounds, np.random.default_rng(0))
    X0 = opt.ask()
    opt.tell(X0, problem.evaluate(X0))
    X1 = opt.ask()
    f1 = problem.evaluate(X1)  # values reused every call: the objective is not timed
    opt.tell(X1, f1)
    f_gen = np.resize(f1, len(X1))

    def step() -> None:
        X = opt.ask()
        opt.tell(X, f_gen[: len(X)])

    return step


def speed(registry: Registry, specs: list[str], ps: int, repeats: int, number: int) -> None:
    if "vehicle" in registry.problems:
        problem, pname = build_problem(registry, {"name": "vehicle", "ps": ps}), "vehicle"
    else:
        print("NOTICE: problem=vehicle is not registered; measuring against problem=functions")
        problem = build_problem(registry, {"name": "functions", "dim": 9, "ps": ps})
        pname = "functions"
    X = problem.bounds.sample(np.random.default_rng(1), ps)
    calls = {" objective": lambda: problem.evaluate(X)}
    calls.update({s: generation_step(registry, s, problem, ps) for s in specs})
    best = interleaved(calls, repeats, number, pick=min)
    obj = best.pop(" objective")
    width = max(10, *map(len, specs))
    print(f"objective: problem={pname}, one population of PS={ps}: {obj * 1e6:.1f} us")
    print(f"{'optimizer':<{width}} {'generation (us)':>16} {'ratio to objective':>20}")
    for spec, g in best.items():
        print(f"{spec:<{width}} {g * 1e6:>16.1f} {g / obj:>19.1%}")


def quality(registry: Registry, specs: list[str], ps: int, runs: int) -> None:
    problems = {"sphere-10D": {"name": "functions", "function": "sphere", "dim": 10}}
    if "vehicle" in registry.problems:
        problems["vehicle"] = {"name": "vehicle"}
    width = max(22, *map(len, specs))
    for label, cfg in problems.items():
        for iterations in (50, 509):
            problem = build_problem(registry, {**cfg, "ps": ps, "iterations": iterations})
            print(f"\n{label}, ps={ps}, budget {ps * (iterations + 1)} evaluations, "
                  f"{runs} runs: best objective")
            print(f"{'optimizer':<{width}} {'median':>10} {'max':>10}")
            for spec in specs:
                cls, params = optimizer_params(registry, {**settings(spec), "ps": ps,
                                                          "iterations": iterations})
                f = np.array([run(problem, cls(params, problem.bounds,
                                               np.random.default_rng(s)),
                                  ps * (iterations + 1)).f_best for s in range(runs)])
                print(f"{spec:<{width}} {np.median(f):>10.4g} {f.max():>10.4g}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--optimizers", nargs="+", default=None,
                        help="NAME[:key=value,...] each (default: DE1-DE8, GA, random)")
    parser.add_argument("--ps", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--number", type=int, default=50)
    parser.add_argument("--quality", action="store_true")
    parser.add_argument("--runs", type=int, default=10)
    args = parser.parse_args(argv)
    registry = Registry()
    specs = args.optimizers or [n for n in OPTIMIZERS if n in registry.optimizers]
    unknown = [s for s in specs if settings(s)["name"] not in registry.optimizers]
    if unknown:
        parser.exit(2, f"error: --optimizers {unknown[0]}: not an optimizer; one of "
                       f"{', '.join(sorted(registry.optimizers))}\n")
    if args.quality:
        quality(registry, specs, args.ps, args.runs)
        print()
    speed(registry, specs, args.ps, args.repeats, args.number)


if __name__ == "__main__":
    main()
