"""What ``optimizer=nevergrad`` costs of its own per candidate: nevergrad's optimizers asked and
told one candidate at a time (the plugin's default, ``batch=library``) on a cheap sphere in the
unit cube, as its users run them, beside the ``cma`` library's own CMA-ES (``optimizer=cmaes``)
asked a generation at a time.

    .venv/bin/python benchmarks/bench_nevergrad_cma.py [--dim 4 9] [--evaluations 3000] \
        [--repeat 3] [--methods CMA TwoPointsDE]

Prints, per dimension, the median over ``--repeat`` timings of ask and tell per candidate
(µs of CPU time, :func:`time.process_time`: robust on a loaded machine), the sphere's own
time included (about 1 µs).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np


def nevergrad_us(method: str, dim: int, evaluations: int, seed: int) -> float:
    """µs per candidate of nevergrad's ``method`` on a sphere in [0, 1]^dim."""
    import nevergrad as ng

    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(seed)
    optimizer = ng.optimizers.registry[method](parametrization=parametrization,
                                               budget=evaluations, num_workers=1)
    t0 = time.process_time()
    for _ in range(evaluations):
        candidate = optimizer.ask()
        optimizer.tell(candidate, float(np.sum((candidate.value - 0.5) ** 2)))
    return (time.process_time() - t0) / evaluations * 1e6


def cma_us(dim: int, evaluations: int, seed: int) -> float:
    """µs per candidate of the cma library's CMA-ES (its own population, bounds [0, 1])."""
    import cma

    es = cma.CMAEvolutionStrategy(np.full(dim, 0.3), 0.3, {
        "bounds": [0.0, 1.0], "seed": seed + 1, "verbose": -9, "maxfevals": evaluations})
    done = 0
    t0 = time.process_time()
    while done < evaluations:
        X = es.ask()
        es.tell(X, [float(np.sum((np.asarray(x) - 0.5) ** 2)) for x in X])
        done += len(X)
    return (time.process_time() - t0) / done * 1e6


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dim", type=int, nargs="+", default=[4, 9])
    ap.add_argument("--evaluations", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--methods", nargs="+", default=["CMA"])
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")  # cma's and nevergrad's advice, once per candidate
    nevergrad_us("CMA", 2, 50, 0)  # imports
    cma_us(2, 50, 0)
    heads = [f"nevergrad {m} (µs/candidate)" for m in args.methods] + ["cma's CMA-ES"]
    print("| dim | " + " | ".join(heads) + " |")
    print("| --- " * (len(heads) + 1) + "|")
    for dim in args.dim:
        cells = [statistics.median(nevergrad_us(m, dim, args.evaluations, r)
                                   for r in range(args.repeat)) for m in args.methods]
        cells.append(statistics.median(cma_us(dim, args.evaluations, r)
                                       for r in range(args.repeat)))
        print(f"| {dim} | " + " | ".join(f"{c:.0f}" for c in cells) + " |")


if __name__ == "__main__":
    main()
