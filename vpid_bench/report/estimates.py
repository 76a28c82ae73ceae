"""The report's view of a problem without a truth: which contexts have none, the identified
values with their 95 % intervals (each run's ``result.intervals``, each job's
``profile.json``) and the problem's comparison rows (``comparisons.json``), all untrusted: a
field of the wrong type, length or size is left out."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..store.job_checks import finite, interval_ends, read_comparisons, read_profile
from ..store.job_files import COMPARISONS, PROFILE
from .load import Rows, first_file_by_context
from .render import fmt

#: The words every no-truth context starts with (the first screen and the body).
NO_TRUTH = ("No truth: the parameters that made this record are not known (a measured "
            "record), so no error against any nominal value is computed")
#: The same for a problem that fits no record (``problem.info.fits_a_record`` false, e.g. a
#: test function whose minimiser has a zero coordinate, where relative errors are undefined).
NO_TRUTH_NO_RECORD = ("No truth is offered by this problem (it fits no record), so no error "
                      "against a true value is computed")


@dataclasses.dataclass
class Identified:
    """The identified values of one context: the best run's vector with its intervals."""

    run: str  # e.g. "lsq, run 3"
    f: float
    names: list[str]
    units: list[str]
    x: list[float]
    lower: list[float | None]  # Jacobian interval (None: unbounded)
    upper: list[float | None]
    sigma: list[float]  # σ estimated per residual group
    profile: dict[str, Any] | None = None  # profile.json (status ok), or None
    profile_note: str = ""  # why there is no profile, when there is none
    #: the robust (HAC) interval's lower ends (None: not in the record)
    robust_lower: list[float | None] | None = None
    objective_unit: str = ""  # the objective's unit the problem states (its info), or ""
    objective_what: str = ""  # what the objective is, in words, or ""
    caveat: str = ""  # what the problem says of its intervals (its info), or ""

    def rows(self) -> tuple[list[str], list[list[Any]]]:
        """A table: parameter, unit, value, its Jacobian interval and half-width (%), and the
        profile interval where one was computed."""
        headers = ["parameter", "unit", "value", "95 % interval (Jacobian)", "± %"]
        prof = self.profile
        if prof is not None:
            headers += ["likelihood's estimate", "95 % interval (profile)"]
        out = []
        for j, name in enumerate(self.names):
            lo, hi, x = self.lower[j], self.upper[j], self.x[j]
            half = (100.0 * (hi - x) / abs(x) if hi is not None and x else math.nan)
            row: list[Any] = [name, self.units[j] if j < len(self.units) else "", x,
                              _interval(lo, hi), half]
            if prof is not None:
                est = prof.get("estimate")
                row += [est[j] if interval_ends(est, len(self.names)) else None,
                        _interval(prof["lower"][j], prof["upper"][j])]
            out.append(row)
        return headers, out


def _interval(lo: float | None, hi: float | None) -> str:
    return f"[{'open' if lo is None else fmt(lo)}, {'open' if hi is None else fmt(hi)}]"


def no_truth(records: Rows, rows: Rows) -> dict[str, bool]:
    """Per context, whether its problem has no truth (every record's ``parameters.true`` null)."""
    by_id = {r["run_id"]: r for r in records}
    out: dict[str, bool] = {}
    for row in rows:
        rec = by_id.get(row["run_id"]) or {}
        none = (rec.get("parameters") or {}).get("true") is None
        out[row["context"]] = out.get(row["context"], True) and none
    return out


def check_intervals(value: Any, d: int) -> dict[str, Any] | None:
    """A record's ``result.intervals``, or ``None`` when missing or malformed."""
    if not (isinstance(value, Mapping) and interval_ends(value.get("lower"), d)
            and interval_ends(value.get("upper"), d)):
        return None
    sigma = value.get("sigma")
    ok = isinstance(sigma, list) and 0 < len(sigma) <= 1000 and all(finite(s) for s in sigma)
    return dict(value) if ok else None


def comparisons_by_context(records: Rows, rows: Rows) -> dict[str, list[dict[str, Any]]]:
    """Per context, the comparison rows of its first job that wrote readable ones."""
    return first_file_by_context(records, rows, COMPARISONS, read_comparisons)


def identified_by_context(records: Rows, rows: Rows, contexts: Mapping[str, bool]
                          ) -> dict[str, Identified]:
    """Per context without a truth: the best ok run with readable intervals, and the
    profile started at the lowest objective."""
    by_id = {r["run_id"]: r for r in records}
    out: dict[str, Identified] = {}
    for context in (c for c, none in contexts.items() if none):
        mine = [r for r in rows if r["context"] == context and r["status"] == "ok"]
        mine.sort(key=lambda r: (_key(r.get("metric")), _key(r.get("f_best"))))
        found = next(filter(None, (_identified(r, by_id[r["run_id"]]) for r in mine)), None)
        if found is not None:
            found.profile, found.profile_note = _best_profile(
                [by_id[r["run_id"]] for r in mine], len(found.names))
            out[context] = found
    return out


def _key(v: Any) -> float:
    return float(v) if finite(v) else math.inf


def _identified(row: Mapping[str, Any], rec: Mapping[str, Any]) -> Identified | None:
    params = rec.get("parameters") or {}
    names = list(params.get("names") or [])
    res = rec.get("result") or {}
    x = res.get("x_best")
    d = len(names)
    if not (d and isinstance(x, list) and len(x) == d and all(finite(v) for v in x)):
        return None
    iv = check_intervals(res.get("intervals"), d)
    if iv is None:
        return None
    robust = iv.get("robust")
    robust = robust if isinstance(robust, Mapping) and interval_ends(robust.get("lower"), d) \
        and interval_ends(robust.get("upper"), d) else {}
    info = (rec.get("problem") or {}).get("info")
    info = info if isinstance(info, Mapping) else {}
    objective = info.get("objective") if isinstance(info.get("objective"), Mapping) else {}
    return Identified(f"{row['algorithm']}, run {row['run_index']}", _key(res.get("f_best")),
                      names, list(params.get("units") or []), [float(v) for v in x],
                      iv["lower"], iv["upper"], [float(s) for s in iv["sigma"]],
                      robust_lower=robust.get("lower"),
                      objective_unit=_text(objective.get("unit"), 20),
                      objective_what=_text(objective.get("what"), 120),
                      caveat=_text(info.get("caveat"), 400))


def _text(v: Any, most: int) -> str:
    """A short text from a record (``""`` when it is not a string)."""
    return " ".join(v.split())[:most] if isinstance(v, str) else ""


def _best_profile(records: Rows, d: int) -> tuple[dict[str, Any] | None, str]:
    """The records' jobs' readable ``profile.json`` (ok) of lowest start, or ``None`` and why."""
    folders = dict.fromkeys(str(rec.get("_job_dir", ".")) for rec in records)
    found = [p for p in (read_profile(Path(f) / PROFILE, d) for f in folders) if p is not None]
    ok = [p for p in found if p["status"] == "ok"]
    if ok:
        return min(ok, key=lambda p: p["f_start"]), ""
    if found:
        return None, f"profile likelihood {found[0]['status']}: {found[0]['reason']}"
    return None, "no profile likelihood was computed"
