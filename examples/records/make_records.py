"""Write the two example records of docs/own-record.md: what a logger on one's own car would
give, at 500 Hz from t = 12.3 s, made here by models whose parameters the fit is not told.

* ``own_halfcar_500hz.csv``: the paper's half car (problem=vehicle) with a heavier body and
  other suspension than the paper's (``CAR`` below) over the paper's bump at 20 km/h, by the
  exact solver (the matrix exponential with the bump's edges where they are), 1.2 s sampled
  at 500 Hz; columns ``t [s], z1dd [m/s^2], z2dd [g]`` (the rear channel in g, as some
  loggers write it).
* ``own_quarter_iso_500hz.csv``: a quarter car (problem=ride_quarter) on an ISO 8608 class C
  road at 60 km/h, by the exact first-order-hold solution, 3 s at 500 Hz; columns ``t [s],
  zsdd [m/s^2], zudd [m/s^2], h [mm]`` (the road under the wheel, which a random road's
  record must carry).

* ``own_quarter_logger_500hz.csv``: a quarter car richer than the fitted one (``LOGGER_CAR``
  below: a progressive spring, 10 % stiffer at 5 cm of stroke, a damper 1.5:1 in rebound
  against compression, a tyre of 210,000 N/m; classical Runge-Kutta at 5 kHz) on an ISO 8608
  class C road at 60 km/h, 12 s at 500 Hz (at 3 s the spring rate's estimate moved by +-3 %
  from road to road), as a logger names its columns: ``time [s],
  body_acc [m/s^2], wheel_acc [g], road [mm]`` (docs/own-record.md's worked example).

All with additive Gaussian noise of 3 % of each channel's rms, from a fixed seed. Run from
the repository: ``.venv/bin/python examples/records/make_records.py`` (rewrites the files).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
G = 9.80665
#: The car behind the half-car record (the paper's: m 505.1, I 651, k1 = k2 15000,
#: c1 = c2 1828, a1 1.468): a loaded body, stiffer front springs, softer rear dampers.
CAR = {"m": 560.0, "I": 700.0, "m1": 30.0, "m2": 52.0, "k1": 16500.0, "k2": 14000.0,
       "c1": 1900.0, "c2": 1650.0, "a1": 1.40}
T0, NOISE, SEED = 12.3, 0.03, 31


def _noisy(y: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return y + NOISE * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(
        y.shape)


def _write(path: Path, header: str, columns: list[np.ndarray]) -> None:
    rows = np.column_stack(columns)
    path.write_text(header + "\n" + "".join(",".join(f"{v:.9g}" for v in r) + "\n"
                                            for r in rows))
    print(f"{path.name}: {rows.shape[0]} rows")


def half_car(rng: np.random.Generator) -> None:
    from vpid_vehicle.config import (
        BumpConfig,
        NoiseConfig,
        RecordConfig,
        VehicleConfig,
        VehicleParams,
    )
    from vpid_vehicle.problem import VehicleProblem

    config = VehicleConfig(vehicle=VehicleParams(**CAR), bump=BumpConfig(),
                           record=RecordConfig(extra=0.72), dt=0.002, integrator="exact",
                           noise=NoiseConfig(level=0.0))
    p = VehicleProblem(config)
    y = _noisy(p.responses(p.x_true[None])[0], rng)
    _write(HERE / "own_halfcar_500hz.csv", "t [s],z1dd [m/s^2],z2dd [g]",
           [T0 + p.t, y[0], y[1] / G])


def quarter_car(rng: np.random.Generator) -> None:
    from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

    p = RideQuarterProblem(RideQuarterConfig(dt=0.002, noise_level=0.0, road="iso8608",
                                             speed_kmh=60.0, seed=SEED))
    print("quarter car's truth (ms, mu, ks, cs):", np.round(p.x_true, 2).tolist())
    y = _noisy(p.clean, rng)
    _write(HERE / "own_quarter_iso_500hz.csv", "t [s],zsdd [m/s^2],zudd [m/s^2],h [mm]",
           [T0 + p.t, y[0], y[1], 1e3 * p.u[:, 0]])


#: The car behind the logger's record: its quarter (kg, kg, N/m, N s/m), its tyre (N/m), the
#: spring's progression (``ks d (1 + p (d / 0.05 m)^2)``) and the damper's asymmetry
#: (``cs (1 +- a) v``, rebound/compression 1.5:1).
LOGGER_CAR = {"ms": 300.0, "mu": 40.0, "ks": 29500.0, "cs": 1700.0, "kt": 210000.0,
              "progression": 0.1, "asymmetry": 0.2}


def _rates(s: np.ndarray, h: float) -> np.ndarray:
    c = LOGGER_CAR
    zs, zu, vs, vu = s
    d, v = zs - zu, vs - vu
    spring = c["ks"] * d * (1 + c["progression"] * (d / 0.05) ** 2)
    damper = c["cs"] * (1 + c["asymmetry"] if v > 0 else 1 - c["asymmetry"]) * v
    return np.array([vs, vu, -(spring + damper) / c["ms"],
                     (spring + damper - c["kt"] * (zu - h)) / c["mu"]])


def logger_quarter(rng: np.random.Generator) -> None:
    from vpid_vehicle.ride.model import Wheel, wheel_inputs
    from vpid_vehicle.ride.quarter import RideQuarterConfig

    fine, sub = 0.0002, 10
    h = wheel_inputs(RideQuarterConfig(road="iso8608", speed_kmh=60.0, duration_s=12.0),
                     (Wheel(0, 0.0),), fine, rng)[:, 0]
    s, y = np.zeros(4), np.empty((h.size, 2))
    for k in range(h.size):  # RK4, the road linear between samples
        r = _rates(s, h[k])
        y[k] = r[2], r[3]
        if k + 1 < h.size:
            hm = 0.5 * (h[k] + h[k + 1])
            k2 = _rates(s + 0.5 * fine * r, hm)
            k3 = _rates(s + 0.5 * fine * k2, hm)
            k4 = _rates(s + fine * k3, h[k + 1])
            s = s + fine / 6 * (r + 2 * k2 + 2 * k3 + k4)
    y = _noisy(y[::sub].T, rng)
    t = T0 + np.arange(y.shape[1]) * fine * sub
    _write(HERE / "own_quarter_logger_500hz.csv",
           "time [s],body_acc [m/s^2],wheel_acc [g],road [mm]",
           [t, y[0], y[1] / G, 1e3 * h[::sub]])


if __name__ == "__main__":
    generator = np.random.default_rng(SEED)
    half_car(generator)
    quarter_car(generator)
    logger_quarter(np.random.default_rng(SEED + 1))
