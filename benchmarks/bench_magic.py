"""The Magic Formula model's kernel with its vectorisable arc tangent and sine
(``ride/vecmath``) against the same kernel calling the C library's, side by side in one run.

Both are compiled from the same source (the second with ``vecmath`` replaced by the C
library's functions), on the ``smoke_lateral_mf`` record (2 s at 1 ms) and a batch of 20
candidates; prints the median over rounds of µs per candidate, their ratio, and how far the
outputs are apart (relative to each channel's peak).

    .venv/bin/python benchmarks/bench_magic.py [--rounds 7] [--batch 20]
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
import types

import numba
import numpy as np
from vpid_vehicle.ride import kernel

from vpid_bench.build import build_problem
from vpid_bench.plugins import Registry


def _recompiled(fn, options, **globals_):
    """``fn``'s Python source compiled again by numba with some of its globals replaced."""
    py = fn.py_func
    scope = dict(py.__globals__)
    scope.update(globals_)
    return numba.njit(**options)(types.FunctionType(py.__code__, scope, py.__name__))


def libm_kernel():
    """The Magic Formula kernel with the C library's ``atan`` and ``sin``."""
    libm = types.ModuleType("libm")
    libm.atan, libm.sin = math.atan, math.sin
    inline = {"inline": "always", "error_model": "numpy"}
    mf = _recompiled(kernel._mf, inline, vecmath=libm)
    rates = _recompiled(kernel._rates, inline, _mf=mf)
    return _recompiled(kernel.mf_single_track, {"error_model": "numpy", "nogil": True},
                       _rates=rates)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--batch", type=int, default=20)
    args = ap.parse_args()
    p = build_problem(Registry(), {"name": "smoke_lateral_mf"})
    X = p.bounds.sample(np.random.default_rng(0), args.batch)
    lf, m, E, vx = p.known["lf"], p.known["m"], p.known["E"], p.model.vx
    call = (np.ascontiguousarray(X[:, :6].T), np.ascontiguousarray(X[:, 6]),
            np.ascontiguousarray(p.u[:, 0]), p.config.dt, m, lf, p.known["L"] - lf, vx, E)
    kernels = {"vecmath (shipped)": kernel.mf_single_track, "C library": libm_kernel()}
    outputs, times = {}, {name: [] for name in kernels}
    for name, k in kernels.items():
        outputs[name] = np.empty((p.u.shape[0], 3, args.batch))
        k(*call, outputs[name])
    for _ in range(args.rounds):
        for name, k in kernels.items():
            t0 = time.perf_counter()
            k(*call, outputs[name])
            times[name].append((time.perf_counter() - t0) / args.batch * 1e6)
    print(f"command: benchmarks/bench_magic.py --rounds {args.rounds} --batch {args.batch}")
    print(f"record: {p.u.shape[0]} steps of {p.config.dt} s, {args.batch} candidates")
    print("| kernel | µs per candidate (median) |")
    print("| --- | --- |")
    for name in kernels:
        print(f"| {name} | {statistics.median(times[name]):.1f} |")
    a, b = outputs.values()
    ratio = statistics.median(times["C library"]) / statistics.median(times["vecmath (shipped)"])
    peak = np.max(np.abs(b), axis=(0, 2))
    apart = np.max(np.abs(a - b), axis=(0, 2)) / peak
    print(f"speed-up: {ratio:.2f}x; outputs apart by at most {apart.max():.1e} of the peak")


if __name__ == "__main__":
    main()
