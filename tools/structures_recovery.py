"""The ``structures`` suite's members: the richer structure recovers the truth of the record
it made, where the linear model fitted to the same record cannot (issue 43; docs/suite.md).

    MPLBACKEND=Agg .venv/bin/python tools/structures_recovery.py [--instances 3]

Per member and instance: the NoRE (%) of the richer structure's optimum of its own record, and
that of the linear model fitted to the same record (written as a file) against the truth's
linear part (:func:`linear_part`).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np
from vpid_vehicle.record_file import column_name
from vpid_vehicle.ride.problem import RecordFileConfig
from vpid_vehicle.ride.suites import MEMBERS

from vpid_bench import relative_errors_percent
from vpid_bench.analysis.optimum import polish


def linear_part(model, x: np.ndarray) -> np.ndarray:
    """The linear model's parameters of a structured row: no cubic term, the damper mean."""
    col = dict(zip(model.names, x, strict=True))
    out = []
    for name in model.base.names:
        if f"{name}_bump" in col:
            out.append(0.5 * (col[f"{name}_bump"] + col[f"{name}_rebound"]))
        else:
            out.append(col[name])
    return np.array(out)


def write_record(path: Path, p) -> None:
    cols = {"t": p.t}
    for w, name in enumerate(p.model.wheel_names):
        cols[name] = p.u[:, w]
    for c, (name, _) in enumerate(p.channels):
        cols[column_name(name)] = p.measured[c]
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(list(cols))
        out.writerows(np.column_stack(list(cols.values())))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--instances", type=int, default=3)
    args = ap.parse_args(argv)
    print("member | instance | richer structure's optimum, NoRE (%) | linear model's optimum "
          "on the same record, NoRE (%)")
    with tempfile.TemporaryDirectory() as tmp:
        for cls in (m for m in MEMBERS if "structures" in m.suites):
            for i in range(args.instances):
                p = cls(cls.Config()).instance(i)
                rich = p.metrics(polish(p, p.x_true)[0])["NoRE"]
                path = Path(tmp) / f"{cls.name}_{i}.csv"
                write_record(path, p)
                lin_cfg = dataclasses.replace(p.config, spring="linear", damper="linear",
                                              reference=RecordFileConfig(str(path)))
                lp = type(p)(lin_cfg)
                truth = linear_part(p.model, p.x_true)
                start = np.clip(truth, lp.bounds.lower, lp.bounds.upper)
                x_lin = polish(lp, start)[0]
                lin = float(np.linalg.norm(relative_errors_percent(x_lin, truth)))
                print(f"{cls.name} | {i} | {rich:.3g} | {lin:.3g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
