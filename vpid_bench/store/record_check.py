"""The types of a record's fields: the one check every reader of records uses.

A record on disk may have been edited by hand or by anyone: a field of the wrong type (a
``run_index`` of ``"three"``, an ``f_best`` of ``"small"``) must neither crash the report nor
be trusted by a resumed job. :func:`check_record` names the first bad field; the report
(:mod:`vpid_bench.report.load`, the archive loader) skips such a record with that line, and
a resumed job (:mod:`vpid_bench.experiment`) sets it aside and runs that run again.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


def _is_num(v: Any, nullable: bool = True) -> bool:
    return (v is None and nullable) or (isinstance(v, (int, float)) and not isinstance(v, bool))


def _is_int(v: Any, nullable: bool = True) -> bool:
    """An integer of 64 bits (a record's ``run_index`` of 10**400 once overflowed the
    report's float conversion), or ``None`` when ``nullable``."""
    return (v is None and nullable) or (isinstance(v, int) and not isinstance(v, bool)
                                        and -2**63 <= v < 2**63)


def _num_list(v: Any, n: int | None = None) -> bool:
    return isinstance(v, list) and all(_is_num(x) for x in v) and (n is None or len(v) == n)


def check_record(record: Mapping[str, Any]) -> str | None:
    """The first field of a (schema-valid) record whose value has the wrong type, as
    ``"<field>: <what was expected>"``, or ``None`` when every field the report and a
    resumed job read is well-typed. Records are untrusted input: the report skips a bad one
    with this line, and a resumed job sets it aside and runs that run again."""
    def field(path: str, ok: bool, expected: str) -> str | None:
        return None if ok else f"{path}: expected {expected}"

    get = record.get
    checks: list[tuple[str, Any, str]] = [
        ("run_id", lambda: isinstance(get("run_id"), str) and get("run_id"), "a text"),
        ("run_index", lambda: _is_int(get("run_index"), False) and get("run_index") >= 0,
         "an integer from 0 to 2**63 - 1"),
        ("status", lambda: get("status") in ("ok", "failed"), "'ok' or 'failed'"),
        ("problem", lambda: isinstance(get("problem"), Mapping), "a mapping"),
        ("problem.name", lambda: isinstance(get("problem").get("name"), str), "a text"),
        ("problem.config", lambda: isinstance(get("problem").get("config") or {}, Mapping),
         "a mapping"),
        ("problem.info", lambda: isinstance(get("problem").get("info") or {}, Mapping),
         "a mapping"),
        ("optimizer", lambda: isinstance(get("optimizer"), Mapping), "a mapping"),
        ("optimizer.name", lambda: isinstance(get("optimizer").get("name"), str), "a text"),
        ("optimizer.params", lambda: isinstance(get("optimizer").get("params") or {}, Mapping),
         "a mapping"),
        ("seeds", lambda: isinstance(get("seeds") or {}, Mapping), "a mapping"),
        ("seeds.seed", lambda: _is_int((get("seeds") or {}).get("seed")), "an integer"),
        ("budget", lambda: _is_int(get("budget")), "an integer or null"),
        ("parameters", lambda: isinstance(get("parameters"), Mapping), "a mapping"),
        ("parameters.names", lambda: isinstance(get("parameters").get("names") or [], list)
         and all(isinstance(n, str) for n in get("parameters").get("names") or []),
         "a list of texts"),
        ("parameters.units", lambda: isinstance(get("parameters").get("units") or [], list)
         and all(isinstance(u, str) for u in get("parameters").get("units") or []),
         "a list of texts"),
        ("parameters.true", lambda: get("parameters").get("true") is None
         or _num_list(get("parameters")["true"]), "a list of numbers or null"),
        ("result", lambda: get("result") is None or isinstance(get("result"), Mapping),
         "a mapping or null"),
        ("result", lambda: get("status") != "ok" or isinstance(get("result"), Mapping),
         "a mapping for an ok run"),
        ("result.x_best", lambda: (get("result") or {}).get("x_best") is None
         or _num_list(get("result")["x_best"]), "a list of numbers"),
        ("result.f_best", lambda: _is_num((get("result") or {}).get("f_best")), "a number"),
        ("result.evaluations", lambda: _is_int((get("result") or {}).get("evaluations")),
         "an integer"),
        ("result.metrics", lambda: isinstance((get("result") or {}).get("metrics") or {},
                                              Mapping)
         and all(isinstance(k, str) and _is_num(v)
                 for k, v in ((get("result") or {}).get("metrics") or {}).items()),
         "a mapping of names to numbers"),
        ("result.rel_error_percent",
         lambda: (get("result") or {}).get("rel_error_percent") is None
         or _num_list(get("result")["rel_error_percent"]), "a list of numbers"),
        ("result.stopped_by", lambda: isinstance((get("result") or {}).get("stopped_by"),
                                                 (str, type(None))), "a text"),
        ("trace", lambda: isinstance(get("trace") or {}, Mapping), "a mapping"),
        ("trace.evaluations", lambda: _num_list((get("trace") or {}).get("evaluations") or []),
         "a list of numbers"),
        ("trace.best", lambda: _num_list((get("trace") or {}).get("best") or []),
         "a list of numbers"),
        ("trace.best", lambda: len((get("trace") or {}).get("best") or [])
         == len((get("trace") or {}).get("evaluations") or []),
         "one value per entry of trace.evaluations"),
        ("trace.batch", lambda: _num_list((get("trace") or {}).get("batch") or []),
         "a list of numbers (an archive's batch numbers)"),
        ("timing", lambda: isinstance(get("timing") or {}, Mapping), "a mapping"),
        ("timing.wall_time_s", lambda: _is_num((get("timing") or {}).get("wall_time_s")),
         "a number"),
        ("timing.run_time_s", lambda: _is_num((get("timing") or {}).get("run_time_s")),
         "a number"),
        ("error", lambda: isinstance(get("error") or {}, Mapping), "a mapping or null"),
    ]
    for path, test, expected in checks:
        bad = field(path, bool(test()), expected)
        if bad:
            return bad
    return None
