"""What a job leaves about the answer itself where no truth is known, and the problem's fixed
comparison rows (docs/architecture.md, a problem without a truth): ``profile.json``, the 95 %
profile-likelihood intervals at the instance's optimum, σ per group estimated from the
residuals there, when the first fit says they take at most :data:`PROFILE_LIMIT_S` (else the
file says why not); ``comparisons.json``, each row of
:meth:`~vpid_bench.api.Problem.comparisons` with its objective and metrics (never truths).
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..problem import Problem
from ..store.job_checks import COMPARISONS_SCHEMA, MAX_COMPARISONS, PROFILE_SCHEMA
from ..store.job_files import COMPARISONS, PROFILE, write_job_json
from .intervals import group_sigma, jacobian_intervals
from .profile import ProfileTooSlowError, profile_intervals

#: Longest a profile may take (s), judged from its first fit before it starts (a job's
#: analysis should not outlast its runs by much; docs/report.md).
PROFILE_LIMIT_S = 120.0


def write_profile(problem: Problem, optimum: dict[str, Any], job_dir: Path,
                  limit_s: float = PROFILE_LIMIT_S) -> Path:
    """``job_dir/profile.json`` for ``problem`` (an instance without a truth) at
    ``optimum`` (:func:`.optimum.update_instance_optimum`'s result)."""
    x = np.asarray(optimum["x_opt"], dtype=float)
    out: dict[str, Any] = {"schema": PROFILE_SCHEMA, "instance": problem.instance_id(),
                           "start": x.tolist(), "f_start": float(optimum["f_opt"]),
                           "names": list(problem.bounds.names), "limit_s": limit_s}
    began = time.perf_counter()
    try:
        groups = np.asarray(problem.fisher_groups(), dtype=int)
        r = np.asarray(problem.fisher_residuals(x[None]), dtype=float)[0]
        sigma = group_sigma(r, groups, x.size)
        jac = jacobian_intervals(problem, x)
        rel = (None if jac is None else
               np.array([math.inf if s is None else s for s in jac["se"]]) / np.abs(x))
        prof = profile_intervals(problem, start=x, sigma=sigma, rel_sd=rel, limit_s=limit_s)
        out.update(status="ok", sigma=sigma.tolist(), **prof)
    except ProfileTooSlowError as exc:
        out.update(status="skipped", reason=str(exc))
    except (ValueError, FloatingPointError, np.linalg.LinAlgError) as exc:
        out.update(status="failed", reason=" ".join(f"{type(exc).__name__}: {exc}".split())[:200])
    out["seconds"] = time.perf_counter() - began
    return write_job_json(Path(job_dir) / PROFILE, out)


def comparison_rows(problem: Problem) -> list[dict[str, Any]]:
    """The problem's comparison rows as JSON: ``name``, ``x`` (physical or ``None``), ``f``
    at ``x``, ``metrics`` (the problem's at ``x``, updated by the row's), ``note``; a row
    whose ``x`` has the wrong length: :class:`ValueError`."""
    given = problem.comparisons() or {}
    if len(given) > MAX_COMPARISONS:
        raise ValueError(f"problem {problem.name!r}: comparisons() gave {len(given)} rows, "
                         f"at most {MAX_COMPARISONS}")
    rows = []
    for name, row in given.items():
        x = row.get("x")
        f, metrics = None, {}
        if x is not None:
            x = np.asarray(x, dtype=float).reshape(-1)
            if x.size != problem.bounds.dim:
                raise ValueError(f"problem {problem.name!r}: comparison {name!r} has {x.size} "
                                 f"values, the problem {problem.bounds.dim} parameters")
            f = float(np.asarray(problem.evaluate(x[None]), dtype=float)[0])
            metrics = {str(k): float(v) for k, v in (problem.metrics(x) or {}).items()}
        metrics.update({str(k): float(v) for k, v in (row.get("metrics") or {}).items()})
        rows.append({"name": str(name), "x": None if x is None else x.tolist(), "f": f,
                     "metrics": metrics, "note": str(row.get("note", ""))})
    return rows


def write_comparisons(problem: Problem, job_dir: Path) -> Path | None:
    """``job_dir/comparisons.json`` when the problem gives comparison rows, else nothing."""
    rows = comparison_rows(problem)
    if not rows:
        return None
    return write_job_json(Path(job_dir) / COMPARISONS, {"schema": COMPARISONS_SCHEMA,
                                                        "problem": problem.name, "rows": rows})
