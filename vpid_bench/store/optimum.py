"""The instance-optimum file (``optima/<key>.json``, and a line of an archive's
``optima.jsonl``): its schema string, size cap, one reader and check (every field: result
folders and archives are untrusted), and which optimum a run record's instance has.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..fileio import json_fault, loads_json
from ..problem import PROTOCOL_KEYS
from .job_checks import finite as _finite  # (the report imports the name)
from .records import write_json_atomic

#: The schema string of an optimum file (written by vpid_bench.analysis.optimum).
SCHEMA = "vpid-bench/instance-optimum/1"
#: A larger optimum file is not read (bytes): a real one holds a few vectors.
MAX_BYTES = 1_000_000


@dataclasses.dataclass(frozen=True)
class Optimum:
    """One checked optimum file."""

    path: Path
    problem: str
    instance: str | None
    settings: Mapping[str, Any] | None
    x_opt: tuple[float, ...]
    f_opt: float
    f_true: float | None
    metrics: Mapping[str, float]
    starts: int
    #: The checked data as read (what an archive writes as the instance's line).
    data: Mapping[str, Any] = dataclasses.field(default_factory=dict, repr=False)


def check_optimum(data: Any) -> str | None:
    """The first bad field of a parsed optimum file as ``"<field>: expected ..."``, or None."""
    if not isinstance(data, Mapping):
        return "the file: expected a JSON object"
    checks: list[tuple[str, bool, str]] = [
        ("schema", data.get("schema") == SCHEMA, repr(SCHEMA)),
        ("problem", isinstance(data.get("problem"), str) and bool(data.get("problem")),
         "a text"),
        ("instance", data.get("instance") is None or isinstance(data.get("instance"), str),
         "a text or null"),
        ("settings", data.get("settings") is None or isinstance(data.get("settings"), Mapping),
         "a mapping or absent"),
        ("data", data.get("data") is None or isinstance(data.get("data"), str),
         "a text (the data's digest) or absent"),
        ("x_opt", isinstance(data.get("x_opt"), list) and len(data["x_opt"]) > 0
         and all(_finite(v) for v in data["x_opt"]), "a non-empty list of finite numbers"),
        ("f_opt", _finite(data.get("f_opt")), "a finite number"),
        ("f_true", data.get("f_true") is None or _finite(data.get("f_true")),
         "a finite number or null"),
        ("metrics", isinstance(data.get("metrics") or {}, Mapping)
         and all(isinstance(k, str) and _finite(v)
                 for k, v in (data.get("metrics") or {}).items()),
         "a mapping of names to finite numbers"),
        ("starts", isinstance(data.get("starts"), int) and not isinstance(data["starts"], bool)
         and data["starts"] >= 1, "a positive integer"),
    ]
    for name, ok, expected in checks:
        if not ok:
            return f"{name}: expected {expected}"
    return None


def read_optimum_data(path: Path) -> tuple[dict[str, Any] | None, str | None]:
    """``(data, None)`` for a good optimum file (every field checked), ``(None, why)`` for a
    bad one: not a regular file, over :data:`MAX_BYTES`, unreadable, or a bad field."""
    try:
        path = Path(path)
        if path.is_symlink() or not path.is_file():
            return None, "not a regular file"
        if path.stat().st_size > MAX_BYTES:
            return None, f"larger than {MAX_BYTES} bytes"
        data = loads_json(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        return None, f"unreadable: {json_fault(exc)}"
    bad = check_optimum(data)
    return (None, f"field {bad}") if bad else (data, None)


def write_optimum_file(path: Path, data: Mapping[str, Any]) -> Path:
    """Write the optimum ``data`` to ``path`` atomically, after the reader's checks (a file
    this writes is always one the reader takes)."""
    bad = check_optimum(data)
    if bad:
        raise ValueError(f"not an optimum file: field {bad}")
    return write_json_atomic(path, data)


def read_optimum_file(path: Path) -> tuple[Optimum | None, str | None]:
    """``(optimum, None)`` for a good file, ``(None, why)`` for a bad one."""
    data, why = read_optimum_data(path)
    return (None, why) if data is None else optimum_from_data(data, path)


def optimum_from_data(data: Any, path: Path) -> tuple[Optimum | None, str | None]:
    """``(optimum, None)`` for parsed data that passes :func:`check_optimum` (from a file,
    or a line of the archive named by ``path``), ``(None, why)`` otherwise."""
    bad = check_optimum(data)
    if bad:
        return None, f"field {bad}"
    return Optimum(path=path, problem=data["problem"], instance=data.get("instance"),
                   settings=data.get("settings"),
                   x_opt=tuple(float(v) for v in data["x_opt"]), f_opt=float(data["f_opt"]),
                   f_true=None if data.get("f_true") is None else float(data["f_true"]),
                   metrics={k: float(v) for k, v in (data.get("metrics") or {}).items()},
                   starts=int(data["starts"]), data=data), None


@dataclasses.dataclass
class OptimaIndex:
    """The checked optimum files found for a report, and the files skipped (with why)."""

    optima: list[Optimum]
    skipped: list[tuple[Path, str]]


def _data_settings(settings: Mapping[str, Any] | None) -> str | None:
    """The settings that define an instance's data (protocol keys left out), canonical."""
    if settings is None:
        return None
    return json.dumps({k: v for k, v in settings.items() if k not in PROTOCOL_KEYS},
                      sort_keys=True, default=str)


def matching_optima(record: Mapping[str, Any], index: OptimaIndex) -> list[Optimum]:
    """Every optimum of a record's instance: the same problem, instance id, data settings
    (protocol keys left out) and dimension; one without settings only by a non-null id."""
    problem = record["problem"]["name"]
    inst = (record.get("instance") or {}).get("id") if isinstance(
        record.get("instance"), Mapping) else None
    inst = inst if isinstance(inst, str) else None
    settings = _data_settings(record["problem"].get("config") or {})
    dim = len((record.get("parameters") or {}).get("names") or [])
    found = []
    for o in index.optima:
        if o.problem != problem or o.instance != inst or len(o.x_opt) != dim:
            continue
        if o.settings is None:
            if inst is None:
                continue
        elif _data_settings(o.settings) != settings:
            continue
        found.append(o)
    return found


def match_optimum(record: Mapping[str, Any], index: OptimaIndex) -> Optimum | None:
    """The lowest of :func:`matching_optima` (several files may hold optima of one instance,
    e.g. one per population size of a sweep), the best known."""
    return min(matching_optima(record, index), key=lambda o: o.f_opt, default=None)
