"""The suite's shared linear core against the paper problem's specialised kernel, per
candidate, side by side in one run.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_ride_core.py [--rounds 7]

Both compute z1'' and z2'' of the paper's half car (Newmark, average acceleration, dt = 1 ms,
the paper's window and bump) for the same population: ``specialised`` is
``vpid_vehicle.kernel`` (structure of arrays, one thread), ``shared core`` is
``vpid_vehicle.ride.linear`` (the half car given as M, C, K, its input and output maps: what
every linear model of the suite runs on), timed from the matrices to the responses. Prints the
median microseconds per candidate over interleaved rounds and their ratio (target: the shared
core within 1.3x of the specialised kernel), and the largest difference of the two responses.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.model import matrices, response_rows, tyre_input
from vpid_vehicle.problem import VehicleProblem
from vpid_vehicle.ride import linear


def shared_core(problem: VehicleProblem, X: np.ndarray) -> np.ndarray:
    """z1'', z2'' ``(n, 2, N)`` of the rows of X through the shared linear core."""
    known, dt = problem.known, problem.config.dt
    M, C, K = matrices(X, known)
    n = X.shape[0]
    F = np.broadcast_to(tyre_input(known), (n, 4, 2))
    R = response_rows(X, known)
    system = linear.LinearSystem(M, C, K, F, R, np.zeros((2, 4)), np.zeros((2, 2)))
    return linear.simulate(linear.newmark(system, dt), problem.model.y).transpose(0, 2, 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--ps", type=int, default=20)
    args = ap.parse_args()
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), args.ps)
    setup = problem.model._kernel_setup()
    specialised = setup.responses(X, 1)
    shared = shared_core(problem, X)
    diff = float(np.max(np.abs(shared - specialised)) / np.max(np.abs(specialised)))
    times: dict[str, list[float]] = {"specialised": [], "shared core": []}
    for _ in range(args.rounds):
        for name, fn in (("specialised", lambda: setup.responses(X, 1)),
                         ("shared core", lambda: shared_core(problem, X))):
            reps, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < 0.3:
                fn()
                reps += 1
            times[name].append((time.perf_counter() - t0) / reps / args.ps * 1e6)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"paper's half car, Newmark dt = {problem.config.dt} s, {problem.t.size} samples, "
          f"PS {args.ps}, {args.rounds} interleaved rounds (median)")
    for name, us in med.items():
        print(f"  {name:12s} {us:8.2f} us per candidate")
    print(f"shared core / specialised: {med['shared core'] / med['specialised']:.2f}x "
          f"(target <= 1.3x); largest response difference {diff:.1e} of the peak")


if __name__ == "__main__":
    main()
