"""Run records on disk: the schema version, atomic JSON writes, reading and checking.

A record says everything needed to repeat a run (config, seeds, versions) and to judge it; it
is strict JSON, a non-finite float written as ``"inf"``, ``"-inf"`` or ``"nan"`` and read back
as a float in the numeric fields (:func:`read_record`). The run id in each file name
(:func:`record_path`) hashes what determines the result, so a re-run of the job recognises its
records (two runs of one config and seed differ only in ``timing``).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..fileio import loads_json, read_text_limited, write_text_atomic

SCHEMA = "vpid-bench/run-record/2"
#: Schemas of earlier vpid-bench versions: recognised, so a reader can say so in one line.
OLD_SCHEMAS = ("vpid-bench/run-record/1",)
RECORDS_DIR = "records"


class CorruptRecordError(ValueError):
    """A record file exists but is not a complete, valid run record."""


class OldRecordError(CorruptRecordError):
    """A complete record written by an earlier vpid-bench (an older schema version)."""


#: How a non-finite float is read back (strict JSON has no inf or nan).
NONFINITE_VALUE = {"inf": math.inf, "-inf": -math.inf, "nan": math.nan}
#: The numeric fields of a record: (section, key); ``*`` marks a list or a mapping of numbers.
NUMERIC_FIELDS = (
    ("result", "f_best"), ("result", "x_best*"), ("result", "metrics*"),
    ("result", "rel_error_percent*"), ("parameters", "true*"), ("trace", "best*"),
    ("trace", "evaluations*"), ("timing", "wall_time_s"), ("timing", "run_time_s"),
)


def _float_text(value: float) -> float | str:
    """A float as strict JSON: itself, or ``"nan"``, ``"inf"``, ``"-inf"``."""
    if math.isfinite(value):
        return value
    return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")


def decode_number(value: Any) -> Any:
    """``"inf"``, ``"-inf"``, ``"nan"`` as floats; anything else unchanged."""
    return NONFINITE_VALUE[value] if isinstance(value, str) and value in NONFINITE_VALUE else value


def decode_numbers(record: dict[str, Any]) -> dict[str, Any]:
    """``record`` with its numeric fields' non-finite markers made floats (in place)."""
    for section, key in NUMERIC_FIELDS:
        node = record.get(section)
        many = key.endswith("*")
        key = key.rstrip("*")
        if not isinstance(node, dict) or key not in node:
            continue
        value = node[key]
        if not many:
            node[key] = decode_number(value)
        elif isinstance(value, list):
            node[key] = [decode_number(v) for v in value]
        elif isinstance(value, dict):
            node[key] = {k: decode_number(v) for k, v in value.items()}
    return record


def _jsonable(obj: Any) -> Any:
    """Numpy scalars and arrays and non-finite floats as strict-JSON values."""
    kind = type(obj)
    if kind is float:  # the common leaves first: a record's traces are long lists of them
        return _float_text(obj)
    if kind is int or kind is str or kind is bool or obj is None:
        return obj
    if isinstance(obj, (list, tuple)):
        if all(type(v) is int or (type(v) is float and math.isfinite(v)) for v in obj):
            return list(obj)  # already strict JSON: no call per element
        return [_jsonable(v) for v in obj]
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "iub" or (obj.dtype.kind == "f" and np.isfinite(obj).all()):
            return obj.tolist()
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (np.floating, float)):
        return _float_text(float(obj))
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def canonical_json(obj: Any) -> str:
    """Compact JSON with sorted keys: the form hashed into ids."""
    return json.dumps(_jsonable(obj), sort_keys=True, separators=(",", ":"), allow_nan=False)


def stable_hash(obj: Any, length: int = 16) -> str:
    """First ``length`` hex digits of the SHA-256 of ``canonical_json(obj)``."""
    return hashlib.sha256(canonical_json(obj).encode()).hexdigest()[:length]


def run_id(key: Mapping[str, Any], run_index: int) -> str:
    """Deterministic id of run ``run_index`` of the job described by ``key``."""
    return stable_hash({**key, "run_index": run_index})


def record_path(job_dir: Path, run_index: int, rid: str) -> Path:
    """Where the record of run ``run_index`` with id ``rid`` lives in ``job_dir``."""
    return Path(job_dir) / RECORDS_DIR / f"run-{run_index:03d}-{rid}.json"


def parse_record_name(name: str) -> tuple[int, str] | None:
    """``(run_index, run_id)`` of a record's file name (:func:`record_path`), or ``None``."""
    match = re.fullmatch(r"run-(\d+)-(\w+)\.json", name)
    return None if match is None else (int(match.group(1)), match.group(2))


def write_json_atomic(path: Path, obj: Any) -> Path:
    """``obj`` as strict, indented JSON (sorted keys), written with :func:`write_text_atomic`."""
    text = json.dumps(_jsonable(obj), indent=1, sort_keys=True, allow_nan=False) + "\n"
    return write_text_atomic(path, text)


#: Written as every JSON file of a job is.
write_record = write_json_atomic

REQUIRED_KEYS = ("schema", "run_id", "run_index", "status", "problem", "optimizer", "seeds",
                 "instance", "budget", "parameters", "result", "trace", "versions", "timing")


def read_record(path: Path) -> dict[str, Any]:
    """Load and check one record; :class:`CorruptRecordError` names the file and the fault."""
    path = Path(path)
    try:
        record = loads_json(read_text_limited(path))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CorruptRecordError(f"{path}: not a readable JSON run record ({exc})") from exc
    return parse_record(record, str(path))


def parse_record(record: Any, where: str) -> dict[str, Any]:
    """Check one parsed record (from a file, or a line of an archive named by ``where``):
    :class:`CorruptRecordError` names ``where`` and the fault."""
    schema = record.get("schema") if isinstance(record, dict) else None
    if schema in OLD_SCHEMAS:
        raise OldRecordError(f"{where}: written by an older vpid-bench ({schema}); this "
                             f"version reads {SCHEMA}: run the job again to include it")
    if schema != SCHEMA:
        raise CorruptRecordError(f"{where}: not a vpid-bench run record (schema != {SCHEMA!r})")
    missing = [k for k in REQUIRED_KEYS if k not in record]
    if missing:
        raise CorruptRecordError(f"{where}: incomplete run record, missing {', '.join(missing)}")
    return decode_numbers(record)


def fingerprint(record: Mapping[str, Any]) -> str:
    """Canonical JSON of a record without its ``timing`` section (for determinism checks)."""
    return canonical_json({k: v for k, v in record.items() if k != "timing"})


def iter_record_files(paths: Iterable[Path]) -> Iterator[Path]:
    """Every ``run-*.json`` record file below the given files or folders, sorted."""
    for p in paths:
        p = Path(p)
        if p.is_file():
            yield p
        elif p.is_dir():
            yield from sorted(p.rglob(f"{RECORDS_DIR}/run-*.json"))
