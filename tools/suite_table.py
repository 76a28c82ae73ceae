"""The table of docs/suite.md: every member of a named suite at its defaults, instance 0.

    .venv/bin/python tools/suite_table.py [--suite vpid1] [--starts 100] [--seed 0] [--only a,b]

Per problem: model, parameter set, dimension, input, sensors, noise, record length, the
Cramér–Rao bound's norm and condition number, and the distinct optima that ``--starts``
bounded least-squares fits from uniform random starts end in (:func:`distinct_optima`; each
column: docs/suite.md, the members of ``vpid1``).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.optimize import least_squares

from vpid_bench.analysis.identifiability import cramer_rao
from vpid_bench.plugins import Registry


def distinct_optima(problem, starts: int, seed: int) -> tuple[list[tuple[float, int, float]], int]:
    """``(f, starts ending there, NoRE %)`` of each distinct converged end, best first, and
    the number of fits that stalled at the evaluation limit."""
    lo, hi = problem.bounds.lower, problem.bounds.upper
    rng = np.random.default_rng(seed)

    def residuals(z: np.ndarray) -> np.ndarray:
        r = problem.residuals((lo + z * (hi - lo))[None])[0]
        return np.where(np.isfinite(r), r, 1e3)

    ends: list[list[float]] = []
    stalled = 0
    for _ in range(starts):
        fit = least_squares(residuals, rng.random(lo.size), bounds=(0, 1), max_nfev=300)
        if fit.status == 0:
            stalled += 1
            continue
        x = lo + fit.x * (hi - lo)
        f = float(problem.evaluate(x[None])[0])
        for end in ends:
            if abs(end[0] - f) <= 1e-4 * max(abs(f), 1e-300):
                end[1] += 1
                break
        else:
            ends.append([f, 1, problem.metrics(x)["NoRE"]])
    return sorted((e[0], int(e[1]), e[2]) for e in ends), stalled


def describe(problem) -> dict[str, str]:
    cfg = problem.config
    inp = getattr(cfg, "road", None)
    if inp == "iso8608":
        inp = f"ISO 8608 class {cfg.road_class}"
    if inp is None:
        inp = f"{cfg.manoeuvre} steer {cfg.steer_deg:g}°"
    return {"set": cfg.parameter_set, "input": f"{inp}, {cfg.speed_kmh:g} km/h",
            "sensors": ", ".join(c for c, _ in problem.channels),
            "noise": f"additive, {100 * cfg.noise_level:g} % of rms",
            "record": f"{problem.t.size} × {cfg.dt * 1e3:g} ms"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", default="vpid1")
    ap.add_argument("--starts", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", default="", help="comma-separated members (default: all)")
    args = ap.parse_args()
    registry = Registry()
    print("| problem | set | d | input | sensors | noise | record | CRB norm (%) | cond. | "
          f"optima from {args.starts} lsq starts: f (starts, NoRE %) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    members = registry.suites().get(args.suite)
    if not members:
        ap.error(f"--suite {args.suite!r}: one of {', '.join(sorted(registry.suites()))}")
    only = [n for n in args.only.split(",") if n]
    unknown = [n for n in only if n not in members]
    if unknown:
        ap.error(f"--only {unknown[0]!r}: a member of {args.suite}, one of "
                 f"{', '.join(members)}")
    members = only or members
    for name in members:
        t0 = time.perf_counter()
        cls = registry.problem(name)
        problem = cls(cls.Config())
        info = describe(problem)
        crb = cramer_rao(problem)
        optima, stalled = distinct_optima(problem, args.starts, args.seed)
        ends = "; ".join(f"{f:.4g} ({n}, {nore:.3g})" for f, n, nore in optima)
        ends += f"; {stalled} stalled" if stalled else ""
        print(f"| `{name}` | {info['set']} | {problem.bounds.dim} | {info['input']} | "
              f"{info['sensors']} | {info['noise']} | {info['record']} | "
              f"{crb['crb_norm_percent']:.3g} | {crb['condition_number']:.3g} | "
              f"{len(optima)}: {ends} |", flush=True)
        print(f"<!-- {name}: {time.perf_counter() - t0:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
