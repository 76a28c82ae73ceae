"""The likelihood (``objective=ml``) against the Cramér–Rao bound, like with like, at more
than one noise level (docs/estimators.md, "The likelihood against the bound").

Per level, over instances 0 .. n-1 of ``problem=vehicle`` (the ``ml`` optimum polished from the
truth): the rms-norm of its relative errors (%) against the bound's norm, and its median NoRE
against the median of ``||N(0, cov_CRB)||``; both ratios are 1 for an efficient estimator.
Deterministic. Command: ``python tools/ml_vs_bound.py --instances 30 --levels 0.05 0.2``.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.analysis.identifiability import entry_sigma, informative, jacobian
from vpid_bench.analysis.optimum import polish


def bound_covariance(inst) -> np.ndarray:
    """The Cramér–Rao covariance of the relative errors (%²) of ``inst`` at its truth, from
    the simulated noise (the entries ``cramer_rao`` keeps)."""
    x = inst.x_true
    groups = np.asarray(inst.fisher_groups(), dtype=int)
    per = entry_sigma(np.asarray(inst.residual_sigma(), dtype=float), groups)
    kept = informative(per, groups)
    Jw = jacobian(inst, x)[kept] / per[kept][:, None] * x[None] / 100.0
    return np.linalg.inv(Jw.T @ Jw)


def measure(level: float, instances: int, draws: int = 200_000) -> dict:
    """The ``ml`` optimum's error statistics and the bound's at noise ``level``."""
    cfg = VehicleConfig(objective="ml")
    cfg = dataclasses.replace(cfg, noise=dataclasses.replace(cfg.noise, level=level))
    problem = VehicleProblem(cfg)
    errors, covs = [], []
    for i in range(instances):
        inst = problem.instance(i)
        x_opt, _ = polish(inst, inst.x_true)
        errors.append(100 * (x_opt - inst.x_true) / inst.x_true)
        covs.append(bound_covariance(inst))
    e = np.asarray(errors)
    cov = np.mean(covs, axis=0)  # per instance the same design (the noise scales with it)
    rng = np.random.default_rng(0)
    gauss = rng.multivariate_normal(np.zeros(cov.shape[0]), cov, size=draws)
    return {"level": level, "instances": instances,
            "rms_norm": float(np.linalg.norm(np.sqrt(np.mean(e**2, axis=0)))),
            "crb_norm": float(np.sqrt(np.trace(cov))),
            "median_nore": float(np.median(np.linalg.norm(e, axis=1))),
            "crb_median": float(np.median(np.linalg.norm(gauss, axis=1)))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--instances", type=int, default=30)
    ap.add_argument("--levels", type=float, nargs="+", default=[0.05, 0.2])
    args = ap.parse_args(argv)
    print(f"command: python tools/ml_vs_bound.py --instances {args.instances} --levels "
          + " ".join(f"{v:g}" for v in args.levels))
    print("noise level | rms-norm of ml's errors | CRB norm | ratio | median NoRE of ml | "
          "median of the CRB Gaussian's norm | ratio")
    print("---: | ---: | ---: | ---: | ---: | ---: | ---:")
    for level in args.levels:
        m = measure(level, args.instances)
        print(f"{100 * level:g} % | {m['rms_norm']:.3g} % | {m['crb_norm']:.3g} % | "
              f"{m['rms_norm'] / m['crb_norm']:.2f} | {m['median_nore']:.3g} % | "
              f"{m['crb_median']:.3g} % | {m['median_nore'] / m['crb_median']:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
