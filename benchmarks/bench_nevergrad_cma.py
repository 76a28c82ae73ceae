"""nevergrad's CMA per candidate as it is, reusing its running strategy, and also asking the
optimizer the registry's ``CMA`` selects directly (:mod:`vpid_peers.nevergrad_cma`: what
``optimizer=nevergrad`` does), side by side in one run: what ``optimizer=nevergrad`` (default
``CMA``, one candidate per ask) costs of its own on a cheap function in the unit cube.

    .venv/bin/python benchmarks/bench_nevergrad_cma.py [--dim 4 9] [--evaluations 3000] [--repeat 3]

Prints, per dimension, the median over ``--repeat`` timings of ask and tell per candidate
(µs) for nevergrad as it is, with the reuse, and with the reuse driving the selected optimizer,
the ratio of the first to the last, and whether the candidates were identical (they must be:
neither changes the search).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np


def timed(dim: int, evaluations: int, reuse: bool, seed: int,
          direct: bool = False) -> tuple[float, np.ndarray]:
    """µs per candidate of nevergrad's CMA on a sphere in [0, 1]^dim, and its candidates
    (``direct``: asking the optimizer the registry's ``CMA`` selects, as the plugin does)."""
    import nevergrad as ng
    from vpid_peers.nevergrad_cma import driven, skip_repeated_bounds_check

    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(seed)
    optimizer = ng.optimizers.registry["CMA"](parametrization=parametrization,
                                              budget=evaluations, num_workers=1)
    if reuse:
        skip_repeated_bounds_check(optimizer)
    if direct:
        optimizer = driven(optimizer)
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
    print("| dim | nevergrad as it is (µs/candidate) | reusing the strategy | and asking the "
          "selected optimizer (the plugin) | ratio | same candidates |")
    print("| --- | --- | --- | --- | --- | --- |")
    for dim in args.dim:
        plain, reused, direct, same = [], [], [], True
        for r in range(args.repeat):
            us_plain, x_plain = timed(dim, args.evaluations, False, r)
            us_reused, x_reused = timed(dim, args.evaluations, True, r)
            us_direct, x_direct = timed(dim, args.evaluations, True, r, direct=True)
            plain.append(us_plain)
            reused.append(us_reused)
            direct.append(us_direct)
            same &= bool(np.array_equal(x_plain, x_reused) and np.array_equal(x_plain, x_direct))
        a, b, c = (statistics.median(t) for t in (plain, reused, direct))
        print(f"| {dim} | {a:.0f} | {b:.0f} | {c:.0f} | {a / c:.2f}x | "
              f"{'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
