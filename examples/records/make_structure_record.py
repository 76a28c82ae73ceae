"""Write the record of docs/own-record.md, "Which structure does my record support?": a
quarter car whose spring is progressive (a cubic term) and whose damper is stiffer in rebound
than in bump, as a logger would give it, at 1 kHz from t = 0.

``own_quarter_progressive_1khz.csv``: ``problem=ride_quarter`` with ``spring=cubic
damper=bilinear`` (its truth drawn from ``SEED``, printed), on an ISO 8608 class D road at
60 km/h, 6 s by RK4 at 0.1 ms (the structure's record), sampled at 1 kHz; additive Gaussian
noise of 3 % of each channel's rms; columns ``t [s], zsdd [m/s^2], zudd [m/s^2], h [mm]``.
(At 1 kHz the road needs no interpolation onto the model's 1 ms steps; a 500 Hz version of
this record put two of the six generating values, ``ms`` and ``cs_rebound``, just outside
their 95 % intervals: the road's height interpolated linearly, and its rate by differences,
are an input error of their own.)
Run from the repository: ``.venv/bin/python examples/records/make_structure_record.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
NOISE, SEED = 0.03, 43


def main() -> None:
    from vpid_vehicle.ride.quarter import RideQuarterConfig, RideQuarterProblem

    p = RideQuarterProblem(RideQuarterConfig(
        spring="cubic", damper="bilinear", noise_level=0.0, road="iso8608", road_class="D",
        speed_kmh=60.0, duration_s=6.0, seed=SEED))
    print("truth:", {n: round(float(v), 2) for n, v in zip(p.model.names, p.x_true,
                                                          strict=True)})
    keep = slice(None)  # every sample of the model's 1 ms grid
    y = p.clean[:, keep]
    rng = np.random.default_rng(SEED)
    y = y + NOISE * np.sqrt(np.mean(y**2, axis=1, keepdims=True)) * rng.standard_normal(
        y.shape)
    rows = np.column_stack([p.t[keep], y[0], y[1], 1e3 * p.u[keep, 0]])
    path = HERE / "own_quarter_progressive_1khz.csv"
    path.write_text("t [s],zsdd [m/s^2],zudd [m/s^2],h [mm]\n" + "".join(
        ",".join(f"{v:.9g}" for v in r) + "\n" for r in rows))
    print(f"{path.name}: {rows.shape[0]} rows")


if __name__ == "__main__":
    main()
