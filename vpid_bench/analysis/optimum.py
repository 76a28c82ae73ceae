"""Each instance's attainable optimum: the lowest objective value its record allows.

On a noisy record the objective's minimum is not at the true parameters; how well an
optimizer *searches* is judged against that minimum ``f*`` (the gap ``f_best - f*``), and how
well the record *identifies* the parameters by where the minimum ``x*`` lies.

:func:`polish` is a deterministic local minimisation of a sum of residual-group norms
(Eq. 3 of the vehicle, a least-squares sum for one group) by iteratively reweighted least
squares: each round weights group ``g`` by ``1 / ||r_g||`` at the current point and solves
the weighted least-squares problem with scipy's trust-region reflective method inside the
box; the fixed point is a stationary point of the sum of norms. It never returns a point
worse than where it started.

:func:`update_instance_optimum` keeps one JSON file per instance in an ``optima`` folder
shared by the jobs of a sweep: the polish from the truth is done once, and again from the best
vector of any run that ends near or below the optimum known so far, keeping the lowest.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..api import Problem
from ..records.io import stable_hash, write_json_atomic

#: A run whose best is within this factor of the known optimum is polished too: it may sit in
#: another basin whose minimum is lower.
POLISH_NEAR = 1.01
SCHEMA = "vpid-bench/instance-optimum/1"


def _f_of(problem: Problem, x: np.ndarray) -> float:
    return float(problem.evaluate(np.asarray(x, dtype=float)[None])[0])


def polish(problem: Problem, x0: np.ndarray, rounds: int = 30, tol: float = 1e-13
           ) -> tuple[np.ndarray, float]:
    """A local minimum of ``problem`` near ``x0`` (physical units) and its objective value,
    by IRLS on the residual groups (see the module). Never worse than ``x0``."""
    from scipy.optimize import least_squares

    b = problem.bounds
    groups = np.asarray(problem.residual_groups(), dtype=int)
    x = np.clip(np.asarray(x0, dtype=float), b.lower, b.upper)
    f = _f_of(problem, x)
    best_x, best_f = x.copy(), f
    scale = np.abs(problem.x_true) if problem.x_true is not None else b.width
    scale = np.where(scale > 0, scale, b.width)  # work in units of the true values
    lo, hi = b.lower / scale, b.upper / scale
    for _ in range(rounds):
        r = problem.residuals(x[None])[0]
        if not np.all(np.isfinite(r)):
            break
        norms = np.array([np.linalg.norm(r[groups == g]) for g in range(groups.max() + 1)])
        w = 1.0 / np.sqrt(np.maximum(norms, 1e-300))[groups]  # squared: 1/||r_g|| per entry

        def weighted(z: np.ndarray, w: np.ndarray = w) -> np.ndarray:
            return _weighted_rows(problem, z[None], scale, w)[0]

        def jacobian(z: np.ndarray, w: np.ndarray = w) -> np.ndarray:
            return _forward_jacobian(problem, z, scale, w, lo, hi)

        sol = least_squares(weighted, x / scale, jac=jacobian, bounds=(lo, hi),
                            method="trf", x_scale=1.0, xtol=1e-15, ftol=1e-15, gtol=1e-15,
                            max_nfev=200)
        x_new = np.clip(sol.x * scale, b.lower, b.upper)
        f_new = _f_of(problem, x_new)
        if f_new < best_f:
            improvement = best_f - f_new
            best_x, best_f = x_new.copy(), f_new
            x = x_new
            if improvement <= tol * max(abs(best_f), 1e-300):
                break
        else:
            break
    return best_x, best_f


def _weighted_rows(problem: Problem, Z: np.ndarray, scale: np.ndarray,
                   w: np.ndarray) -> np.ndarray:
    """Weighted residuals of the rows of ``Z`` (in units of ``scale``), non-finite entries
    replaced by a huge value, ``(n, m)``."""
    res = np.asarray(problem.residuals(Z * scale), dtype=float)
    return np.where(np.isfinite(res), res, 1e150) * w


def _forward_jacobian(problem: Problem, z: np.ndarray, scale: np.ndarray, w: np.ndarray,
                      lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Forward differences of the weighted residuals at ``z``, ``(m, dim)``, all ``dim + 1``
    points in one batched ``residuals`` call (a step ``sqrt(eps) max(1, |z_i|)``, as scipy's
    ``2-point``, taken backwards where a forward step would leave the box)."""
    h = np.sqrt(np.finfo(float).eps) * np.maximum(1.0, np.abs(z))
    h = np.where(z + h > hi, -h, h)
    h = np.where((z + h < lo) | (z + h > hi), 0.5 * (hi - lo) - np.abs(z - 0.5 * (lo + hi)), h)
    Z = np.repeat(z[None], z.size + 1, axis=0)
    Z[np.arange(1, z.size + 1), np.arange(z.size)] += h
    h = Z[np.arange(1, z.size + 1), np.arange(z.size)] - z  # the steps actually taken
    R = _weighted_rows(problem, Z, scale, w)
    return ((R[1:] - R[0]) / h[:, None]).T


#: The polish from the truth of the instances met in this process: a pure function of the
#: instance, so the jobs of a sweep that share an instance (every optimizer, every population
#: size) polish it once per process even when each job keeps its own optima
#: folder. Bounded; results are the same with or without it.
_TRUTH_POLISH: dict[str, tuple[np.ndarray, float]] = {}
_TRUTH_POLISH_SIZE = 64


def _polish_from_truth(problem: Problem, settings: Mapping[str, Any]
                       ) -> tuple[np.ndarray, float]:
    """:func:`polish` from the truth, memoised by the instance without the protocol keys
    (``ps``, ``iterations``: they change the runs, not the record)."""
    key = instance_key(problem, {k: v for k, v in settings.items()
                                 if k not in ("ps", "iterations")})
    if key not in _TRUTH_POLISH:
        if len(_TRUTH_POLISH) >= _TRUTH_POLISH_SIZE:
            _TRUTH_POLISH.pop(next(iter(_TRUTH_POLISH)))
        _TRUTH_POLISH[key] = polish(problem, problem.x_true)
    x, f = _TRUTH_POLISH[key]
    return x.copy(), f


def instance_key(problem: Problem, settings: Mapping[str, Any]) -> str:
    """The file stem of an instance's optimum: a hash of everything that defines its record
    (the problem's name and settings, its data digest, the instance's id)."""
    return stable_hash({"problem": problem.name, "settings": dict(settings),
                        "data": problem.content_digest(), "instance": problem.instance_id()})


def read_optimum(path: Path) -> dict[str, Any] | None:
    """An optimum file, checked; ``None`` when missing or not a valid optimum file (untrusted
    input: it is recomputed then)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        return None
    f, x = data.get("f_opt"), data.get("x_opt")
    if not (isinstance(f, (int, float)) and math.isfinite(f) and isinstance(x, list)
            and all(isinstance(v, (int, float)) and math.isfinite(v) for v in x)):
        return None
    return data


def update_instance_optimum(problem: Problem, settings: Mapping[str, Any], folder: Path,
                            run_bests: Iterable[tuple[np.ndarray, float]]) -> dict[str, Any]:
    """Polish ``problem``'s instance from its truth (once) and from every run best near or
    below the known optimum; write and return the lowest as ``folder/<key>.json``."""
    x_true = problem.x_true
    if x_true is None:
        raise ValueError("the optimum polish needs the true parameters")
    path = Path(folder) / f"{instance_key(problem, settings)}.json"
    known = read_optimum(path)
    if known is None or len(known["x_opt"]) != problem.bounds.dim:
        x_opt, f_opt = _polish_from_truth(problem, settings)
        known = {"starts": 1}
    else:
        x_opt, f_opt = np.asarray(known["x_opt"], dtype=float), float(known["f_opt"])
    starts = int(known.get("starts", 1))
    changed = "schema" not in known
    for x, f in run_bests:
        x = np.asarray(x, dtype=float)
        if not (np.all(np.isfinite(x)) and math.isfinite(f)) or f > POLISH_NEAR * f_opt:
            continue
        x_new, f_new = polish(problem, x)
        starts += 1
        changed = True
        if f_new < f_opt:
            x_opt, f_opt = x_new, f_new
    metrics = getattr(problem, "metrics", None)
    out = {
        "schema": SCHEMA, "problem": problem.name, "instance": problem.instance_id(),
        "x_opt": [float(v) for v in x_opt], "f_opt": float(f_opt),
        "f_true": _f_of(problem, x_true), "starts": starts,
        "metrics": ({str(k): float(v) for k, v in (metrics(x_opt) or {}).items()}
                    if metrics is not None else {}),
    }
    if changed:
        write_json_atomic(path, out)
    return out
