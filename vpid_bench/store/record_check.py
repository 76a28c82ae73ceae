"""The fields of a record: the one check every reader of records uses.

A record on disk may have been edited by hand or by anyone: a field of the wrong type (a
``run_index`` of ``"three"``, an ``f_best`` of ``"small"``), a count below zero, a name of
200,000 characters (a report over it once ran past 300 s at 3 GB) or a run index that
contradicts the record's file name (the report once counted that run twice on one instance
and never on the other) must neither crash the report nor be trusted by a resumed job.
:func:`check_record` names the first bad field; the report (:mod:`vpid_bench.report.load`,
the archive loader) skips such a record with that line, and a resumed job
(:mod:`vpid_bench.experiment`) sets it aside and runs that run again.

The rules are a table (:data:`RULES`), one small function per field, checked in order: a
rule may rely on every rule before it (``problem.name`` is read only once ``problem`` is
known to be a mapping).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from typing import Any

from .records import parse_record_name

#: The longest name a record may hold (characters): its problem, optimizer, instance id,
#: run id, parameter names and units, metric names, the keys of its problem config and
#: optimizer parameters, and why it stopped. Registered names are short identifiers (the
#: longest shipped, 28 characters; the shipped archives' longest name of any kind, 25);
#: every table, figure and line of a report shows them.
MAX_NAME_CHARS = 200
#: The longest text value in a record's problem config or optimizer parameters (characters):
#: a file path may be one (Linux allows paths of 4,096 bytes). A varying value is part of
#: the labels every table shows.
MAX_TEXT_CHARS = 4096


def _is_num(v: Any, nullable: bool = True) -> bool:
    return (v is None and nullable) or (isinstance(v, (int, float)) and not isinstance(v, bool))


def _is_int(v: Any, nullable: bool = True) -> bool:
    """An integer of 64 bits (a record's ``run_index`` of 10**400 once overflowed the
    report's float conversion), or ``None`` when ``nullable``."""
    return (v is None and nullable) or (isinstance(v, int) and not isinstance(v, bool)
                                        and -2**63 <= v < 2**63)


def _num_list(v: Any, n: int | None = None) -> bool:
    # a trace holds thousands of numbers: plain floats and ints pass on their type alone
    return isinstance(v, list) and (n is None or len(v) == n) and all(
        type(x) is float or type(x) is int or _is_num(x) for x in v)


def _texts(v: Any) -> bool:
    """A list of texts, or nothing (``None`` or empty)."""
    return isinstance(v or [], list) and all(isinstance(x, str) for x in v or [])


def _name(v: Any) -> bool:
    """Not a text, or a text of at most :data:`MAX_NAME_CHARS` characters (its type is
    another rule's)."""
    return not isinstance(v, str) or len(v) <= MAX_NAME_CHARS


def _section(record: Mapping[str, Any], key: str) -> Any:
    """``record[key]``, ``{}`` when it is missing or null (the type rules before the
    section's fields have refused anything but a mapping)."""
    return record.get(key) or {}


# One rule per field: each takes a record and says whether that field is good.

def _run_id(r: Mapping[str, Any]) -> bool:
    return isinstance(r.get("run_id"), str) and bool(r.get("run_id"))


def _run_index(r: Mapping[str, Any]) -> bool:
    return _is_int(r.get("run_index"), False) and r["run_index"] >= 0


def _status(r: Mapping[str, Any]) -> bool:
    return r.get("status") in ("ok", "failed")


def _problem(r: Mapping[str, Any]) -> bool:
    return isinstance(r.get("problem"), Mapping)


def _problem_name(r: Mapping[str, Any]) -> bool:
    return isinstance(r["problem"].get("name"), str)


def _problem_config(r: Mapping[str, Any]) -> bool:
    return isinstance(r["problem"].get("config") or {}, Mapping)


def _problem_info(r: Mapping[str, Any]) -> bool:
    return isinstance(r["problem"].get("info") or {}, Mapping)


def _optimizer(r: Mapping[str, Any]) -> bool:
    return isinstance(r.get("optimizer"), Mapping)


def _optimizer_name(r: Mapping[str, Any]) -> bool:
    return isinstance(r["optimizer"].get("name"), str)


def _optimizer_params(r: Mapping[str, Any]) -> bool:
    return isinstance(r["optimizer"].get("params") or {}, Mapping)


def _seeds(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "seeds"), Mapping)


def _seed(r: Mapping[str, Any]) -> bool:
    return _is_int(_section(r, "seeds").get("seed"))


def _instance(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "instance"), Mapping)


def _instance_id(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "instance").get("id"), (str, type(None)))


def _instance_index(r: Mapping[str, Any]) -> bool:
    """Run ``i`` fits instance ``i``: an index that is not the run's contradicts it."""
    index = _section(r, "instance").get("index", r["run_index"])
    return index == r["run_index"] and not isinstance(index, bool)


def _budget(r: Mapping[str, Any]) -> bool:
    return _is_int(r.get("budget"))


def _parameters(r: Mapping[str, Any]) -> bool:
    return isinstance(r.get("parameters"), Mapping)


def _parameter_names(r: Mapping[str, Any]) -> bool:
    return _texts(r["parameters"].get("names"))


def _parameter_units(r: Mapping[str, Any]) -> bool:
    return _texts(r["parameters"].get("units"))


def _true(r: Mapping[str, Any]) -> bool:
    return r["parameters"].get("true") is None or _num_list(r["parameters"]["true"])


def _result(r: Mapping[str, Any]) -> bool:
    return r.get("result") is None or isinstance(r.get("result"), Mapping)


def _ok_result(r: Mapping[str, Any]) -> bool:
    return r.get("status") != "ok" or isinstance(r.get("result"), Mapping)


def _x_best(r: Mapping[str, Any]) -> bool:
    x = _section(r, "result").get("x_best")
    return x is None or _num_list(x)


def _f_best(r: Mapping[str, Any]) -> bool:
    return _is_num(_section(r, "result").get("f_best"))


def _evaluations(r: Mapping[str, Any]) -> bool:
    """A count: -1 evaluations once passed, and the report counted the run."""
    n = _section(r, "result").get("evaluations")
    return _is_int(n) and (n is None or n >= 0)


def _metrics(r: Mapping[str, Any]) -> bool:
    metrics = _section(r, "result").get("metrics") or {}
    return isinstance(metrics, Mapping) and all(
        isinstance(k, str) and _is_num(v) for k, v in metrics.items())


def _rel_error(r: Mapping[str, Any]) -> bool:
    eps = _section(r, "result").get("rel_error_percent")
    return eps is None or _num_list(eps)


def _stopped_by(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "result").get("stopped_by"), (str, type(None)))


def _trace(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "trace"), Mapping)


def _trace_evaluations(r: Mapping[str, Any]) -> bool:
    return _num_list(_section(r, "trace").get("evaluations") or [])


def _trace_best(r: Mapping[str, Any]) -> bool:
    return _num_list(_section(r, "trace").get("best") or [])


def _trace_lengths(r: Mapping[str, Any]) -> bool:
    trace = _section(r, "trace")
    return len(trace.get("best") or []) == len(trace.get("evaluations") or [])


def _trace_batch(r: Mapping[str, Any]) -> bool:
    return _num_list(_section(r, "trace").get("batch") or [])


def _timing(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "timing"), Mapping)


def _wall_time(r: Mapping[str, Any]) -> bool:
    return _is_num(_section(r, "timing").get("wall_time_s"))


def _run_time(r: Mapping[str, Any]) -> bool:
    return _is_num(_section(r, "timing").get("run_time_s"))


def _error(r: Mapping[str, Any]) -> bool:
    return isinstance(_section(r, "error"), Mapping)


def _short_names(names: Callable[[Mapping[str, Any]], Iterable[Any]]
                 ) -> Callable[[Mapping[str, Any]], bool]:
    """A rule: every name ``names(record)`` gives is short (:data:`MAX_NAME_CHARS`)."""
    return lambda r: all(_name(v) for v in names(r))


def _leaves(tree: Any) -> Iterator[tuple[bool, Any]]:
    """``(is a key, value)`` of every key and leaf of nested mappings and lists, without
    recursion (a record read from a file nests at most
    :data:`~vpid_bench.fileio.MAX_JSON_DEPTH` deep; one made in memory, anything)."""
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
    """A rule: the keys of ``record[section][key]`` (the problem config, the optimizer
    parameters) are short names and its texts at most :data:`MAX_TEXT_CHARS` long: a
    varying one is part of the labels every table shows."""
    return lambda r: all(
        _name(v) if is_key else not isinstance(v, str) or len(v) <= MAX_TEXT_CHARS
        for is_key, v in _leaves(r[section].get(key)))


Rule = tuple[str, Callable[[Mapping[str, Any]], bool], str]

#: ``(field, rule, what was expected)``, in the order they are checked.
RULES: tuple[Rule, ...] = (
    ("run_id", _run_id, "a text"),
    ("run_index", _run_index, "an integer from 0 to 2**63 - 1"),
    ("status", _status, "'ok' or 'failed'"),
    ("problem", _problem, "a mapping"),
    ("problem.name", _problem_name, "a text"),
    ("problem.config", _problem_config, "a mapping"),
    ("problem.info", _problem_info, "a mapping"),
    ("optimizer", _optimizer, "a mapping"),
    ("optimizer.name", _optimizer_name, "a text"),
    ("optimizer.params", _optimizer_params, "a mapping"),
    ("seeds", _seeds, "a mapping"),
    ("seeds.seed", _seed, "an integer"),
    ("instance", _instance, "a mapping or null"),
    ("instance.id", _instance_id, "a text or null"),
    ("instance.index", _instance_index, "the run's run_index (run i fits instance i)"),
    ("budget", _budget, "an integer or null"),
    ("parameters", _parameters, "a mapping"),
    ("parameters.names", _parameter_names, "a list of texts"),
    ("parameters.units", _parameter_units, "a list of texts"),
    ("parameters.true", _true, "a list of numbers or null"),
    ("result", _result, "a mapping or null"),
    ("result", _ok_result, "a mapping for an ok run"),
    ("result.x_best", _x_best, "a list of numbers"),
    ("result.f_best", _f_best, "a number"),
    ("result.evaluations", _evaluations, "an integer from 0 (a count)"),
    ("result.metrics", _metrics, "a mapping of names to numbers"),
    ("result.rel_error_percent", _rel_error, "a list of numbers"),
    ("result.stopped_by", _stopped_by, "a text"),
    ("trace", _trace, "a mapping"),
    ("trace.evaluations", _trace_evaluations, "a list of numbers"),
    ("trace.best", _trace_best, "a list of numbers"),
    ("trace.best", _trace_lengths, "one value per entry of trace.evaluations"),
    ("trace.batch", _trace_batch, "a list of numbers (an archive's batch numbers)"),
    ("timing", _timing, "a mapping"),
    ("timing.wall_time_s", _wall_time, "a number"),
    ("timing.run_time_s", _run_time, "a number"),
    ("error", _error, "a mapping or null"),
    # the names a report shows, once every type above is known
    *((field, _short_names(names), f"a name of at most {MAX_NAME_CHARS} characters")
      for field, names in (
        ("run_id", lambda r: [r["run_id"]]),
        ("problem.name", lambda r: [r["problem"]["name"]]),
        ("optimizer.name", lambda r: [r["optimizer"]["name"]]),
        ("instance.id", lambda r: [_section(r, "instance").get("id")]),
        ("parameters.names", lambda r: r["parameters"].get("names") or []),
        ("parameters.units", lambda r: r["parameters"].get("units") or []),
        ("result.metrics", lambda r: _section(r, "result").get("metrics") or {}),
        ("result.stopped_by", lambda r: [_section(r, "result").get("stopped_by")]))),
    ("problem.config", _short_settings("problem", "config"),
     f"keys of at most {MAX_NAME_CHARS} characters and texts of at most {MAX_TEXT_CHARS}"),
    ("optimizer.params", _short_settings("optimizer", "params"),
     f"keys of at most {MAX_NAME_CHARS} characters and texts of at most {MAX_TEXT_CHARS}"),
)


def _file_name_rule(record: Mapping[str, Any], file_name: str) -> str | None:
    """A record file is named ``run-<run_index>-<run_id>.json``
    (:func:`~vpid_bench.store.records.record_path`): a record whose fields say another run
    than its name (a ``run_index`` edited by hand) is not the run its name claims."""
    named = parse_record_name(file_name)
    if named is None:
        return None
    if record["run_index"] != named[0]:
        return f"run_index: expected {named[0]}, the run index its file name {file_name} gives"
    if record["run_id"] != named[1]:
        return f"run_id: expected {named[1]}, the run id its file name {file_name} gives"
    return None


def check_record(record: Mapping[str, Any], file_name: str | None = None) -> str | None:
    """The first bad field of a (schema-valid) record, as ``"<field>: expected <what>"``, or
    ``None`` when every field the report and a resumed job read is good (:data:`RULES`).
    ``file_name``: the name of the file the record was read from, whose run index and run id
    the record's must be (a line of an archive has none). Records are untrusted input: the
    report skips a bad one with this line, and a resumed job sets it aside and runs that run
    again."""
    for path, rule, expected in RULES:
        if not rule(record):
            return f"{path}: expected {expected}"
    return None if file_name is None else _file_name_rule(record, file_name)
