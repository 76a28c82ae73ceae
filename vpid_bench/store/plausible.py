"""Values no real run gives: the check an archived record passes before it is ranked.

An archive's records stand beside a user's runs without being run again; a forged or damaged
archive whose checksums match once ranked runs with a NaN metric, an infinite objective or a
negative error as better than the user's own. :func:`implausible` names the first value an ok
run cannot give (the list: docs/protocol.md, the archive; numbers below :data:`ABSURD`); the
archive loader skips the line and names it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

#: A magnitude no objective, metric or parameter of a real run reaches.
ABSURD = 1e100
#: Relative slack of the comparisons between two values a run wrote (ulps of a batch).
RTOL = 1e-9


def _num(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _bad_number(name: str, v: Any) -> str | None:
    if not _num(v) or not math.isfinite(float(v)) or abs(float(v)) >= ABSURD:
        return f"{name} = {v!r}: expected a finite number below {ABSURD:g} in magnitude"
    return None


def _numbers(record: Mapping[str, Any]) -> Iterator[tuple[str, Any]]:
    """Every number of an ok record's result and trace that is not plainly a finite float
    below :data:`ABSURD`, named, in the record's order (lazily: an archive's report checks
    hundreds of thousands, and only a suspect one needs its name)."""
    res = record.get("result") or {}
    trace = record.get("trace") or {}
    yield "result.f_best", res.get("f_best")
    yield from _suspects("result.x_best", res.get("x_best") or [])
    yield from ((f"result.metrics.{k}", v) for k, v in (res.get("metrics") or {}).items())
    yield from _suspects("result.rel_error_percent", res.get("rel_error_percent") or [])
    yield from _suspects("trace.best", trace.get("best") or [], skip_null=True)


def _suspects(prefix: str, values: Sequence[Any], skip_null: bool = False
              ) -> Iterator[tuple[str, Any]]:
    for i, v in enumerate(values):
        if type(v) is float and -ABSURD < v < ABSURD:
            continue  # the common case, not named
        if v is None and skip_null:
            continue  # a trace's null: nothing finite found yet
        yield f"{prefix}[{i}]", v


def _box(record: Mapping[str, Any]) -> str | None:
    """``x_best`` against the parameters: one value each, inside ``[lower, upper]``."""
    params = record.get("parameters") or {}
    x = (record.get("result") or {}).get("x_best") or []
    names = params.get("names") or []
    if len(x) != len(names):
        return f"result.x_best has {len(x)} values: expected one per parameter ({len(names)})"
    lower, upper = params.get("lower"), params.get("upper")
    if not (isinstance(lower, list) and isinstance(upper, list)
            and len(lower) == len(upper) == len(x) and all(map(_num, lower + upper))):
        return "parameters.lower, .upper: expected a number per parameter"
    for i, (v, lo, hi) in enumerate(zip(x, lower, upper, strict=True)):
        slack = RTOL * max(abs(lo), abs(hi), 1.0)
        if not lo - slack <= v <= hi + slack:
            return f"result.x_best[{i}] = {v!r}: expected a value inside [{lo!r}, {hi!r}]"
    return None


def _counts(record: Mapping[str, Any]) -> str | None:
    """Evaluations and the trace: within the budget, in order, ending at ``f_best``."""
    res = record.get("result") or {}
    budget = record.get("budget")
    limit = budget if isinstance(budget, int) and budget > 0 else None
    ev = res.get("evaluations")
    if not isinstance(ev, int) or ev < 1 or (limit is not None and ev > limit):
        return f"result.evaluations = {ev!r}: expected an integer from 1 to the budget ({budget})"
    trace = record.get("trace") or {}
    tev, best = trace.get("evaluations") or [], trace.get("best") or []
    if len(tev) != len(best):
        return "trace: expected as many evaluations as best values"
    if any(b < a for a, b in zip(tev, tev[1:], strict=False)) or \
            (tev and (tev[0] < 1 or (limit is not None and tev[-1] > limit))):
        return "trace.evaluations: expected counts that never decrease, from 1 to the budget"
    seen = [b for b in best if b is not None]
    if any(b > a * (1 + RTOL) + RTOL for a, b in zip(seen, seen[1:], strict=False)):
        return "trace.best: expected a best-so-far that never increases"
    f = res.get("f_best")
    if seen and not _close(seen[-1], f):
        return f"trace.best ends at {seen[-1]!r}: expected result.f_best ({f!r})"
    return None


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= RTOL * max(abs(a), abs(b), 1.0)


def implausible(record: Mapping[str, Any], f_opt: float | None = None) -> str | None:
    """The first value of a (type-checked) record that no real run gives, as ``"<field> =
    <value>: expected ..."``, or ``None``. ``f_opt``: the optimum of the record's instance,
    when known (``f_best`` may not lie below it)."""
    timing = record.get("timing") or {}
    for key in ("wall_time_s", "run_time_s"):
        v = timing.get(key)
        if v is not None and (not _num(v) or not 0 <= float(v) < ABSURD):
            return f"timing.{key} = {v!r}: expected null or a finite number of seconds >= 0"
    if record.get("status") != "ok":
        return None
    for name, v in _numbers(record):
        why = _bad_number(name, v)
        if why:
            return why
    for name, v in ((record.get("result") or {}).get("metrics") or {}).items():
        if v < 0:
            return (f"result.metrics.{name} = {v!r}: expected an error, a number >= 0 (a "
                    "problem's metrics are accuracy figures)")
    why = _box(record) or _counts(record)
    if why:
        return why
    f = record["result"]["f_best"]
    if f_opt is not None and f < f_opt and not _close(f, f_opt):
        return (f"result.f_best = {f!r}: expected a value not below its instance's optimum "
                f"({f_opt!r}, optima.jsonl)")
    return None
