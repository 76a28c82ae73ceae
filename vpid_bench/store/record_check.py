"""The fields of a record: the one check every reader of records uses.

A record on disk is untrusted (docs/report.md, untrusted records): a field of the wrong type,
a count below zero, a name of 200,000 characters (a report over it once ran past 300 s at
3 GB) or a run index that contradicts the file name (once counted twice on one instance).
:func:`check_record` names the first bad field; the report skips such a record with that
line, a resumed job sets it aside and runs that run again. The rules are a table
(:data:`RULES`) checked in order: a rule may rely on every rule before it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

from .records import parse_record_name

#: The longest name a record may hold (characters): problem, optimizer, instance id, run id,
#: parameter names and units, metric names, config keys, why it stopped. Registered names are
#: short (the longest shipped, 28 characters); every table and figure of a report shows them.
MAX_NAME_CHARS = 200
#: The longest text value in a record's problem config or optimizer parameters (characters):
#: a file path may be one (Linux allows paths of 4,096 bytes).
MAX_TEXT_CHARS = 4096


def _is_num(v: Any, nullable: bool = True) -> bool:
    return (v is None and nullable) or (isinstance(v, (int, float)) and not isinstance(v, bool))


def _is_int(v: Any, nullable: bool = True) -> bool:
    """An integer of 64 bits (a ``run_index`` of 10**400 once overflowed the report's float
    conversion), or ``None`` when ``nullable``."""
    return (v is None and nullable) or (isinstance(v, int) and not isinstance(v, bool)
                                        and -2**63 <= v < 2**63)


def _num_list(v: Any) -> bool:
    # a trace holds thousands of numbers: plain floats and ints pass on their type alone
    return isinstance(v, list) and all(type(x) is float or type(x) is int or _is_num(x) for x in v)


def _texts(v: Any) -> bool:
    """A list of texts, or nothing (``None`` or empty)."""
    return isinstance(v or [], list) and all(isinstance(x, str) for x in v or [])


def _name(v: Any) -> bool:
    """Not a text (its type is another rule's), or one of at most :data:`MAX_NAME_CHARS`."""
    return not isinstance(v, str) or len(v) <= MAX_NAME_CHARS


def _sec(record: Mapping[str, Any], key: str) -> Any:
    """``record[key]``, ``{}`` when missing or null (earlier rules refused a non-mapping)."""
    return record.get(key) or {}


def _instance_index(r: Mapping[str, Any]) -> bool:
    """Run ``i`` fits instance ``i``: an index that is not the run's contradicts it."""
    index = _sec(r, "instance").get("index", r["run_index"])
    return index == r["run_index"] and not isinstance(index, bool)


def _short_names(names: Callable[[Mapping[str, Any]], Iterable[Any]]
                 ) -> Callable[[Mapping[str, Any]], bool]:
    """A rule: every name ``names(record)`` gives is short (:data:`MAX_NAME_CHARS`)."""
    return lambda r: all(_name(v) for v in names(r))


def _leaves(tree: Any) -> Iterator[tuple[bool, Any]]:
    """``(is a key, value)`` of every key and leaf of nested mappings and lists, without
    recursion (a record made in memory may nest any depth)."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, Mapping):
            for k, v in node.items():
                yield True, k
                stack.append(v)
        elif isinstance(node, (list, tuple)):
            stack.extend(node)
        else:
            yield False, node


def _short_settings(section: str, key: str) -> Callable[[Mapping[str, Any]], bool]:
    """A rule: the keys of ``record[section][key]`` are short names and its texts at most
    :data:`MAX_TEXT_CHARS` long (a varying one is part of the labels every table shows)."""
    return lambda r: all(
        _name(v) if is_key else not isinstance(v, str) or len(v) <= MAX_TEXT_CHARS
        for is_key, v in _leaves(r[section].get(key)))


Rule = tuple[str, Callable[[Mapping[str, Any]], bool], str]
_SETTINGS = f"keys of at most {MAX_NAME_CHARS} characters and texts of at most {MAX_TEXT_CHARS}"

#: ``(field, rule, what was expected)``, in the order they are checked.
RULES: tuple[Rule, ...] = (
    ("run_id", lambda r: isinstance(r.get("run_id"), str) and bool(r["run_id"]), "a text"),
    ("run_index", lambda r: _is_int(r.get("run_index"), False) and r["run_index"] >= 0,
     "an integer from 0 to 2**63 - 1"),
    ("status", lambda r: r.get("status") in ("ok", "failed"), "'ok' or 'failed'"),
    ("problem", lambda r: isinstance(r.get("problem"), Mapping), "a mapping"),
    ("problem.name", lambda r: isinstance(r["problem"].get("name"), str), "a text"),
    ("problem.config", lambda r: isinstance(r["problem"].get("config") or {}, Mapping),
     "a mapping"),
    ("problem.info", lambda r: isinstance(r["problem"].get("info") or {}, Mapping),
     "a mapping"),
    ("optimizer", lambda r: isinstance(r.get("optimizer"), Mapping), "a mapping"),
    ("optimizer.name", lambda r: isinstance(r["optimizer"].get("name"), str), "a text"),
    ("optimizer.params", lambda r: isinstance(r["optimizer"].get("params") or {}, Mapping),
     "a mapping"),
    ("seeds", lambda r: isinstance(_sec(r, "seeds"), Mapping), "a mapping"),
    ("seeds.seed", lambda r: _is_int(_sec(r, "seeds").get("seed")), "an integer"),
    ("instance", lambda r: isinstance(_sec(r, "instance"), Mapping), "a mapping or null"),
    ("instance.id", lambda r: isinstance(_sec(r, "instance").get("id"), (str, type(None))),
     "a text or null"),
    ("instance.index", _instance_index, "the run's run_index (run i fits instance i)"),
    ("budget", lambda r: _is_int(r.get("budget")), "an integer or null"),
    ("parameters", lambda r: isinstance(r.get("parameters"), Mapping), "a mapping"),
    ("parameters.names", lambda r: _texts(r["parameters"].get("names")), "a list of texts"),
    ("parameters.units", lambda r: _texts(r["parameters"].get("units")), "a list of texts"),
    ("parameters.true", lambda r: r["parameters"].get("true") is None
     or _num_list(r["parameters"]["true"]), "a list of numbers or null"),
    ("result", lambda r: r.get("result") is None or isinstance(r["result"], Mapping),
     "a mapping or null"),
    ("result", lambda r: r.get("status") != "ok" or isinstance(r.get("result"), Mapping),
     "a mapping for an ok run"),
    ("result.x_best", lambda r: _sec(r, "result").get("x_best") is None
     or _num_list(r["result"]["x_best"]), "a list of numbers"),
    ("result.f_best", lambda r: _is_num(_sec(r, "result").get("f_best")), "a number"),
    # a count: -1 evaluations once passed, and the report counted the run
    ("result.evaluations", lambda r: _is_int(n := _sec(r, "result").get("evaluations"))
     and (n is None or n >= 0), "an integer from 0 (a count)"),
    ("result.metrics", lambda r: isinstance(m := _sec(r, "result").get("metrics") or {},
                                            Mapping)
     and all(isinstance(k, str) and _is_num(v) for k, v in m.items()),
     "a mapping of names to numbers"),
    ("result.rel_error_percent", lambda r: _sec(r, "result").get("rel_error_percent") is None
     or _num_list(r["result"]["rel_error_percent"]), "a list of numbers"),
    ("result.stopped_by", lambda r: isinstance(_sec(r, "result").get("stopped_by"),
                                               (str, type(None))), "a text"),
    ("trace", lambda r: isinstance(_sec(r, "trace"), Mapping), "a mapping"),
    ("trace.evaluations", lambda r: _num_list(_sec(r, "trace").get("evaluations") or []),
     "a list of numbers"),
    ("trace.best", lambda r: _num_list(_sec(r, "trace").get("best") or []),
     "a list of numbers"),
    ("trace.best", lambda r: len(_sec(r, "trace").get("best") or [])
     == len(_sec(r, "trace").get("evaluations") or []),
     "one value per entry of trace.evaluations"),
    ("trace.batch", lambda r: _num_list(_sec(r, "trace").get("batch") or []),
     "a list of numbers (an archive's batch numbers)"),
    ("timing", lambda r: isinstance(_sec(r, "timing"), Mapping), "a mapping"),
    ("timing.wall_time_s", lambda r: _is_num(_sec(r, "timing").get("wall_time_s")),
     "a number"),
    ("timing.run_time_s", lambda r: _is_num(_sec(r, "timing").get("run_time_s")), "a number"),
    ("error", lambda r: isinstance(_sec(r, "error"), Mapping), "a mapping or null"),
    # the names a report shows, once every type above is known
    *((field, _short_names(names), f"a name of at most {MAX_NAME_CHARS} characters")
      for field, names in (
        ("run_id", lambda r: [r["run_id"]]),
        ("problem.name", lambda r: [r["problem"]["name"]]),
        ("optimizer.name", lambda r: [r["optimizer"]["name"]]),
        ("instance.id", lambda r: [_sec(r, "instance").get("id")]),
        ("parameters.names", lambda r: r["parameters"].get("names") or []),
        ("parameters.units", lambda r: r["parameters"].get("units") or []),
        ("result.metrics", lambda r: _sec(r, "result").get("metrics") or {}),
        ("result.stopped_by", lambda r: [_sec(r, "result").get("stopped_by")]))),
    ("problem.config", _short_settings("problem", "config"), _SETTINGS),
    ("optimizer.params", _short_settings("optimizer", "params"), _SETTINGS),
)


def check_record(record: Mapping[str, Any], file_name: str | None = None) -> str | None:
    """The first bad field of a (schema-valid) record, as ``"<field>: expected <what>"``, or
    ``None`` (:data:`RULES`). ``file_name``: the file it was read from (an archive's line has
    none), named ``run-<run_index>-<run_id>.json``: a record whose fields say another run (a
    ``run_index`` edited by hand) is not the run its name claims."""
    for path, rule, expected in RULES:
        if not rule(record):
            return f"{path}: expected {expected}"
    named = None if file_name is None else parse_record_name(file_name)
    if named is not None and record["run_index"] != named[0]:
        return f"run_index: expected {named[0]}, the run index its file name {file_name} gives"
    if named is not None and record["run_id"] != named[1]:
        return f"run_id: expected {named[1]}, the run id its file name {file_name} gives"
    return None
