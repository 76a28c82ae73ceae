"""nevergrad's CMA per candidate as it is, reusing its running strategy, also asking the
optimizer the registry's ``CMA`` selects directly (:mod:`vpid_peers.nevergrad_cma`), and
replicated on cma (:mod:`vpid_peers.nevergrad_replica`: what ``optimizer=nevergrad`` runs),
side by side in one run: what ``optimizer=nevergrad`` (default ``CMA``, one candidate per
ask) costs of its own on a cheap function in the unit cube.

    .venv/bin/python benchmarks/bench_nevergrad_cma.py [--dim 4 9] [--evaluations 3000] [--repeat 3]

Prints, per dimension, the median over ``--repeat`` timings of ask and tell per candidate
(µs) for nevergrad as it is, with the reuse, with the reuse driving the selected optimizer and
replicated, the ratio of the first to the last, and whether the candidates were identical
(they must be: none of them changes the search).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

import numpy as np


def timed(dim: int, evaluations: int, reuse: bool, seed: int, direct: bool = False,
          replica: bool = False) -> tuple[float, np.ndarray]:
    """µs per candidate of nevergrad's CMA on a sphere in [0, 1]^dim, and its candidates
    (``direct``: asking the optimizer the registry's ``CMA`` selects; ``replica``: that one
    replicated on cma, as the plugin does)."""
    import nevergrad as ng
    from vpid_peers.nevergrad_cma import driven, skip_repeated_bounds_check
    from vpid_peers.nevergrad_replica import replicated

    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(seed)
    optimizer = ng.optimizers.registry["CMA"](parametrization=parametrization,
                                              budget=evaluations, num_workers=1)
    if reuse:
        skip_repeated_bounds_check(optimizer)
    if direct:
        optimizer = driven(optimizer)
    if replica:
        optimizer = replicated(optimizer)
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
          "selected optimizer | replicated on cma (the plugin) | ratio | same candidates |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    ways = [{"reuse": False}, {"reuse": True}, {"reuse": True, "direct": True},
            {"reuse": True, "direct": True, "replica": True}]
    for dim in args.dim:
        times: list[list[float]] = [[] for _ in ways]
        same = True
        for r in range(args.repeat):
            asked = []
            for way, spent in zip(ways, times):
                us, x = timed(dim, args.evaluations, seed=r, **way)
                spent.append(us)
                asked.append(x)
            same &= all(np.array_equal(asked[0], x) for x in asked[1:])
        medians = [statistics.median(t) for t in times]
        print(f"| {dim} | " + " | ".join(f"{m:.0f}" for m in medians)
              + f" | {medians[0] / medians[-1]:.1f}x | {'yes' if same else 'NO'} |")


if __name__ == "__main__":
    main()
