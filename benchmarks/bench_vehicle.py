"""Speed of ``problem=vehicle``: microseconds per candidate of three ways to compute Eq. (3).

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_vehicle.py [--ps 20,600] [--rounds 21]
    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_vehicle.py --threshold   # thread hand-off
    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_vehicle.py --memory      # bytes per sample

Side by side in one process (dt = 1 ms, the paper's window): ``numpy``, a plain numpy Newmark
loop over time vectorised over the population (kept here so the ratio cannot drift when the
package changes); ``soa-1``, the package's structure-of-arrays kernel on one thread;
``soa-all``, the same on every core this process may use. Interleaved rounds (each times every
variant once); the tables give the minimum and the median over the rounds, ratios are medians
of the per-round ratios. Wall time is what a user waits for; for one thread the thread's CPU
time is given too, much less sensitive to other processes. Also: the kernel on a 1-sample
window (set-up and call), and a fresh process's build and first evaluation. ``--memory``:
the bytes per sample behind the memory cap (tracemalloc at two record lengths; docs/sweeps.md).
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable

import numpy as np
from vpid_vehicle import kernel
from vpid_vehicle.config import BYTES_PER_SAMPLE_CANDIDATE, BYTES_PER_STEP, VehicleConfig
from vpid_vehicle.model import matrices, response_rows, tyre_input
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.params import build_dataclass


def baseline_newmark(problem: VehicleProblem, X: np.ndarray) -> np.ndarray:
    """Eq. (3) for a population with a plain numpy Newmark loop over time (the baseline)."""
    known, dt = problem.known, problem.config.dt
    gamma, beta = problem.config.newmark.gamma, problem.config.newmark.beta
    M, C, K = matrices(X, known)
    F = problem.model.y @ tyre_input(known).T
    n, N = X.shape[0], F.shape[0]
    S_inv = np.linalg.inv(M + gamma * dt * C + beta * dt * dt * K)
    d = np.zeros((n, 4))
    v = np.zeros((n, 4))
    a = np.linalg.solve(M, np.broadcast_to(F[0], (n, 4))[..., None])[..., 0]
    acc = np.empty((N, n, 4))
    acc[0] = a
    for k in range(1, N):
        dp = d + dt * v + dt * dt * (0.5 - beta) * a
        vp = v + dt * (1 - gamma) * a
        rhs = F[k] - np.einsum("nij,nj->ni", C, vp) - np.einsum("nij,nj->ni", K, dp)
        a = np.einsum("nij,nj->ni", S_inv, rhs)
        d = dp + beta * dt * dt * a
        v = vp + gamma * dt * a
        acc[k] = a
    z = np.einsum("nij,knj->nik", response_rows(X, known), acc)
    ref = problem.reference
    num = np.linalg.norm(z - ref[None], axis=2).sum(axis=1)
    return num / np.linalg.norm(ref, axis=1).sum()


def timed(fn: Callable[[], object], number: int, clock=time.thread_time) -> tuple[float, float]:
    """Wall and CPU seconds per call over ``number`` calls (``clock``: the CPU clock)."""
    w, c = time.perf_counter(), clock()
    for _ in range(number):
        fn()
    return (time.perf_counter() - w) / number, (clock() - c) / number


def measure(ps: int, rounds: int, seconds: float = 0.02) -> tuple[dict, dict]:
    """Per-candidate wall and CPU microseconds of every variant over interleaved rounds."""
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), ps)
    ref, setup = problem.reference, problem.model._kernel_setup()
    fns = {"numpy": lambda: baseline_newmark(problem, X),
           "soa-1": lambda: setup.objective(X, ref, 1),
           "soa-all": lambda: setup.objective(X, ref, kernel.available_threads())}
    expected, numbers = fns["numpy"](), {}
    for name, fn in fns.items():  # compile or load, check, and size each timing
        np.testing.assert_allclose(fn(), expected, rtol=1e-10, atol=0, err_msg=name)
        numbers[name] = max(1, int(seconds / max(timed(fn, 1)[0], 1e-9)))
    wall = {name: [] for name in fns}
    cpu = {name: [] for name in fns}
    for _ in range(rounds):
        for name, fn in fns.items():
            w, c = timed(fn, numbers[name])
            wall[name].append(1e6 * w / ps)
            cpu[name].append(1e6 * c / ps)
    return ({n: np.array(v) for n, v in wall.items()}, {n: np.array(v) for n, v in cpu.items()})


def setup_cost(ps: int, rounds: int) -> float:
    """CPU microseconds per candidate of the SoA kernel on a 1-sample window: the
    per-candidate set-up plus the share of the call overhead (one thread, minimum)."""
    problem = VehicleProblem(VehicleConfig())
    k, cfg = problem.known, problem.config
    one = kernel.Setup(k.L, k.kt1, k.kt2, problem.model.y[:1], cfg.dt, cfg.newmark.gamma,
                       cfg.newmark.beta)
    X = problem.bounds.sample(np.random.default_rng(0), ps)
    ref = np.array(problem.reference[:, :1])
    one.objective(X, ref, 1)
    return min(1e6 * timed(lambda: one.objective(X, ref, 1), max(1, 4000 // ps))[1] / ps
               for _ in range(rounds))


def report(ps: int, wall: dict, cpu: dict) -> None:
    print(f"\nPS = {ps} (us per candidate; {len(wall['numpy'])} interleaved rounds)")
    print(f"{'variant':>9} {'wall min':>9} {'wall med':>9} {'cpu min':>8} "
          f"{'numpy/this (wall med)':>25} {'(cpu med)':>10}")
    for name in wall:
        single = name != "soa-all"
        cpu_min = f"{cpu[name].min():8.2f}" if single else f"{'-':>8}"
        r_wall = np.median(wall["numpy"] / wall[name])
        r_cpu = f"{np.median(cpu['numpy'] / cpu[name]):10.2f}" if single else f"{'-':>10}"
        print(f"{name:>9} {wall[name].min():9.2f} {np.median(wall[name]):9.2f} {cpu_min} "
              f"{r_wall:25.2f} {r_cpu}")
    print(f"numpy / soa-1 (wall med): {np.median(wall['numpy'] / wall['soa-1']):.0f}x; "
          f"soa-1 / soa-all (wall med): {np.median(wall['soa-1'] / wall['soa-all']):.2f}x "
          f"with {kernel.available_threads()} threads")


def threshold(rounds: int) -> None:
    """Small batches on one thread against every thread, with the chunking forced
    (MIN_PER_THREAD = 1): the wall-time ratio (what a user gains when cores are free) and the
    extra CPU time the hand-off costs per call, summed over threads."""
    problem = VehicleProblem(VehicleConfig())
    setup, ref = problem.model._kernel_setup(), problem.reference
    threads = kernel.available_threads()
    saved, kernel.MIN_PER_THREAD = kernel.MIN_PER_THREAD, 1
    try:
        print(f"\nthread hand-off ({threads} threads, chunking forced; current "
              f"MIN_PER_THREAD = {saved}):")
        print(f"{'batch':>6} {'1 thread us (cpu min)':>22} {'extra cpu us (min)':>19} "
              f"{'wall 1 thread / all (median)':>29}")
        for n in (8, 16, 32, 48, 64, 96, 128, 256):
            X = problem.bounds.sample(np.random.default_rng(1), n)
            calls = [lambda t=t, X=X: setup.objective(X, ref, t) for t in (1, threads)]
            for fn in calls:
                fn()
            runs = [[timed(fn, max(2, 2000 // n), time.process_time) for fn in calls]
                    for _ in range(rounds)]
            cpu1, cpun = (min(r[i][1] for r in runs) for i in (0, 1))
            ratio = np.median([a[0] / b[0] for a, b in runs])
            print(f"{n:>6} {1e6 * cpu1:22.1f} {1e6 * (cpun - cpu1):19.1f} {ratio:29.2f}")
    finally:
        kernel.MIN_PER_THREAD = saved


def memory(ps: int = 20) -> None:
    """Bytes per sample of the set-up and per sample and candidate of a residual batch."""
    def peak(extra: float) -> tuple[int, int, int]:
        tracemalloc.start()
        problem = VehicleProblem(build_dataclass(VehicleConfig, {"record": {"extra": extra}}))
        setup = tracemalloc.get_traced_memory()[1]
        tracemalloc.reset_peak()
        problem.evaluate_with_residuals(problem.bounds.sample(np.random.default_rng(0), ps))
        batch = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return problem.t.size, setup, batch

    peak(0.0)  # imports and compiled kernels first: they are not per-sample costs
    (n1, s1, b1), (n2, s2, b2) = peak(0.5), peak(5.5)
    print(f"samples {n1} -> {n2}")
    print(f"set-up: {(s2 - s1) / (n2 - n1):.0f} B per sample (cap assumes {BYTES_PER_STEP})")
    print(f"one residual batch of {ps}: {(b2 - b1) / (n2 - n1) / ps:.1f} B per sample and "
          f"candidate (cap assumes {BYTES_PER_SAMPLE_CANDIDATE})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=21, help="interleaved rounds (default 21)")
    ap.add_argument("--ps", default="20,600", help="population sizes (default 20,600)")
    ap.add_argument("--threshold", action="store_true",
                    help="also time small batches on 1 thread against all threads")
    ap.add_argument("--memory", action="store_true", help="bytes per sample instead")
    args = ap.parse_args()
    if args.memory:
        return memory()
    print("command:", shlex.join([os.path.relpath(sys.executable), *sys.argv]))
    print(f"cores usable: {kernel.available_threads()}, os.getloadavg(): "
          f"{tuple(round(x, 1) for x in os.getloadavg())}")
    code = ("import time; t=time.perf_counter(); from vpid_vehicle.problem import VehicleProblem;"
            "from vpid_vehicle.config import VehicleConfig; p=VehicleProblem(VehicleConfig());"
            "p.evaluate(p.x_true[None]); print(time.perf_counter()-t)")
    cold = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                check=True).stdout.strip())
    for ps in (int(p) for p in args.ps.split(",")):
        report(ps, *measure(ps, args.rounds))
        print(f"soa-1 on a 1-sample window (set-up + call): {setup_cost(ps, args.rounds):.2f} "
              "us per candidate (cpu min)")
    if args.threshold:
        threshold(args.rounds)
    print(f"\ncold start (new process: build problem + first evaluate): {cold:.2f} s")


if __name__ == "__main__":
    main()
