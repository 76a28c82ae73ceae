"""CMA-ES's own cost per evaluation in two well-kept libraries, side by side in one run: ``cma``
(Hansen's, what ``optimizer=cmaes`` runs) and ``cmaes`` (CyberAgent's, installed with
nevergrad's dependencies where present), each driving the same number of generations on a
cheap function in the unit cube, as ``optimizer=cmaes`` drives cma (its options: bounds by
``BoundTransform``, the run's generator for the deviates, quiet).

    .venv/bin/python benchmarks/bench_cma_libraries.py [--dim 9] [--generations 300] [--repeat 5]

Prints, per library, the median over ``--repeat`` timings of its ask and tell per evaluation
(µs) and their ratio. The function costs a few µs per row, so the time is the library's.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np


def sphere(X: np.ndarray) -> np.ndarray:
    return np.sum((np.asarray(X) - 0.3) ** 2, axis=1)


def with_cma(dim: int, lam: int, generations: int, seed: int) -> float:
    import cma

    rng = np.random.default_rng(seed)
    es = cma.CMAEvolutionStrategy(rng.random(dim), 0.3, {
        "popsize": lam, "bounds": [0.0, 1.0], "BoundaryHandler": "BoundTransform",
        "randn": lambda *shape: rng.standard_normal(shape), "seed": float("nan"),
        "verbose": -9, "verb_log": 0, "verb_disp": 0})
    t0 = time.perf_counter()
    for _ in range(generations):
        X = es.ask()
        es.tell(X, sphere(X).tolist())
        es.stop()
    return (time.perf_counter() - t0) / (generations * lam) * 1e6


def with_cmaes(dim: int, lam: int, generations: int, seed: int) -> float:
    import cmaes

    rng = np.random.default_rng(seed)
    opt = cmaes.CMA(mean=rng.random(dim), sigma=0.3, bounds=np.array([[0.0, 1.0]] * dim),
                    seed=int(rng.integers(2**31)), population_size=lam)
    t0 = time.perf_counter()
    for _ in range(generations):
        X = np.array([opt.ask() for _ in range(lam)])
        opt.tell(list(zip(X, sphere(X), strict=True)))
        opt.should_stop()
    return (time.perf_counter() - t0) / (generations * lam) * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dim", type=int, default=9)
    ap.add_argument("--generations", type=int, default=300)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    lam = 4 + int(3 * math.log(args.dim))  # cma's default population, as optimizer=cmaes
    times: dict[str, list[float]] = {"cma": [], "cmaes": []}
    for i in range(args.repeat):  # interleaved, so a change of machine load hits both
        times["cma"].append(with_cma(args.dim, lam, args.generations, i))
        times["cmaes"].append(with_cmaes(args.dim, lam, args.generations, i))
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"dim {args.dim}, population {lam}, {args.generations} generations, "
          f"median of {args.repeat}:")
    for k, v in med.items():
        print(f"  {k:6s} {v:8.1f} us per evaluation (ask + tell)")
    print(f"  cma / cmaes: {med['cma'] / med['cmaes']:.2f}x")


if __name__ == "__main__":
    main()
