"""JADE, SHADE and L-SHADE beside DE4: final objective at the protocol's budget and at 10x it,
and the cost of one generation against the vehicle objective.

Part 1 (quality, deterministic: seeds 0..runs-1): median and max of the best objective value
over ``--runs`` runs at ``ps = 20`` with ``ps * 51`` (1x) and ``ps * 510`` (10x) evaluations,
on the 10-D sphere and on the vehicle (the default problem). L-SHADE runs twice: its initial
population from the protocol (``N_init=ps``, the default here) and from the paper
(``N_init=paper``, 18 D). This is the measurement behind the ``N_init`` default.

Part 2 (speed, as ratios in one process): one generation (ask + tell, objective values
computed beforehand) against one vehicle evaluation of a population of 20, interleaved, best
of several repeats (the method of ``bench_optimizers.py``).

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_adaptive_de.py [--runs 10] [--repeats 7]
"""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import numpy as np

from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.plugins import Registry
from vpid_bench.runner import run

PS = 20
CONTENDERS = (("de4", {}), ("jade", {}), ("shade", {}), ("lshade", {"N_init": "ps"}),
              ("lshade", {"N_init": "paper"}))


def finals(registry, problem_cfg: dict, name: str, extra: dict, iterations: int, runs: int):
    problem = build_problem(registry, {**problem_cfg, "ps": PS, "iterations": iterations})
    cls, params = optimizer_params(registry, {"name": name, "ps": PS, "iterations": iterations,
                                              **extra})
    budget = PS * (iterations + 1)
    return np.array([run(problem, cls(params, problem.bounds, np.random.default_rng(s)),
                         budget).f_best for s in range(runs)])


def quality(registry, runs: int) -> None:
    problems = {"sphere-10D": {"name": "functions", "function": "sphere", "dim": 10}}
    if "vehicle" in registry.problems:
        problems["vehicle"] = {"name": "vehicle"}
    for label, cfg in problems.items():
        for iterations in (50, 509):
            print(f"\n{label}, ps={PS}, budget {PS * (iterations + 1)} evaluations, "
                  f"{runs} runs: best objective")
            print(f"{'optimizer':<22} {'median':>10} {'max':>10}")
            for name, extra in CONTENDERS:
                f = finals(registry, cfg, name, extra, iterations, runs)
                tag = name + "".join(f" {k}={v}" for k, v in extra.items())
                print(f"{tag:<22} {np.median(f):>10.4g} {f.max():>10.4g}")


def speed(registry, repeats: int, number: int) -> None:
    spec = importlib.util.spec_from_file_location(
        "bench_optimizers", Path(__file__).with_name("bench_optimizers.py"))
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    problem, pname = bench.make_problem(registry, PS)
    X = problem.bounds.sample(np.random.default_rng(1), PS)
    problem.evaluate(X)
    names = ("de4", "jade", "shade", "lshade")
    steps = {n: bench.generation_step(registry, n, problem, PS) for n in names}
    for step in steps.values():
        step()
    t_obj, t_gen = [], {n: [] for n in names}
    for _ in range(repeats):
        t_obj.append(bench.best_per_call(lambda: problem.evaluate(X), 1, number))
        for n in names:
            t_gen[n].append(bench.best_per_call(steps[n], 1, number))
    obj = min(t_obj)
    print(f"\nobjective: problem={pname}, one population of PS={PS}: {obj * 1e6:.1f} us")
    print(f"{'optimizer':<10} {'generation (us)':>16} {'ratio to objective':>20}")
    for n in names:
        g = min(t_gen[n])
        print(f"{n:<10} {g * 1e6:>16.1f} {g / obj:>19.1%}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--number", type=int, default=50)
    args = parser.parse_args(argv)
    registry = Registry()
    quality(registry, args.runs)
    speed(registry, args.repeats, args.number)


if __name__ == "__main__":
    main()
