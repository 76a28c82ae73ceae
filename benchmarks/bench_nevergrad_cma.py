"""nevergrad's CMA per candidate with and without reusing its running strategy
(:mod:`vpid_peers.nevergrad_cma`), side by side in one run: what ``optimizer=nevergrad``
(default ``CMA``, one candidate per ask) costs of its own on a cheap function in the unit
cube, as the plugin drives it.

    .venv/bin/python benchmarks/bench_nevergrad_cma.py [--dim 4 9] [--evaluations 3000] [--repeat 3]

Prints, per dimension, the median over ``--repeat`` timings of ask and tell per candidate
(µs) for nevergrad as it is and with the reuse, their ratio, and whether the candidates were
identical (they must be: the reuse changes no search).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np


def timed(dim: int, evaluations: int, reuse: bool, seed: int) -> tuple[float, np.ndarray]:
    """µs per candidate of nevergrad's CMA on a sphere in [0, 1]^dim, and its candidates."""
    import nevergrad as ng
    from vpid_peers.nevergrad_cma import skip_repeated_bounds_check

    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(seed)
    optimizer = ng.optimizers.registry["CMA"](parametrization=parametrization,
                                              budget=evaluations, num_workers=1)
    if reuse:
        skip_repeated_bounds_check(optimizer)
    asked = np.empty((evaluations, dim))
    t0 = time.perf_counter()
    for i in range(evaluations):
        candidate = optimizer.ask()
        asked[i] = candidate.value
        optimizer.tell(candidate, float(np.sum((asked[i] - 0.5) ** 2)))
    return (time.perf_counter() - t0) / evaluations * 1e6, asked


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dim", type=int, nargs="+", default=[4, 9])
    ap.add_argument("--evaluations", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")  # cma's and nevergrad's advice, once per candidate
    timed(2, 50, False, 0)  # imports
    print("| dim | nevergrad as it is (µs/candidate) | reusing the strategy | ratio | "
          "same candidates |")
    print("| --- | --- | --- | --- | --- |")
    for dim in args.dim:
        plain, reused, same = [], [], True
        for r in range(args.repeat):
            us_plain, x_plain = timed(dim, args.evaluations, False, r)
            us_reused, x_reused = timed(dim, args.evaluations, True, r)
            plain.append(us_plain)
            reused.append(us_reused)
            same &= bool(np.array_equal(x_plain, x_reused))
        a, b = statistics.median(plain), statistics.median(reused)
        print(f"| {dim} | {a:.0f} | {b:.0f} | {a / b:.2f}x | {'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
