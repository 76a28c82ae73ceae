"""The suite's shared linear core against the paper problem's specialised kernel, per
candidate, side by side in one run.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_ride_core.py [--rounds 7]

All compute z1'' and z2'' of the paper's half car (Newmark, average acceleration, dt = 1 ms,
the paper's window and bump) for the same population:

* ``specialised``: ``vpid_vehicle.kernel`` (structure of arrays, one thread), from the rows;
* ``shared core``: ``vpid_vehicle.ride.linear.newmark_outputs`` (the half car given as M, C,
  K, its input and output maps: what every linear model of the suite runs on), from the
  matrices to the responses (the target: within 1.3x of the specialised kernel);
* ``+ matrices``: the same with the model's numpy code that builds M, C, K and the maps from
  the rows (what a ride problem's evaluation runs);
* ``plain numpy``: ``simulate(newmark(...))``, the plain statement of the scheme (the shared
  core before it was compiled end to end).

Prints the median microseconds per candidate over interleaved rounds, the ratios to the
specialised kernel, and the largest difference of each to the specialised responses.
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


def system_of(problem: VehicleProblem, X: np.ndarray) -> linear.LinearSystem:
    """The paper's half car of the rows of X as a linear system (outputs z1'', z2'')."""
    known = problem.known
    M, C, K = matrices(X, known)
    F = np.broadcast_to(tyre_input(known), (X.shape[0], 4, 2))
    return linear.LinearSystem(M, C, K, F, response_rows(X, known), np.zeros((2, 4)),
                               np.zeros((2, 2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--ps", type=int, default=20)
    args = ap.parse_args()
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), args.ps)
    dt, u = problem.config.dt, np.ascontiguousarray(problem.model.y)
    setup = problem.model._kernel_setup()
    system = system_of(problem, X)
    ways = {
        "specialised": lambda: setup.responses(X, 1),
        "shared core": lambda: linear.newmark_outputs(system, dt, u),
        "+ matrices": lambda: linear.newmark_outputs(system_of(problem, X), dt, u),
        "plain numpy": lambda: linear.simulate(linear.newmark(system, dt), u),
    }
    reference = setup.responses(X, 1).transpose(0, 2, 1)
    peak = np.max(np.abs(reference))
    diffs = {name: float(np.max(np.abs(fn() - reference))) / peak
             for name, fn in ways.items() if name != "specialised"}
    times: dict[str, list[float]] = {name: [] for name in ways}
    for _ in range(args.rounds):
        for name, fn in ways.items():
            reps, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < 0.3:
                fn()
                reps += 1
            times[name].append((time.perf_counter() - t0) / reps / args.ps * 1e6)
    med = {k: statistics.median(v) for k, v in times.items()}
    print(f"paper's half car, Newmark dt = {dt} s, {problem.t.size} samples, PS {args.ps}, "
          f"{args.rounds} interleaved rounds (median)")
    for name, us in med.items():
        ratio = us / med["specialised"]
        diff = f", largest difference {diffs[name]:.1e} of the peak" if name in diffs else ""
        print(f"  {name:12s} {us:8.2f} us per candidate  {ratio:5.2f}x{diff}")
    print(f"shared core / specialised: {med['shared core'] / med['specialised']:.2f}x "
          "(target <= 1.3x)")


if __name__ == "__main__":
    main()
