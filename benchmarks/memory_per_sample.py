"""Bytes of memory per simulated sample, the figures behind the vehicle's memory cap.

``plugins/vpid_vehicle/config.py`` estimates a job's memory as ``BYTES_PER_STEP`` per time
step plus ``BYTES_PER_SAMPLE_CANDIDATE`` per sample and candidate of a batch. This measures
both with tracemalloc at two record lengths (the difference cancels fixed costs):

    .venv/bin/python benchmarks/memory_per_sample.py
"""

from __future__ import annotations

import tracemalloc

import numpy as np
from vpid_vehicle.config import VehicleConfig
from vpid_vehicle.problem import VehicleProblem

from vpid_bench.params import build_dataclass

PS = 20


def _peak(extra: float) -> tuple[int, int, int]:
    """Samples, peak bytes of the set-up, peak bytes of one residual batch of PS."""
    tracemalloc.start()
    problem = VehicleProblem(build_dataclass(VehicleConfig, {"record": {"extra": extra}}))
    setup = tracemalloc.get_traced_memory()[1]
    tracemalloc.reset_peak()
    X = problem.bounds.sample(np.random.default_rng(0), PS)
    problem.evaluate_with_residuals(X)
    batch = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return problem.t.size, setup, batch


def main() -> None:
    _peak(0.0)  # imports and compiled kernels first: they are not per-sample costs
    n1, s1, b1 = _peak(0.5)
    n2, s2, b2 = _peak(5.5)
    dn = n2 - n1
    print(f"samples {n1} -> {n2}")
    print(f"set-up: {(s2 - s1) / dn:.0f} B per sample (cap assumes 128)")
    print(f"one residual batch of {PS}: {(b2 - b1) / dn / PS:.1f} B per sample and candidate "
          "(cap assumes 16)")


if __name__ == "__main__":
    main()
