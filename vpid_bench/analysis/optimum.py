"""Each instance's attainable optimum: the lowest objective value its record allows
(docs/report.md, each run against its instance's optimum).

:func:`polish` minimises a sum of residual-group norms by iteratively reweighted least
squares (group ``g`` weighted by ``1 / ||r_g||``, scipy's ``trf`` inside the box); it never
returns a point worse than its start. :func:`update_instance_optimum` keeps one JSON file per
instance in a sweep's ``optima`` folder, polished from the truth and from run bests below or
near it (:data:`POLISH_NEAR`, :data:`SAME_POINT`), the lowest kept.
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import own_folder
from ..problem import PROTOCOL_KEYS, Problem
from ..store.optimum import SCHEMA, read_optimum_data, write_optimum_file
from ..store.records import stable_hash

#: A run whose best is within this factor of the known optimum is polished too: it may sit in
#: another basin whose minimum is lower.
POLISH_NEAR = 1.01
#: ... unless its best is not below the known optimum and lies within this share of the box's
#: width of the optimum's point on every parameter: in the optimum's basin, a polish ends where
#: the optimum's did (with a final target, 175 of 233 run bests of a vpid1 slice were there).
SAME_POINT = 1e-3
#: scipy's xtol/ftol/gtol for each weighted least-squares step. 1e-10 makes a polish 2.2x
#: cheaper than 1e-15 and moves f* by at most 4.3e-13 (relative) from DE1 run bests and the
#: truths of 30 instances of the default problem (``benchmarks/bench_optima.py polish``):
#: far below the relative gap of 1e-6 at which a run counts as having reached the optimum.
INNER_TOL = 1e-10


def _f_of(problem: Problem, x: np.ndarray) -> float:
    return float(problem.evaluate(np.asarray(x, dtype=float)[None])[0])


def polish(problem: Problem, x0: np.ndarray, rounds: int = 30, tol: float = 1e-13,
           inner_tol: float = INNER_TOL) -> tuple[np.ndarray, float]:
    """A local minimum of ``problem`` near ``x0`` (physical units) and its objective value,
    by IRLS on the residual groups (see the module); never worse than ``x0``. Each step's
    Jacobian goes to the problem as one batch of ``d + 1`` points (several times cheaper
    than scipy's point-by-point differences)."""
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

        def jac(z: np.ndarray, w: np.ndarray = w) -> np.ndarray:
            return _forward_jacobian(problem, z, scale, w, lo, hi)

        sol = least_squares(weighted, x / scale, jac=jac, bounds=(lo, hi), method="trf",
                            x_scale=1.0, xtol=inner_tol, ftol=inner_tol, gtol=inner_tol,
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


def _weighted_rows(problem: Problem, Z: np.ndarray, scale: np.ndarray, w: np.ndarray) -> np.ndarray:
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


def record_settings(settings: Mapping[str, Any]) -> dict[str, Any]:
    """The problem settings that define a record: all but the protocol (``ps``,
    ``iterations``), so jobs at ``ps`` 20 and 30 share each instance's optimum."""
    return {str(k): v for k, v in settings.items() if k not in PROTOCOL_KEYS}


def optimum_key(problem_name: str, settings: Mapping[str, Any], data: str | None,
                instance_id: str | None) -> str:
    """The file stem of an instance's optimum: a hash of what defines its record (problem
    name, settings without the protocol, data digest, instance id)."""
    return stable_hash({"problem": problem_name, "settings": record_settings(settings),
                        "data": data, "instance": instance_id})


def instance_key(problem: Problem, settings: Mapping[str, Any]) -> str:
    """:func:`optimum_key` of ``problem`` (an instance) with its job's ``settings``."""
    return optimum_key(problem.name, settings, problem.content_digest(), problem.instance_id())


def load_optima(folders: Iterable[Path]) -> dict[str, dict[str, Any]]:
    """Every valid optimum file in ``folders`` (e.g. ``<sweep>/optima``), by file stem; the
    first folder that holds a stem wins; invalid (untrusted) files are left out."""
    out: dict[str, dict[str, Any]] = {}
    for folder in folders:
        folder = Path(folder)
        if not folder.is_dir():
            continue
        for path in sorted(folder.glob("*.json")):
            if path.stem not in out and path.is_file():
                data = read_optimum_data(path)[0]
                if data is not None:
                    out[path.stem] = data
    return out


def find_optimum(record: Mapping[str, Any], optima: Mapping[str, Mapping[str, Any]]
                 ) -> Mapping[str, Any] | None:
    """The optimum (from :func:`load_optima`) of the instance a run record fitted, or
    ``None``: the key recomputed from the record with the file's data digest must be the
    file's name, and its ``x_opt`` of the record's dimension."""
    try:
        name = record["problem"]["name"]
        settings = record["problem"]["config"]
        instance = (record.get("instance") or {}).get("id")
        dim = len(record["parameters"]["names"])
    except (KeyError, TypeError, AttributeError):
        return None
    if not isinstance(name, str) or not isinstance(settings, Mapping):
        return None
    digests = {d.get("data") for d in optima.values()
               if d.get("problem") == name and d.get("instance") == instance}
    for digest in sorted(digests, key=str):
        try:
            key = optimum_key(name, settings, digest, instance)
        except (TypeError, ValueError):
            return None
        found = optima.get(key)
        if found is not None and len(found["x_opt"]) == dim:
            return found
    return None


def update_instance_optimum(problem: Problem, settings: Mapping[str, Any], folder: Path,
                            run_bests: Iterable[tuple[np.ndarray, float]]) -> dict[str, Any]:
    """Polish ``problem``'s instance from its truth (once) and from every run best near or
    below the known optimum; write and return the lowest as ``folder/<key>.json``. Without a
    truth (a measured record) the first polish starts from the lowest run best instead."""
    run_bests = list(run_bests)
    x_start = problem.x_true
    if x_start is None:
        finite = [(x, f) for x, f in run_bests
                  if math.isfinite(f) and np.all(np.isfinite(np.asarray(x, dtype=float)))]
        if not finite:
            raise ValueError("the optimum polish needs the true parameters or a run's best")
        x_start = np.asarray(min(finite, key=lambda b: b[1])[0], dtype=float)
    path = own_folder(folder) / f"{instance_key(problem, settings)}.json"  # never a link
    with _locked(path):  # launcher workers share the folder: read, polish, write as one step
        return _update(problem, settings, path, x_start, run_bests)


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``<path>.lock`` (POSIX advisory; elsewhere no lock)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path.with_suffix(".lock"), os.O_RDWR | os.O_CREAT
                 | getattr(os, "O_NOFOLLOW", 0), 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def _update(problem: Problem, settings: Mapping[str, Any], path: Path, x_start: np.ndarray,
            run_bests: Iterable[tuple[np.ndarray, float]]) -> dict[str, Any]:
    known = read_optimum_data(path)[0]  # a bad (untrusted) file is recomputed
    if known is None or len(known["x_opt"]) != problem.bounds.dim:
        x_opt, f_opt = polish(problem, x_start)
        known = {"starts": 1}
    else:
        x_opt, f_opt = np.asarray(known["x_opt"], dtype=float), float(known["f_opt"])
    starts = int(known.get("starts", 1))
    changed = "schema" not in known
    width = problem.bounds.width
    for x, f in run_bests:
        x = np.asarray(x, dtype=float)
        if not (np.all(np.isfinite(x)) and math.isfinite(f)) or f > POLISH_NEAR * f_opt:
            continue
        if f >= f_opt and x.shape == x_opt.shape and np.all(
                np.abs(x - x_opt) <= SAME_POINT * width):
            continue  # in the optimum's basin (see SAME_POINT)
        x_new, f_new = polish(problem, x)
        starts += 1
        changed = True
        if f < f_opt:  # the run's own value (a batched evaluation may differ by an ulp)
            x_opt, f_opt = x, float(f)
        if f_new < f_opt:
            x_opt, f_opt = x_new, f_new
    metrics = getattr(problem, "metrics", None)
    out = {
        "schema": SCHEMA, "problem": problem.name, "instance": problem.instance_id(),
        "settings": dict(settings),  # lets a report match the file to its runs' records
        "data": problem.content_digest(),
        "x_opt": [float(v) for v in x_opt], "f_opt": float(f_opt),
        "f_true": None if problem.x_true is None else _f_of(problem, problem.x_true),
        "starts": starts,
        "metrics": ({str(k): float(v) for k, v in (metrics(x_opt) or {}).items()}
                    if metrics is not None else {}),
    }
    if changed:
        write_optimum_file(path, out)
    return out
