"""What CMA-ES libraries cost of their own per candidate, side by side in one run, on a cheap
sphere in the unit cube: ``cma`` (Hansen's) asked a generation at a time as
``optimizer=cmaes`` drives it (bounds by ``BoundTransform``, the run's generator for the
deviates), ``cmaes`` (CyberAgent's, installed with nevergrad's dependencies) likewise, and
nevergrad's optimizers asked and told one candidate at a time, as ``optimizer=nevergrad``
runs them by default (``batch=library``).

    .venv/bin/python benchmarks/bench_cma_libraries.py [--dim 4 9] [--evaluations 3000] \\
        [--repeat 3] [--libraries cma cmaes nevergrad:CMA nevergrad:TwoPointsDE]

Prints, per dimension, the median over ``--repeat`` interleaved timings of ask and tell per
candidate (µs of CPU time, :func:`time.process_time`, which a loaded machine inflates less;
the sphere's own time, about 1 µs, included) and its ratio to the first library's.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
import warnings

import numpy as np


def sphere(X: np.ndarray) -> np.ndarray:
    return np.sum((np.asarray(X) - 0.5) ** 2, axis=-1)


def with_cma(dim: int, evaluations: int, seed: int) -> float:
    import cma

    rng = np.random.default_rng(seed)
    es = cma.CMAEvolutionStrategy(np.full(dim, 0.3), 0.3, {
        "popsize": 4 + int(3 * math.log(dim)), "bounds": [0.0, 1.0],
        "BoundaryHandler": "BoundTransform", "randn": lambda *shape: rng.standard_normal(shape),
        "seed": float("nan"), "verbose": -9, "verb_log": 0, "verb_disp": 0})
    done, t0 = 0, time.process_time()
    while done < evaluations:
        X = es.ask()
        es.tell(X, sphere(X).tolist())
        es.stop()
        done += len(X)
    return (time.process_time() - t0) / done * 1e6


def with_cmaes(dim: int, evaluations: int, seed: int) -> float:
    import cmaes

    opt = cmaes.CMA(mean=np.full(dim, 0.3), sigma=0.3, bounds=np.array([[0.0, 1.0]] * dim),
                    seed=seed + 1, population_size=4 + int(3 * math.log(dim)))
    done, t0 = 0, time.process_time()
    while done < evaluations:
        X = np.array([opt.ask() for _ in range(opt.population_size)])
        opt.tell(list(zip(X, sphere(X), strict=True)))
        opt.should_stop()
        done += len(X)
    return (time.process_time() - t0) / done * 1e6


def with_nevergrad(method: str, dim: int, evaluations: int, seed: int) -> float:
    import nevergrad as ng

    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(seed)
    optimizer = ng.optimizers.registry[method](parametrization=parametrization,
                                               budget=evaluations, num_workers=1)
    t0 = time.process_time()
    for _ in range(evaluations):
        candidate = optimizer.ask()
        optimizer.tell(candidate, float(sphere(candidate.value)))
    return (time.process_time() - t0) / evaluations * 1e6


def library(spec: str):
    """``cma``, ``cmaes`` or ``nevergrad:<method>`` as ``f(dim, evaluations, seed)``."""
    if spec.startswith("nevergrad:"):
        return lambda *a: with_nevergrad(spec.split(":", 1)[1], *a)
    return {"cma": with_cma, "cmaes": with_cmaes}[spec]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dim", type=int, nargs="+", default=[4, 9])
    ap.add_argument("--evaluations", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--libraries", nargs="+", default=["cma", "cmaes", "nevergrad:CMA"])
    args = ap.parse_args(argv)
    bad = [s for s in args.libraries if s not in ("cma", "cmaes")
           and not s.startswith("nevergrad:")]
    if bad:
        ap.exit(2, f"error: --libraries {bad[0]}: one of cma, cmaes, nevergrad:<method>\n")
    warnings.simplefilter("ignore")  # cma's and nevergrad's advice, once per candidate
    runs = {s: library(s) for s in args.libraries}
    for fn in runs.values():
        fn(2, 50, 0)  # imports
    print("| dim | " + " | ".join(f"{s} (µs/candidate)" for s in runs) + " |")
    print("| --- " * (len(runs) + 1) + "|")
    for dim in args.dim:
        times: dict[str, list[float]] = {s: [] for s in runs}
        for r in range(args.repeat):  # interleaved, so a change of load meets all alike
            for s, fn in runs.items():
                times[s].append(fn(dim, args.evaluations, r))
        med = [statistics.median(t) for t in times.values()]
        print(f"| {dim} | " + " | ".join(f"{m:.0f} ({m / med[0]:.2f}x)" for m in med) + " |")


if __name__ == "__main__":
    main()
