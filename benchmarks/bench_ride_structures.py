"""The linear ride kernel's time per evaluation beside the previous code path, and the richer
suspension structures' (issue 43), side by side.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_ride_structures.py \\
        [--previous /work/main] [--rounds 5]

For the quarter, half and full car (3 s records at dt = 1 ms, hump road) it times
``problem.evaluate`` on the same 20 rows drawn in the linear box:

* ``previous``: the linear structure in the checkout ``--previous`` (the code before the
  structures were added; its own ``.venv/bin/python``);
* ``linear``: the linear structure in this checkout (the same Newmark kernel, now reached
  through :func:`vpid_vehicle.ride.structures.structured`);
* ``cubic+bilinear``: the richest structure (RK4, :mod:`vpid_vehicle.ride.structures`).

Each is measured in its own process (compiled code warmed first), the rounds interleaved so a
load change on the machine meets every path alike. Prints the best (least) microseconds per
candidate over 15 evaluations in each of the rounds (on a loaded machine the least time is
the code's, a median the load's) and the ratio of ``linear`` to ``previous``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

SNIPPET = r"""
import json, sys, time
import numpy as np
from vpid_vehicle.ride.quarter import RideQuarterProblem
from vpid_vehicle.ride.half import RideHalfProblem
from vpid_vehicle.ride.full import RideFullProblem
structure = sys.argv[1]
out = {}
for P in (RideQuarterProblem, RideHalfProblem, RideFullProblem):
    kw = {} if structure == "linear" else {"spring": "cubic", "damper": "bilinear"}
    p = P(P.Config(**kw))
    b = p.bounds
    X = b.lower + (b.upper - b.lower) * np.random.default_rng(1).uniform(0.1, 0.9,
                                                                          (20, b.lower.size))
    p.evaluate(X)
    times = []
    for _ in range(15):
        t = time.perf_counter()
        p.evaluate(X)
        times.append(time.perf_counter() - t)
    out[P.name] = 1e6 * float(np.min(times)) / X.shape[0]
print(json.dumps(out))
"""


def measure(python: Path, cwd: Path, structure: str) -> dict[str, float]:
    """Microseconds per candidate of each family, in a process of ``python``."""
    done = subprocess.run([str(python), "-c", SNIPPET, structure], cwd=cwd, check=True,
                          capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--previous", type=Path, default=Path("/work/main"),
                    help="a checkout of the code before the structures (its .venv)")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args(argv)
    here = Path(__file__).resolve().parents[1]
    paths = {"previous": (args.previous / ".venv/bin/python", args.previous, "linear"),
             "linear": (here / ".venv/bin/python", here, "linear"),
             "cubic+bilinear": (here / ".venv/bin/python", here, "rich")}
    runs: dict[str, list[dict[str, float]]] = {k: [] for k in paths}
    for _ in range(args.rounds):
        for key, (python, cwd, structure) in paths.items():
            runs[key].append(measure(python, cwd, structure))
    families = list(runs["linear"][0])
    print("family | previous (us/cand) | linear (us/cand) | linear / previous | "
          "cubic+bilinear (us/cand)")
    for fam in families:
        med = {k: min(r[fam] for r in v) for k, v in runs.items()}
        print(f"{fam} | {med['previous']:.1f} | {med['linear']:.1f} | "
              f"{med['linear'] / med['previous']:.3f} | {med['cubic+bilinear']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
