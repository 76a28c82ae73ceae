"""Speed of ``problem=vehicle``: microseconds per candidate and the ratio to a plain loop.

Run as a script (prints a table; timings are the best of several interleaved repeats, so
the ratio is measured side by side in one run even on a shared machine)::

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_vehicle.py

or with pytest-benchmark: ``.venv/bin/python -m pytest benchmarks/bench_vehicle.py``.

The baseline is kept here on purpose: a straightforward numpy Newmark loop vectorised over
the population (precomputed inverse of S, einsum mat-vecs), so the ratio cannot drift when
the package changes. Target: <= 15 us per candidate at PS = 20, dt = 1 ms, and >= 30x.
"""

from __future__ import annotations

import subprocess
import sys
import timeit

import numpy as np
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.model import matrices, response_rows, tyre_input
from vpid_vehicle.problem import VehicleProblem


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


def best_time(fn, repeats: int, number: int) -> float:
    """Best wall time per call (s) over ``repeats`` timings of ``number`` calls (stdlib timeit)."""
    return min(timeit.repeat(fn, repeat=repeats, number=number)) / number


def cold_start_s() -> float:
    """Seconds for a fresh process to build the problem and evaluate once (loads the
    numba on-disk cache; compiles only if the cache is missing or stale)."""
    code = ("import time; t=time.perf_counter(); from vpid_vehicle.problem import VehicleProblem;"
            "from vpid_vehicle.config import VehicleConfig; p=VehicleProblem(VehicleConfig());"
            "p.evaluate(p.x_true[None]); print(time.perf_counter()-t)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.strip())


def measure(ps: int = 20, rounds: int = 5) -> dict[str, float]:
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), ps)
    fast = problem.evaluate(X)  # compile or load the kernel before timing
    slow = baseline_newmark(problem, X)
    assert np.allclose(fast, slow, rtol=1e-10, atol=0), "fast path and baseline disagree"
    t_fast, t_slow = np.inf, np.inf
    for _ in range(rounds):  # interleaved, so both see the same machine load
        t_fast = min(t_fast, best_time(lambda: problem.evaluate(X), 3, 50))
        t_slow = min(t_slow, best_time(lambda: baseline_newmark(problem, X), 1, 3))
    return {
        "ps": ps,
        "samples": problem.t.size,
        "fast_us_per_candidate": 1e6 * t_fast / ps,
        "baseline_us_per_candidate": 1e6 * t_slow / ps,
        "ratio": t_slow / t_fast,
    }


def test_fast_evaluate(benchmark):
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), 20)
    problem.evaluate(X)
    benchmark(problem.evaluate, X)


def test_baseline_newmark(benchmark):
    problem = VehicleProblem(VehicleConfig())
    X = problem.bounds.sample(np.random.default_rng(0), 20)
    benchmark.pedantic(baseline_newmark, args=(problem, X), rounds=5)


def main() -> None:
    cold = cold_start_s()
    print(f"{'PS':>4} {'samples':>8} {'fast us/cand':>13} {'baseline us/cand':>17} {'ratio':>7}")
    for ps in (20, 30):
        r = measure(ps)
        print(f"{r['ps']:>4} {r['samples']:>8} {r['fast_us_per_candidate']:>13.2f} "
              f"{r['baseline_us_per_candidate']:>17.1f} {r['ratio']:>7.1f}")
    print(f"cold start (new process: build problem + first evaluate): {cold:.2f} s")


if __name__ == "__main__":
    main()
