"""What the vehicle's records allow, over many noise instances (docs/vehicle.md): the NoRE of
each instance's optimum x* (polished from the truth) under each estimator (``objective`` eq3,
ols, ml, ml_profiled) beside the Cramér–Rao bound, for the paper's window and the long record
(``record.extra=0.5``): median NoRE with its quartiles, the CRB NoRE, per parameter the CRB %
and the median |error| of x*. Deterministic (instances 0 .. n-1 of ``noise.seed=0``).
Command: ``python tools/identifiability_floor.py --instances 30``.
"""

from __future__ import annotations

import argparse

import numpy as np
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.analysis.identifiability import cramer_rao
from vpid_bench.analysis.optimum import polish
from vpid_bench.params import build_dataclass

DESIGNS = {"vehicle (0.48 s window)": {},
           "vehicle_long_record (+0.5 s)": {"record": {"extra": 0.5}}}


OBJECTIVES = ("eq3", "ols", "ml", "ml_profiled")


def measure(overrides: dict, instances: int) -> dict:
    """Floor and bounds of one design over ``instances`` noise records."""
    problem = VehicleProblem(build_dataclass(VehicleConfig, overrides, prefix="problem"))
    crb = cramer_rao(problem)
    nores, errors = [], []
    for i in range(instances):
        inst = problem.instance(i)
        x, _ = polish(inst, inst.x_true)
        nores.append(inst.metrics(x)["NoRE"])
        errors.append(np.abs(100 * (x - inst.x_true) / inst.x_true))
    return {"names": crb["names"], "crb": np.asarray(crb["crb_percent"]),
            "crb_nore": crb["crb_norm_percent"], "nore": np.asarray(nores),
            "errors": np.median(errors, axis=0), "condition": crb["condition_number"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--instances", type=int, default=30)
    args = parser.parse_args()
    print(f"command: python tools/identifiability_floor.py --instances {args.instances}")
    for (label, design), objective in ((d, o) for d in DESIGNS.items() for o in OBJECTIVES):
        m = measure({**design, "objective": objective}, args.instances)
        q1, med, q3 = np.percentile(m["nore"], [25, 50, 75])
        print(f"\n{label}, objective={objective}: median NoRE of x* {med:.3g} % "
              f"(IQR {q1:.3g}-{q3:.3g}, "
              f"min {m['nore'].min():.1f}, max {m['nore'].max():.1f}) over {args.instances} "
              f"instances; CRB NoRE {m['crb_nore']:.3g} %; condition number "
              f"{m['condition']:.0f}")
        print("  parameter      " + " ".join(f"{n:>6s}" for n in m["names"]))
        print("  CRB %          " + " ".join(f"{v:6.2f}" for v in m["crb"]))
        print("  median |err| % " + " ".join(f"{v:6.2f}" for v in m["errors"]))


if __name__ == "__main__":
    main()
