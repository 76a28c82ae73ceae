"""What an answer assumes: the quantities a problem states rather than identifies, the boxes
it searched, the input it used (``known``, ``box``, ``input`` of ``problem.info``,
docs/architecture.md), and estimates on or near a bound. Untrusted: a field of the wrong
type is left out, texts cut to :data:`MAX_TEXT`, lists to :data:`MAX_ROWS`."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from ..store.job_checks import finite
from .render import fmt
from .safe import escape

#: Longest text shown from a record's ``known``/``box`` entries (characters).
MAX_TEXT = 80
#: Most rows shown of each list.
MAX_ROWS = 40
#: An estimate within this fraction of its box's width from a bound is flagged.
NEAR_BOUND = 0.01


def _text(value: Any, limit: int = MAX_TEXT) -> str | None:
    return value[:limit] if isinstance(value, str) else None


def _num(value: Any) -> float | None:
    return float(value) if finite(value) else None


#: A group of more boxes than this from one source not the user's is named, not listed.
MAX_LISTED = 4


def _grouped(items: list[tuple[str, str, str]], short: bool = False) -> str:
    """``(source, name, text)`` items as "source: text, text; source: text"; with ``short``,
    a large group not set by the user gives its names only."""
    by: dict[str, list[tuple[str, str]]] = {}
    for source, name, text in items:
        by.setdefault(source, []).append((name, text))
    parts = []
    for src, entries in by.items():
        if short and len(entries) > MAX_LISTED and not src.startswith("set by you"):
            body = ", ".join(escape(n) for n, _ in entries) + f" ({len(entries)})"
        else:
            body = ", ".join(t for _, t in entries)
        parts.append(f"{escape(src)}: {body}")
    return "; ".join(parts)


def _known_text(known: Any) -> str:
    items = []
    for k in known[:MAX_ROWS] if isinstance(known, list) else []:
        if not isinstance(k, Mapping):
            continue
        name, unit, source = _text(k.get("name")), _text(k.get("unit")), _text(k.get("source"))
        value = _num(k.get("value"))
        if name is None or value is None or source is None:
            continue
        what = _text(k.get("what"))
        items.append((source, name,
                      f"{escape(name)} = {fmt(value, 6)} {escape(unit or '')}".rstrip()
                      + (f" ({escape(what)})" if what else "")))
    return _grouped(items)


def _box_text(box: Any) -> str:
    items = []
    for b in box[:MAX_ROWS] if isinstance(box, list) else []:
        if not isinstance(b, Mapping):
            continue
        name, source = _text(b.get("name")), _text(b.get("source"))
        lo, hi = _num(b.get("lower")), _num(b.get("upper"))
        if name is None or lo is None or hi is None or source is None:
            continue
        unit = escape(_text(b.get("unit")) or "")
        items.append((source, name,
                      f"{escape(name)} [{fmt(lo, 6)}, {fmt(hi, 6)}] {unit}".rstrip()))
    return _grouped(items, short=True)


def _context_records(data: Any, context: str) -> list[Mapping[str, Any]]:
    ids = {r["run_id"] for r in data.rows if r["context"] == context}
    return [rec for rec in data.loaded.records if rec.get("run_id") in ids]


def _info(rec: Mapping[str, Any]) -> Mapping[str, Any]:
    problem = rec.get("problem")
    info = problem.get("info") if isinstance(problem, Mapping) else None
    return info if isinstance(info, Mapping) else {}


def fits_a_record(data: Any, context: str) -> bool:
    """False where a record says its problem fits no record (a test function)."""
    return all(_info(r).get("fits_a_record", True) is not False
               for r in _context_records(data, context))


def _best(records: Sequence[Mapping[str, Any]]) -> Mapping[str, Any] | None:
    best, f_best = None, math.inf
    for rec in records:
        result = rec.get("result")
        f = _num(result.get("f_best")) if isinstance(result, Mapping) else None
        if f is not None and f < f_best:
            best, f_best = rec, f
    return best


def near_bounds(rec: Mapping[str, Any]) -> list[str]:
    """In words, each parameter of ``x_best`` within :data:`NEAR_BOUND` box widths of a bound."""
    params, result = rec.get("parameters"), rec.get("result")
    if not isinstance(params, Mapping) or not isinstance(result, Mapping):
        return []
    names, units = params.get("names"), params.get("units") or []
    lower, upper, x = params.get("lower"), params.get("upper"), result.get("x_best")
    if not all(isinstance(v, list) for v in (names, lower, upper, x)) or not (
            len(names) == len(lower) == len(upper) == len(x)):
        return []
    out = []
    for j, name in enumerate(names[:MAX_ROWS]):
        lo, hi, v = _num(lower[j]), _num(upper[j]), _num(x[j])
        if lo is None or hi is None or v is None or not hi > lo:
            continue
        width = hi - lo
        side = ("lower", lo) if v - lo <= NEAR_BOUND * width else (
            ("upper", hi) if hi - v <= NEAR_BOUND * width else None)
        if side is None:
            continue
        unit = units[j] if j < len(units) and isinstance(units[j], str) else ""
        out.append(f"{escape(_text(name) or '?')} = {fmt(v, 6)} is within "
                   f"{100 * NEAR_BOUND:g} % of the box's width of its {side[0]} bound "
                   f"{fmt(side[1], 6)} {escape(unit[:20])}")
    return out


def blocks(data: Any, context: str) -> list[tuple[str, list[str], list[list[Any]]]]:
    """The "Assumed" block of ``context`` as ``(Markdown text, headers, rows)`` items."""
    records = _context_records(data, context)
    info = next((_info(r) for r in records if "known" in _info(r) or "box" in _info(r)), {})
    known, box = _known_text(info.get("known")), _box_text(info.get("box"))
    if not known and not box:
        return []
    text = "Assumed (the answer depends on it; problem.known.<name>=value and " \
        "problem.bounds.<name>=[lo,hi] change it):"
    if known:
        text += f" stated, not identified: {known}."
    if box:
        text += f" Searched within the boxes: {box}."
    out: list[tuple[str, list[str], list[list[Any]]]] = [(text, [], [])]
    used = _text(info.get("input"), 4 * MAX_TEXT)
    if used:
        out.append((f"Input used: {escape(used)}.", [], []))
    best = _best(records)
    flags = near_bounds(best) if best is not None else []
    if flags:
        out.append(("On a bound: in the best run, " + "; ".join(flags) + ". The optimum may "
                    "lie outside the box: widen it with problem.bounds.<name>=[lo,hi] (or "
                    "check the stated quantities above).", [], []))
    return out
