"""The problems' compiled kernels beside other ways to compute the same, per candidate, side
by side in one run (interleaved rounds; the median, or the least where noted).

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_kernels.py \\
        {core,magic,structures,measured} [--rounds 7] [--ps 20]

``core``: the paper's half car's specialised kernel against the ride suite's shared linear
core (target within 1.3x of it), the same with the model's matrices, and plain numpy;
``magic``: the Magic Formula kernel's vectorisable ``atan`` and ``sin`` against the C
library's; ``structures``: each ride family's linear and richest structure; ``measured``:
the measured problems, ``--ps`` at once against one at a time (docs/suite.md and
docs/measured.md). Prints per way µs per candidate, its ratio to the first way and, where the
ways compute the same outputs, the largest difference to the first's (of the peak).
"""

from __future__ import annotations

import argparse
import math
import statistics
import types
from collections.abc import Iterator

import numba
import numpy as np
from _shared import interleaved
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.model import matrices, response_rows, tyre_input
from vpid_vehicle.problem import VehicleProblem
from vpid_vehicle.ride import kernel, linear
from vpid_vehicle.ride.full import RideFullProblem
from vpid_vehicle.ride.half import RideHalfProblem
from vpid_vehicle.ride.quarter import RideQuarterProblem

from vpid_bench.build import build_problem
from vpid_bench.plugins import Registry


def system_of(problem, X: np.ndarray):
    """The paper's half car of the rows of X as a linear system (outputs z1'', z2'')."""
    known = problem.known
    M, C, K = matrices(X, known)
    F = np.broadcast_to(tyre_input(known), (X.shape[0], 4, 2))
    return linear.LinearSystem(M, C, K, F, response_rows(X, known), np.zeros((2, 4)),
                               np.zeros((2, 2)))


def core(args) -> Iterator[tuple]:
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), args.ps)
    dt, u = problem.config.dt, np.ascontiguousarray(problem.model.y)
    setup, system = problem.model._kernel_setup(), system_of(problem, X)
    ways = {"specialised": lambda: setup.responses(X, 1).transpose(0, 2, 1),
            "shared core": lambda: linear.newmark_outputs(system, dt, u),
            "+ matrices": lambda: linear.newmark_outputs(system_of(problem, X), dt, u),
            "plain numpy": lambda: linear.simulate(linear.newmark(system, dt), u)}
    ref = ways["specialised"]()
    diffs = {k: float(np.max(np.abs(fn() - ref)) / np.max(np.abs(ref))) for k, fn in ways.items()}
    yield (f"paper's half car, Newmark dt = {dt} s, {problem.t.size} samples, PS {args.ps}",
           ways, args.ps, diffs, {"seconds": 0.3})


def _recompiled(fn, options, **globals_):
    """``fn``'s Python source compiled again by numba with some of its globals replaced."""
    py = fn.py_func
    scope = {**py.__globals__, **globals_}
    return numba.njit(**options)(types.FunctionType(py.__code__, scope, py.__name__))


def magic(args) -> Iterator[tuple]:
    libm = types.ModuleType("libm")  # numba types a module's functions, not a namespace's
    libm.atan, libm.sin = math.atan, math.sin
    inline = {"inline": "always", "error_model": "numpy"}
    rates = _recompiled(kernel._rates, inline, _mf=_recompiled(kernel._mf, inline, vecmath=libm))
    kernels = {"vecmath (shipped)": kernel.mf_single_track,
               "C library": _recompiled(kernel.mf_single_track,
                                        {"error_model": "numpy", "nogil": True}, _rates=rates)}
    p = build_problem(Registry(), {"name": "smoke_lateral_mf"})
    X = p.bounds.sample(np.random.default_rng(0), args.ps)
    lf = p.known["lf"]
    call = (np.ascontiguousarray(X[:, :6].T), np.ascontiguousarray(X[:, 6]),
            np.ascontiguousarray(p.u[:, 0]), p.config.dt, p.known["m"], lf, p.known["L"] - lf,
            p.model.vx, p.known["E"])
    out = {name: np.empty((p.u.shape[0], 3, args.ps)) for name in kernels}
    ways = {name: (lambda k=k, o=out[name]: k(*call, o)) for name, k in kernels.items()}
    for fn in ways.values():
        fn()
    ref = out["vecmath (shipped)"]
    peak = np.max(np.abs(ref), axis=(0, 2))
    diffs = {n: float(np.max(np.max(np.abs(o - ref), axis=(0, 2)) / peak)) for n, o in out.items()}
    yield (f"Magic Formula, {p.u.shape[0]} steps of {p.config.dt} s, {args.ps} candidates",
           ways, args.ps, diffs, {})


def structures(args) -> Iterator[tuple]:
    for P in (RideQuarterProblem, RideHalfProblem, RideFullProblem):
        ways = {}
        for name, keys in (("linear", {}), ("cubic+bilinear", {"spring": "cubic",
                                                               "damper": "bilinear"})):
            p = P(P.Config(**keys))
            b = p.bounds
            X = b.lower + (b.upper - b.lower) * np.random.default_rng(1).uniform(
                0.1, 0.9, (args.ps, b.lower.size))
            ways[name] = lambda p=p, X=X: p.evaluate(X)
        yield P.name, ways, args.ps, {}, {"number": 15, "pick": min}


def measured(args) -> Iterator[tuple]:
    registry = Registry()
    for cfg in ({"name": "emps"}, {"name": "bayesrace"}, {"name": "racecar"},
                {"name": "racecar", "tyres": "magic_formula"}):
        p = build_problem(registry, cfg)
        b = p.bounds
        X = b.lower + (b.upper - b.lower) * np.random.default_rng(0).random((args.ps, b.dim))
        ways = {f"{args.ps} at once": lambda p=p, X=X: p.evaluate(X),
                "1 at a time": lambda p=p, X=X: [p.evaluate(x[None]) for x in X]}
        yield " ".join(f"{k}={v}" if k != "name" else v for k, v in cfg.items()), ways, \
            args.ps, {}, {}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("part", choices=("core", "magic", "structures", "measured"))
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--ps", type=int, default=20, help="candidates per call")
    args = ap.parse_args()
    print(f"command: benchmarks/bench_kernels.py {args.part} --rounds {args.rounds} "
          f"--ps {args.ps}")
    for title, ways, n, diffs, timing in globals()[args.part](args):
        seconds = interleaved(ways, args.rounds, **timing)
        first = next(iter(seconds.values()))
        pick = timing.get("pick", statistics.median).__name__
        print(f"{title} ({args.rounds} interleaved rounds, the {pick})")
        print("| way | µs per candidate | × the first | largest difference (of the peak) |")
        print("| --- | --- | --- | --- |")
        for name, s in seconds.items():
            diff = f"{diffs[name]:.1e}" if name in diffs else ""
            print(f"| {name} | {s / n * 1e6:.2f} | {s / first:.2f} | {diff} |")


if __name__ == "__main__":
    main()
