"""The content checks of a job's JSON files (:mod:`.job_files` names them, caps their size,
reads and writes them): one reader per file, which returns the checked data, or nothing and
why for a file that is missing, too large, not JSON or has a field of the wrong type, size or
value (a report never trusts what a job folder holds)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..estimators import OBJECTIVES
from .job_files import read_job_json

DIAGNOSTICS_SCHEMA = "vpid-bench/diagnostics/1"
PROFILE_SCHEMA = "vpid-bench/profile/1"
COMPARISONS_SCHEMA = "vpid-bench/comparisons/1"
#: Most comparison rows a problem may give (the report prints each).
MAX_COMPARISONS = 20
#: Instances (and runs of one instance) an identifiability file may list.
MAX_INSTANCES = 100_000
#: Most channels, inputs per channel and lags of a diagnostics file read.
MAX_GROUPS, MAX_INPUTS, MAX_LAGS = 64, 16, 200


def interval_ends(v: Any, d: int) -> bool:
    """``d`` interval ends, each a finite number or ``None`` (open)."""
    return isinstance(v, list) and len(v) == d and all(x is None or finite(x) for x in v)


def finite(v: Any) -> bool:
    """A finite number (not a bool)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v: Any) -> bool:
    return finite(v) and v >= 0


def _checked(path: Path, checks: Callable[[dict[str, Any]], Iterable[tuple[str, bool, str]]]
             ) -> tuple[dict[str, Any] | None, str]:
    """The JSON object of the job file ``path`` if it passes every ``(field, ok, expected)``
    of ``checks(data)``: ``(data, "")``, or ``(None, why)``."""
    data, why = read_job_json(path)
    if why or not isinstance(data, dict):
        return None, why or "not a JSON object"
    for key, ok, expected in checks(data):
        if not ok:
            return None, f"field {key}: expected {expected}"
    return data, ""


def read_identifiability(path: Path, names: Sequence[str]) -> tuple[dict[str, Any] | None, str]:
    """A job's ``identifiability.json``, checked against the records' parameter ``names``:
    ``(data, "")``, or ``(None, why)``."""
    d = len(names)
    return _checked(path, lambda data: (
        ("names", data.get("names") == list(names), f"the records' parameter names {names}"),
        ("crb_percent", _bounds_ok(data.get("crb_percent"), d),
         f"a list of {d} finite numbers >= 0"),
        ("crb_norm_percent", _positive(data.get("crb_norm_percent")), "a finite number >= 0"),
        ("singular_values", isinstance(data.get("singular_values"), list)
         and 1 <= len(data["singular_values"]) <= d
         and all(map(_positive, data["singular_values"])),
         f"a list of 1 to {d} finite numbers >= 0"),
        ("condition_number", data.get("condition_number") is None
         or (finite(data["condition_number"]) and data["condition_number"] >= 1),
         "a finite number >= 1 or null (infinite)"),
        ("sigma", isinstance(data.get("sigma"), list) and 1 <= len(data["sigma"]) <= 10_000
         and all(finite(v) and v > 0 for v in data["sigma"]), "a list of numbers > 0"),
        *_optional_checks(data, d)))


def _bounds_ok(v: Any, d: int) -> bool:
    return isinstance(v, list) and len(v) == d and all(map(_positive, v))


def _instance_entry_ok(e: Any, d: int) -> bool:
    norms = e.get("sigma_floor_norms") if isinstance(e, dict) else None
    return (isinstance(e, dict) and (e.get("instance") is None
                                     or isinstance(e["instance"], str))
            and isinstance(e.get("runs"), list) and 1 <= len(e["runs"]) <= MAX_INSTANCES
            and all(isinstance(i, int) and not isinstance(i, bool) and i >= 0
                    for i in e["runs"])
            and _bounds_ok(e.get("crb_percent"), d) and _positive(e.get("crb_norm_percent"))
            and (norms is None or (isinstance(norms, list) and len(norms) <= 10
                                   and all(map(_positive, norms)))))


def _optional_checks(data: Mapping[str, Any], d: int) -> list[tuple[str, bool, str]]:
    """Checks of the fields written since round four (absent in older files)."""
    checks = []
    if "excluded_entries" in data:
        v = data["excluded_entries"]
        checks.append(("excluded_entries", isinstance(v, int) and not isinstance(v, bool)
                       and v >= 0, "an integer >= 0"))
    if "sigma_floor_sensitivity" in data:
        v = data["sigma_floor_sensitivity"]
        checks.append(("sigma_floor_sensitivity", isinstance(v, list) and 1 <= len(v) <= 10
                       and all(isinstance(e, dict) and _positive(e.get("fraction"))
                               and _positive(e.get("crb_norm_percent"))
                               and _bounds_ok(e.get("crb_percent"), d) for e in v),
                       f"a list of 1 to 10 {{fraction, crb_percent ({d} numbers), "
                       "crb_norm_percent}"))
    if "instances" in data:
        v = data["instances"]
        checks.append(("instances", isinstance(v, list) and len(v) <= MAX_INSTANCES
                       and all(_instance_entry_ok(e, d) for e in v),
                       f"a list of at most {MAX_INSTANCES} {{instance, runs, crb_percent "
                       f"({d} numbers), crb_norm_percent[, sigma_floor_norms]}}"))
    return checks


def read_estimator_floors(path: Path) -> tuple[dict[str, Any] | None, str]:
    """A job's ``estimators.json``, checked: ``(data, "")`` or ``(None, why)``."""
    def checks(data: dict[str, Any]) -> Iterable[tuple[str, bool, str]]:
        n, floors = data.get("instances"), data.get("floors")
        return (
            ("metric", isinstance(data.get("metric"), str) and 0 < len(data["metric"]) <= 64,
             "a name"),
            ("instances", isinstance(n, int) and not isinstance(n, bool) and 1 <= n <= 1000,
             "an integer in [1, 1000]"),
            ("chosen", data.get("chosen") in OBJECTIVES, "one of " + ", ".join(OBJECTIVES)),
            ("floors", isinstance(floors, dict) and floors and set(floors) <= set(OBJECTIVES)
             and all(isinstance(v, dict) and _positive(v.get("median"))
                     and isinstance(v.get("values"), list) and len(v["values"]) == n
                     and all(map(_positive, v["values"])) for v in floors.values()),
             "per objective a median and one value per instance, finite and >= 0"))

    return _checked(path, checks)


def _numbers(v: Any, most: int) -> bool:
    return isinstance(v, list) and 0 < len(v) <= most and all(finite(x) for x in v)


def _opt(v: Any) -> float:
    return float(v) if finite(v) else math.nan


def _group(g: Any) -> dict[str, Any] | None:
    """One channel's entry, checked (``None``: unusable)."""
    if not isinstance(g, Mapping) or not _numbers(g.get("acf"), MAX_LAGS + 1):
        return None
    if not all(finite(g.get(k)) for k in ("band99", "lag1", "n")):
        return None
    cross = {}
    raw = g.get("cross")
    for name, c in (list(raw.items())[:MAX_INPUTS] if isinstance(raw, Mapping) else []):
        if isinstance(c, Mapping) and _numbers(c.get("ccf"), 2 * MAX_LAGS + 1) and all(
                finite(c.get(k)) for k in ("band99", "max_abs", "lag_at_max", "outside")):
            cross[str(name)[:40]] = dict(c)
    out = {k: _opt(g.get(k)) for k in ("rms", "signal_rms", "rms_over_signal", "sigma",
                                        "rms_over_sigma", "ljung_box_p", "band99", "lag1")}
    out.update(name=str(g.get("name", ""))[:40], acf=[float(x) for x in g["acf"]],
               sigma_source="stated" if g.get("sigma_source") == "stated" else "estimated",
               cross=cross, correlated=g.get("correlated") is True,
               input_correlated=g.get("input_correlated") is True,
               misfit=g.get("misfit") is True, n=int(g["n"]))
    return out


def _intervals(iv: Any, d: int) -> dict[str, Any] | None:
    """The white and robust standard errors, checked (``None`` where unusable)."""
    if not isinstance(iv, Mapping) or not interval_ends(iv.get("se"), d):
        return None
    rob = iv.get("robust")
    if not isinstance(rob, Mapping) or not interval_ends(rob.get("se"), d):
        return None
    return {"se": iv["se"], "robust_se": rob["se"],
            "lags": int(rob["lags"]) if finite(rob.get("lags")) else None}


def read_diagnostics(path: Path) -> dict[str, Any] | None:
    """A job's ``diagnostics.json``, checked; ``None`` when missing, failed or malformed."""
    data = read_job_json(path)[0]
    if not isinstance(data, dict) or data.get("schema") != DIAGNOSTICS_SCHEMA \
            or data.get("status") != "ok":
        return None
    groups = data.get("groups")
    if not isinstance(groups, list) or not 0 < len(groups) <= MAX_GROUPS:
        return None
    checked = [_group(g) for g in groups]
    names, x = data.get("names"), data.get("x")
    if None in checked or not finite(data.get("f")) or not _numbers(x, 1000) \
            or not (isinstance(names, list) and len(names) == len(x)):
        return None
    held = data.get("held_out")
    return {"groups": checked, "f": float(data["f"]), "x": [float(v) for v in x],
            "names": [str(n)[:40] for n in names],
            "intervals": _intervals(data.get("intervals"), len(x)),
            "held_out": dict(held) if isinstance(held, Mapping) and finite(held.get("error"))
            and finite(held.get("naive")) else None,
            "explained": not any(g["correlated"] or g["input_correlated"] for g in checked)}


def read_profile(path: Path, d: int) -> dict[str, Any] | None:
    """A job's ``profile.json`` (any status), checked; ``None`` when missing or malformed."""
    data = read_job_json(path)[0]
    if not isinstance(data, dict) or data.get("schema") != PROFILE_SCHEMA:
        return None
    if not finite(data.get("f_start")) or data.get("status") not in ("ok", "skipped", "failed"):
        return None
    if data["status"] == "ok" and not (interval_ends(data.get("lower"), d)
                                       and interval_ends(data.get("upper"), d)):
        return None
    reason = data.get("reason", "")
    data["reason"] = reason[:200] if isinstance(reason, str) else ""
    return data


def read_comparisons(path: Path, record: Mapping[str, Any]) -> list[dict[str, Any]] | None:
    """A job's ``comparisons.json`` rows, checked; ``None`` when missing or malformed."""
    data = read_job_json(path)[0]
    if not isinstance(data, dict) or data.get("schema") != COMPARISONS_SCHEMA:
        return None
    rows = data.get("rows")
    if not isinstance(rows, list) or not 0 < len(rows) <= MAX_COMPARISONS:
        return None
    out = []
    for row in rows:
        if not isinstance(row, dict) or not isinstance(row.get("name"), str):
            return None
        metrics = row.get("metrics") or {}
        if not (isinstance(metrics, dict) and all(isinstance(k, str) and finite(v)
                                                  for k, v in metrics.items())):
            return None
        f = row.get("f")
        note = row.get("note")
        out.append({"name": row["name"][:80], "f": f if finite(f) else math.nan,
                    "metrics": metrics, "note": note[:200] if isinstance(note, str) else ""})
    return out
