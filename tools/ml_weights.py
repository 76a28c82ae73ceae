"""Why ``objective=ml`` takes each sample's σ from its neighbours: three ways of weighing the
paper's records under their multiplicative noise, side by side (docs/estimators.md).

``leave_one_out`` (``ml`` as built, :func:`vpid_bench.estimators.plug_in_sigma`);
``own_sample`` (``σ_k = level × |y_k|`` from the noisy sample, the rule before round four);
``exact_likelihood`` (``σ_k(θ) = level × |g_k(θ)|`` from the prediction, with the
``Σ log σ_k(θ)`` term). For each, over instances 0 .. n-1 of ``problem=vehicle`` (or a record
made by the exact solution, ``--exact-record``), the errors of the optimum polished from the
truth and (``--lsq K``) ``lsq``'s gap to it from random starts on the first K instances.
Deterministic. Command: ``python tools/ml_weights.py --instances 30 --lsq 5``.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from vpid_peers.lsq import LeastSquares, LSQParams
from vpid_vehicle.config import PARAM_NAMES, VehicleConfig
from vpid_vehicle.problem import VehicleProblem

from vpid_bench import estimators
from vpid_bench.analysis.optimum import polish
from vpid_bench.problem import default_budget
from vpid_bench.runner import run

RULES = ("leave_one_out", "own_sample", "exact_likelihood")


def problem_class(rule: str) -> type:
    """The paper's problem under ``objective=ml`` with ``rule``'s weights."""
    class Weighed(VehicleProblem):
        def _weighting(self) -> np.ndarray:
            if "_weights" not in self.__dict__:
                y, level = self.reference, self.config.noise.level
                rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
                floor = estimators.SIGMA_FLOOR * level * rms
                if rule == "own_sample":
                    self._weights = 1.0 / np.maximum(level * np.abs(y), floor)
                else:
                    self._weights = 1.0 / estimators.plug_in_sigma(y, level, "multiplicative")
            return self._weights

        def evaluate_with_residuals(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            if rule != "exact_likelihood":
                return super().evaluate_with_residuals(X)
            return exact_likelihood(self, X)

    return Weighed


def exact_likelihood(problem, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``f`` = the negative log-likelihood per sample of the multiplicative model with σ from
    the prediction, less its value's constant part (``log`` of the record's σ), and residuals
    whose sum of squares is ``2 M f``."""
    y, level = problem.reference, problem.config.noise.level
    rms = np.sqrt(np.mean(y**2, axis=1, keepdims=True))
    floor = estimators.SIGMA_FLOOR * level * rms
    keep = np.abs(y) > 1e-12 * np.abs(y).max(axis=1, keepdims=True)
    ref = np.sqrt((level * y) ** 2 + floor**2)
    g = problem.responses(np.atleast_2d(X))
    with np.errstate(all="ignore"):
        sig = np.sqrt((level * g) ** 2 + floor[None] ** 2)
        r = np.where(keep, (y[None] - g) / sig, 0.0)
        M = int(keep.sum())
        S = np.sum(r**2, axis=(1, 2))
        f = (0.5 * S + np.sum(np.where(keep, np.log(sig / ref), 0.0), axis=(1, 2))) / M
        R = r * np.sqrt(np.maximum(2 * M * f, 0.0) / S)[:, None, None]
    R = R.reshape(R.shape[0], -1)
    bad = ~(np.isfinite(f) & np.all(np.isfinite(R), axis=1))
    f[bad], R[bad] = np.inf, np.inf
    return f, R


def measure(rule: str, instances: int, lsq: int, exact: bool) -> dict:
    cfg = VehicleConfig(objective="ml")
    if exact:
        cfg = dataclasses.replace(cfg, reference=dataclasses.replace(cfg.reference,
                                                                     integrator="exact"))
    problem = problem_class(rule)(cfg)
    errors, gaps = [], []
    budget = default_budget(cfg.ps, cfg.iterations)
    for i in range(instances):
        inst = problem.instance(i)
        inst.__dict__.pop("_weights", None)
        x_opt, f_opt = polish(inst, inst.x_true)
        errors.append(100 * (x_opt - inst.x_true) / inst.x_true)
        if i < lsq:
            rng = np.random.default_rng(np.random.SeedSequence(0, spawn_key=(i,)))
            res = run(inst, LeastSquares(LSQParams(budget=budget), inst.bounds, rng), budget)
            gaps.append((res.f_best - f_opt) / abs(f_opt))
    e = np.asarray(errors)
    se = e.std(axis=0, ddof=1) / np.sqrt(len(e))
    return {"median_nore": float(np.median(np.linalg.norm(e, axis=1))),
            "rms_norm": float(np.linalg.norm(np.sqrt(np.mean(e**2, axis=0)))),
            "mean_over_se": e.mean(axis=0) / se, "mean": e.mean(axis=0),
            "lsq_gap": float(np.median(gaps)) if gaps else None}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--instances", type=int, default=30)
    parser.add_argument("--lsq", type=int, default=5)
    parser.add_argument("--exact-record", action="store_true")
    args = parser.parse_args()
    print(f"command: python tools/ml_weights.py --instances {args.instances} "
          f"--lsq {args.lsq}" + (" --exact-record" if args.exact_record else ""))
    print("             " + " ".join(f"{n:>6s}" for n in PARAM_NAMES))
    for rule in RULES:
        m = measure(rule, args.instances, args.lsq, args.exact_record)
        gap = ("" if m["lsq_gap"] is None
               else f"; lsq from random starts: median gap {m['lsq_gap']:.3g}")
        print(f"{rule}: median NoRE of the optimum {m['median_nore']:.3g} %, norm of the rms "
              f"errors {m['rms_norm']:.3g} %{gap}")
        print("  mean err %  " + " ".join(f"{v:6.3f}" for v in m["mean"]))
        print("  mean / se   " + " ".join(f"{v:6.2f}" for v in m["mean_over_se"]))


if __name__ == "__main__":
    main()
