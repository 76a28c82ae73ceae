"""How large a member's model error is against its noise ``σ_c``: ``python -m
vpid_vehicle.ride.model_error [member ...]`` (docs/suite.md, "Model error"): per instance the
rms of ``(clean_c − fitted_c(θ̂)) / σ_c`` at the fitted model's best fit ``θ̂`` to the clean
record (``ratio``: the misfit no parameter removes), the same at the truth and the NoRE (%)
of ``θ̂``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from vpid_bench import relative_errors_percent


def model_error(problem: Any) -> dict[str, Any]:
    """The model error of one ride or lateral problem instance (see the module)."""
    from scipy.optimize import least_squares

    clean, sigma = problem.clean, problem.sigma
    x_true = problem.x_true
    b = problem.bounds
    scale = np.abs(x_true)

    def whitened(z: np.ndarray) -> np.ndarray:
        fitted = problem.responses((z * scale)[None])[0]
        r = ((clean - fitted) / sigma[:, None]).reshape(-1)
        return np.where(np.isfinite(r), r, 1e6)

    z0 = np.ones(x_true.size)
    fit = least_squares(whitened, z0, bounds=(b.lower / scale, b.upper / scale),
                        x_scale=1.0, xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    x_fit = fit.x * scale

    def rms(z: np.ndarray) -> float:
        return float(np.sqrt(np.mean(whitened(z) ** 2)))

    return {"ratio": rms(fit.x), "ratio_at_truth": rms(z0),
            "bias_nore": float(np.linalg.norm(relative_errors_percent(x_fit, x_true))),
            "x_fit": x_fit.tolist(), "noise_level": float(problem.config.noise_level)}


def members_with_model_error() -> list[type]:
    """The ``vpid1`` members whose record comes from a richer model."""
    from .suites import MEMBERS

    return [m for m in MEMBERS if "vpid1" in m.suites
            and getattr(m.Config(), "record_model", "linear") != "linear"]


#: Instances whose at-fit ratio the command prints (each has its own truth).
INSTANCES = 5
#: Each model-error member's ratios per archived instance (``--write``; the report reads it).
RATIOS_FILE = Path(__file__).with_name("model_error_ratios.json")
#: Instances of the file (the vpid1 archive's).
FILE_INSTANCES = 15


def ratios(instances: int = FILE_INSTANCES) -> dict[str, Any]:
    """Per model-error member: the ratios of its first ``instances``, its seed and fit."""
    from .richer import FIT_WITH

    out: dict[str, Any] = {}
    for cls in members_with_model_error():
        p = cls(cls.Config())
        fits = [model_error(p.instance(i)) for i in range(instances)]
        out[cls.name] = {"seed": int(p.config.seed),
                         "record_model": p.config.record_model,
                         "fit_with": FIT_WITH.get(p.config.record_model),
                         "ratio_at_fit": [round(f["ratio"], 4) for f in fits],
                         "ratio_at_truth": [round(f["ratio_at_truth"], 4) for f in fits]}
    return out


def read_ratios() -> dict[str, Any]:
    """The shipped :data:`RATIOS_FILE` (empty when absent)."""
    if not RATIOS_FILE.is_file():
        return {}
    return json.loads(RATIOS_FILE.read_text(encoding="utf-8"))


def main(argv: list[str] | None = None) -> int:
    """Print each member's model error (all model-error members by default)."""
    from .richer import FIT_WITH
    from .suites import MEMBERS

    names = list(sys.argv[1:] if argv is None else argv)
    if names == ["--write"]:
        RATIOS_FILE.write_text(json.dumps(ratios(), indent=1, sort_keys=True) + "\n",
                               encoding="utf-8")
        print(f"wrote {RATIOS_FILE}")
        return 0
    by_name = {m.name: m for m in MEMBERS}
    unknown = [n for n in names if n not in by_name]
    if unknown:
        print(f"error: no suite member {unknown[0]!r}; allowed: {', '.join(sorted(by_name))}",
              file=sys.stderr)
        return 2
    members = [by_name[n] for n in names] if names else members_with_model_error()
    print("member | record model | noise level | model error / noise (at the fit) | "
          "at the truth | NoRE of the noise-free fit (%) | at the fit, instances 0-"
          f"{INSTANCES - 1} | fitted with it by")
    for cls in members:
        p = cls(cls.Config())
        out = model_error(p)
        per = [out["ratio"]] + [model_error(p.instance(i))["ratio"]
                                for i in range(1, INSTANCES)]
        record_model = getattr(p.config, "record_model", "linear")
        print(f"{cls.name} | {record_model} | "
              f"{out['noise_level']:g} | {out['ratio']:.3g} | {out['ratio_at_truth']:.3g} | "
              f"{out['bias_nore']:.3g} | {', '.join(f'{r:.3g}' for r in per)} | "
              f"{FIT_WITH.get(record_model) or 'none in the suite'}")
    return 0


if __name__ == "__main__":  # pragma: no cover - the command
    raise SystemExit(main())
