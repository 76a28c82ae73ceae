"""How often the 95 % intervals cover the pseudo-true value on the suite's model-error members:
the robust (HAC sandwich) interval beside the white-noise (Jacobian) one (docs/estimators.md,
"What an interval covers under model error").

Per member and instance: the estimate ``θ̂`` (:func:`_fit` of the noisy record), the
pseudo-true ``θ*`` (the same on the noise-free record, ``problem.clean``) and both intervals
at ``θ̂``; a parameter is covered when ``θ*_j`` lies inside. Deterministic. Command:
``python tools/interval_coverage.py --instances 15``.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from vpid_vehicle.ride.suites import MEMBERS as ALL

from vpid_bench.analysis.diagnostics import problem_diagnostics

#: The suite's model-error members (docs/suite.md).
MEMBERS = ("vpid1_q_golden_bilinear", "vpid1_h_gokdag_seat_iso_c", "vpid1_l_civic_model_error")
#: Reweightings of the profiled likelihood's fit (the weights settle in two or three).
REWEIGHTS = 5


def _fit(problem: Any, measured: np.ndarray, start: np.ndarray) -> np.ndarray:
    """The ``ml_profiled`` estimate on ``measured`` (a record of the problem's channels):
    least squares on ``fisher_residuals`` weighted by ``1/σ̂_c`` per channel, ``σ̂_c`` from
    the residuals of the previous fit, repeated :data:`REWEIGHTS` times."""
    saved = problem.measured
    problem.measured = measured
    try:
        groups = np.asarray(problem.fisher_groups(), dtype=int)
        scale = np.abs(start)
        b = problem.bounds
        w = np.ones(int(groups.max()) + 1)
        z = start / scale
        for _ in range(REWEIGHTS):
            def res(z: np.ndarray, w: np.ndarray = w) -> np.ndarray:
                r = problem.fisher_residuals((z * scale)[None])[0] * w[groups]
                return np.where(np.isfinite(r), r, 1e6)

            z = least_squares(res, z, bounds=(b.lower / scale, b.upper / scale),
                              xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200).x
            r = problem.fisher_residuals((z * scale)[None])[0]
            w = 1.0 / np.sqrt(np.array([np.mean(r[groups == g] ** 2) for g in range(w.size)]))
        return z * scale
    finally:
        problem.measured = saved


def member_coverage(name: str, instances: int) -> dict[str, Any]:
    """Coverage of both intervals over ``instances`` instances of suite member ``name``."""
    cls = {m.name: m for m in ALL}[name]
    base = cls(cls.Config())
    white, robust, half_w, half_r, lag1 = [], [], [], [], []
    for i in range(instances):
        p = base.instance(i)
        x_star = _fit(p, p.clean, p.x_true)
        x_hat = _fit(p, p.measured, p.x_true)
        d = problem_diagnostics(p, x_hat)
        iv = d["intervals"]
        lo, hi = np.array(iv["lower"], float), np.array(iv["upper"], float)
        rlo = np.array(iv["robust"]["lower"], float)
        rhi = np.array(iv["robust"]["upper"], float)
        white += list((lo <= x_star) & (x_star <= hi))
        robust += list((rlo <= x_star) & (x_star <= rhi))
        half_w += list(100 * (hi - x_hat) / np.abs(x_hat))
        half_r += list(100 * (rhi - x_hat) / np.abs(x_hat))
        lag1.append(max(abs(g["lag1"]) for g in d["groups"]))
    return {"member": name, "instances": instances, "cases": len(white),
            "white": float(np.mean(white)), "robust": float(np.mean(robust)),
            "half_white": float(np.median(half_w)), "half_robust": float(np.median(half_r)),
            "lag1": float(np.median(lag1))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=15)
    ap.add_argument("members", nargs="*", default=list(MEMBERS))
    args = ap.parse_args(argv)
    unknown = [m for m in args.members if m not in MEMBERS]
    if unknown:
        print(f"error: member {unknown[0]!r} is not a model-error member; allowed: "
              f"{', '.join(MEMBERS)}", file=sys.stderr)
        return 2
    print("member | instances x parameters | coverage white (Jacobian) | coverage robust "
          "(HAC) | median ± % white | median ± % robust | median lag-1")
    print("--- | ---: | ---: | ---: | ---: | ---: | ---:")
    for name in args.members:
        c = member_coverage(name, args.instances)
        print(f"{name} | {c['cases']} | {100 * c['white']:.0f} % | {100 * c['robust']:.0f} % | "
              f"{c['half_white']:.3g} | {c['half_robust']:.3g} | {c['lag1']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
