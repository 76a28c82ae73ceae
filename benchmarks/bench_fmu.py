"""Speed of ``problem=fmu``: one simulation of the example quarter-car FMU (FMI 2.0
co-simulation, the input's slope given each step) three ways, side by side in one run:
``project``, ``FmuProblem.evaluate`` of one candidate (reset, start values, initialise, the
compiled step loop of :mod:`vpid_fmu.kernels`, residuals, objective); ``C loop``,
``benchmarks/fmu_c_loop.c`` compiled here with gcc, driving the same binary through the same
calls (timed inside C: no process start); ``fmpy``, fmpy's ``simulate_fmu`` on the FMU
extracted once (its Python loop over steps). Needs gcc and fmpy.

    MPLBACKEND=Agg .venv/bin/python benchmarks/bench_fmu.py [--rounds 5] [--reps 20] \\
        [--samples 5000]

Interleaved rounds; the median over rounds (project and C: of ``--reps`` simulations each).
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
import zipfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
X = np.array([280.0, 33.0, 17000.0, 1300.0])



def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--samples", type=int, default=5000)
    args = ap.parse_args()
    import fmpy
    from vpid_fmu import example
    from vpid_fmu.problem import FmuConfig, FmuProblem

    from vpid_bench.params import build_dataclass

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        fmu = example.build(folder / "quarter_car.fmu")
        dt = 1 / 500
        t = np.arange(args.samples) * dt
        h = example.road(t)
        record = folder / "record.csv"
        ones = np.ones_like(t)
        np.savetxt(record, np.column_stack([t, h, ones, ones]), delimiter=",",
                   header="t,h,zsdd,zudd", comments="", fmt="%.17g")
        problem = FmuProblem(build_dataclass(FmuConfig, {
            "fmu": str(fmu), "reference": {"file": str(record)}}, "problem"))
        problem.evaluate(X[None])  # compile (or load the cache) and instantiate
        exe = folder / "fmu_c_loop"  # the C loop, compiled here
        subprocess.run([example.compiler() or "gcc", "-O2", f"-I{example.fmi_headers()}",
                        str(HERE / "fmu_c_loop.c"), "-o", str(exe), "-ldl"], check=True)
        (folder / "h.bin").write_bytes(h.astype("<f8").tobytes())
        lib = folder / "lib" / "quarter_car.so"
        lib.parent.mkdir()
        with zipfile.ZipFile(fmu) as z:
            lib.write_bytes(z.read("binaries/linux64/quarter_car.so"))
        unzipped = fmpy.extract(str(fmu), str(folder / "fmpy"))
        md = fmpy.read_model_description(unzipped)
        signal = np.zeros(t.size, dtype=[("time", float), ("h", float)])
        signal["time"], signal["h"] = t, h
        start = dict(zip(("ms", "mu", "ks", "cs"), X))
        times: dict[str, list[float]] = {"project": [], "C loop": [], "fmpy": []}
        for _ in range(args.rounds):
            one = []
            for _ in range(args.reps):
                t0 = time.perf_counter()
                problem.evaluate(X[None])
                one.append(time.perf_counter() - t0)
            times["project"].append(statistics.median(one))
            out = subprocess.run([str(exe), str(lib), example.GUID, str(folder / "h.bin"),
                                  str(t.size), repr(dt), str(args.reps), "5", "6", "7"],
                                 capture_output=True, text=True, check=True).stdout.split()
            times["C loop"].append(float(out[0]))
            t0 = time.perf_counter()
            fmpy.simulate_fmu(unzipped, model_description=md, start_values=start,
                              input=signal, output_interval=dt, stop_time=t[-1],
                              output=["zsdd", "zudd"], set_stop_time=True)
            times["fmpy"].append(time.perf_counter() - t0)
        c = statistics.median(times["C loop"])
        print(f"one simulation of the example quarter-car FMU, {t.size} samples at 500 Hz "
              f"(FMI 2.0 co-simulation), median of {args.rounds} interleaved rounds:")
        print(f"{'way':<10} {'ms':>9} {'x C loop':>9}")
        for name, values in times.items():
            m = statistics.median(values)
            print(f"{name:<10} {1e3 * m:9.3f} {m / c:9.2f}")


if __name__ == "__main__":
    main()
