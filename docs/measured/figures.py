"""The figures of docs/measured.md: measured against simulated signals on each problem's
validation record, for the best run of a sweep of the documented command.

    .venv/bin/python docs/measured/figures.py emps <sweep folder>
    .venv/bin/python docs/measured/figures.py bayesrace <sweep folder>
    .venv/bin/python docs/measured/figures.py racecar <sweep folder>

reads every run record under the sweep folder, takes the run with the lowest objective,
rebuilds the problem from that record's configuration and draws its validation record
(``docs/measured/<problem>_validation.png``) beside the problem's comparison points. Nothing
is fitted here: the identified vector is the command's. For ``bayesrace`` it also prints the
95 % intervals at that vector (Jacobian with sigma from the residuals, and profile
likelihood; the framework computes them for problems without a truth only).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent


def best_record(sweep: Path, problem: str) -> dict:
    """The ok run record of ``problem`` with the lowest ``f_best`` under ``sweep``."""
    best = None
    for path in sorted(sweep.glob("**/records/run-*.json")):
        rec = json.loads(path.read_text(encoding="utf-8"))
        res = rec.get("result") or {}
        if rec.get("status") != "ok" or (rec.get("problem") or {}).get("name") != problem:
            continue
        f = res.get("f_best")
        if f is not None and math.isfinite(f) and (best is None or f < best["result"]["f_best"]):
            best = rec
    if best is None:
        raise SystemExit(f"error: no ok run of problem={problem} under {sweep}")
    return best


def emps_figure(sweep: Path) -> Path:
    """The pulses record: tracking error (reference minus position) and voltage, measured
    against simulated by the sweep's best vector and by the published estimate, and the
    position's residual of each."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from vpid_emps.problem import PUBLISHED, EmpsConfig, EmpsProblem

    rec = best_record(sweep, "emps")
    problem = EmpsProblem(_config(rec, EmpsConfig))
    x = np.asarray(rec["result"]["x_best"], dtype=float)
    val = problem.validation
    r = val.record
    q_ours, u_ours = val.simulate(x[None])
    q_pub, u_pub = val.simulate(PUBLISHED[None])
    fig, axes = plt.subplots(3, 1, figsize=(9, 8.5), sharex=True)
    um = 1e6
    ax = axes[0]
    ax.plot(r.t, um * (r.qg - r.qm), color="0.3", lw=0.8, label="measured")
    ax.plot(r.t, um * (r.qg - q_ours[0]), color="C3", lw=0.8, ls="--",
            label=f"simulated, {rec['optimizer']['name']}'s best")
    ax.plot(r.t, um * (r.qg - q_pub[0]), color="C0", lw=0.8, ls=":",
            label="simulated, published estimate")
    ax.set_ylabel("tracking error\nqg - q (µm)")
    ax.legend(fontsize=8, ncol=3, loc="upper center")
    ax = axes[1]
    ax.plot(r.t, r.vir, color="0.3", lw=0.8, label="logged")
    ax.plot(r.t, u_ours[0], color="C3", lw=0.8, ls="--", label="simulated (ours)")
    ax.set_ylabel("motor voltage u (V)")
    ax = axes[2]
    m_ours, m_pub = problem.metrics(x), problem.metrics(PUBLISHED)
    ax.plot(r.t, um * (r.qm - q_ours[0]), color="C3", lw=0.8,
            label=f"ours: rms {m_ours['val_rms_um']:.3f} µm, "
                  f"fit {100 - m_ours['val_unexplained_pct']:.4f} %")
    ax.plot(r.t, um * (r.qm - q_pub[0]), color="C0", lw=0.8, alpha=0.7,
            label=f"published: rms {m_pub['val_rms_um']:.3f} µm, "
                  f"fit {100 - m_pub['val_unexplained_pct']:.4f} %")
    ax.set_ylabel("position residual\nqm - q (µm)")
    ax.set_xlabel("time t (s)")
    ax.legend(fontsize=8, loc="upper center", ncol=2)
    for a in axes:
        a.grid(alpha=0.3)
    fig.suptitle(f"EMPS, validation record ({r.name}): measured against simulated in the "
                 "closed loop", fontsize=10)
    fig.tight_layout()
    out = HERE / "emps_validation.png"
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def _config(rec: dict, cls: type) -> object:
    import dataclasses

    names = {f.name for f in dataclasses.fields(cls)}
    return cls(**{k: v for k, v in rec["problem"]["config"].items() if k in names})


def bayesrace_figure(sweep: Path) -> Path:
    """The held-out track: logged (the simulator's Euler) against our continuous model with
    the best run's coefficients and with the simulator's own; then the intervals (stdout)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from vpid_vehicle.ride.bayesrace import CHANNELS, BayesraceConfig, BayesraceProblem

    from vpid_bench.analysis.intervals import group_sigma, jacobian_intervals
    from vpid_bench.analysis.profile import profile_intervals

    rec = best_record(sweep, "bayesrace")
    problem = BayesraceProblem(_config(rec, BayesraceConfig))
    x = np.asarray(rec["result"]["x_best"], dtype=float)
    held = problem.held_out
    ours, truth = held.simulate(x[None])[0], held.simulate(problem.x_true[None])[0]
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    t = held.record.t
    for c, (name, unit) in enumerate(CHANNELS):
        ax = axes[c]
        ax.plot(t, held.record.states[c], color="0.3", lw=0.8, label="record (simulator's "
                "explicit Euler, 50 Hz)")
        ax.plot(t, truth[c], color="C0", lw=0.9, ls=":", label="our model, simulator's "
                "coefficients")
        ax.plot(t, ours[c], color="C3", lw=0.9, ls="--",
                label=f"our model, {rec['optimizer']['name']}'s best fit")
        ax.set_ylabel(f"{name} ({unit})")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, ncol=3, loc="upper center")
    axes[-1].set_xlabel("time t (s)")
    fig.suptitle(f"Bayesrace, held-out track ({held.record.name}): the record against our "
                 "continuous-time model", fontsize=10)
    fig.tight_layout()
    out = HERE / "bayesrace_validation.png"
    fig.savefig(out, dpi=110)
    plt.close(fig)
    jac = jacobian_intervals(problem, x)
    r = problem.fisher_residuals(x[None])[0]
    sigma = group_sigma(r, problem.fisher_groups(), x.size)
    rel = np.array([np.inf if v is None else v for v in jac["se"]]) / np.abs(x)
    prof = profile_intervals(problem, start=x, sigma=sigma, rel_sd=rel)
    print("| coefficient | simulator | identified | 95 % (Jacobian) | 95 % (profile) | "
          "profile says |")
    print("| --- | ---: | ---: | --- | --- | --- |")
    for j, name in enumerate(problem.bounds.names):
        def fmt(v: float | None) -> str:
            return "open" if v is None else f"{v:.4g}"

        print(f"| {name} | {problem.x_true[j]:.4g} | {x[j]:.4g} | [{fmt(jac['lower'][j])}, "
              f"{fmt(jac['upper'][j])}] | [{fmt(prof['lower'][j])}, {fmt(prof['upper'][j])}] "
              f"| {prof['classification'][j]} |")
    return out


def racecar_figure(sweep: Path) -> Path:
    """Sixty seconds of the held-out windows: logged yaw rate and lateral velocity against
    the best run's prediction and the naive predictor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from vpid_vehicle.ride.racecar import CHANNELS, RacecarConfig, RacecarProblem

    rec = best_record(sweep, "racecar")
    problem = RacecarProblem(_config(rec, RacecarConfig))
    x = np.asarray(rec["result"]["x_best"], dtype=float)
    w = problem.held_out
    pred, naive = problem._predict(x, w)[0], w.naive()
    keep = w.t[:, 0] < w.t[0, 0] + 60.0
    fig, axes = plt.subplots(2, 1, figsize=(9, 6.5), sharex=True)
    for c, (name, unit) in enumerate(CHANNELS):
        ax = axes[c]
        for j in np.flatnonzero(keep):
            first = j == np.flatnonzero(keep)[0]
            ax.plot(w.t[j], w.measured[j, :, c], color="0.3", lw=0.9,
                    label="logged" if first else None)
            ax.plot(w.t[j], pred[j, :, c], color="C3", lw=0.9, ls="--",
                    label=f"predicted, {rec['optimizer']['name']}'s best" if first else None)
            ax.plot(w.t[j], naive[j, :, c], color="C0", lw=0.8, ls=":",
                    label="naive (held)" if first else None)
        ax.set_ylabel(f"{name} ({unit})")
        ax.grid(alpha=0.3)
    m = problem.metrics(x)
    axes[0].legend(fontsize=8, ncol=3, loc="upper center")
    axes[-1].set_xlabel("time in the log t (s)")
    fig.suptitle(f"racecar ({problem.config.tyres} tyres), held-out {w.name}: "
                 f"{problem.fitted.H}-sample windows from the logged state; model rms over "
                 f"naive {m['val_rel_naive']:.2f}", fontsize=10)
    fig.tight_layout()
    out = HERE / "racecar_validation.png"
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


FIGURES = {"emps": emps_figure, "bayesrace": bayesrace_figure, "racecar": racecar_figure}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("problem", choices=sorted(FIGURES))
    parser.add_argument("sweep", type=Path, help="the sweep folder of the documented command")
    args = parser.parse_args()
    print(FIGURES[args.problem](args.sweep))


if __name__ == "__main__":
    main()
