"""Typed hyper-parameters: build a frozen dataclass from a config mapping, and back.

``build_dataclass(Params, mapping, prefix="optimizer")`` checks every key against the
dataclass fields (nested dataclasses included) and every value against the field's type, so
that ``optimizer.FF=0.8`` or ``problem.noise.level=abc`` fails with one line naming the key,
the bad value and what is allowed, before any work is done. :func:`hydra_node` builds a
plugin's Hydra config node from its dataclass (a third-party plugin needs no YAML).
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, Literal, TypeVar, Union, get_args, get_origin

from .errors import ConfigError

T = TypeVar("T")


def _is_dataclass_type(tp: Any) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


def _type_name(tp: Any) -> str:
    origin = get_origin(tp)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(tp))
    if origin in (Union, types.UnionType):
        return " or ".join(_type_name(a) for a in get_args(tp))
    if tp is type(None):
        return "null"
    return getattr(tp, "__name__", str(tp))


def _coerce(value: Any, tp: Any, key: str) -> Any:
    """Return ``value`` converted to the annotated type ``tp``, or raise ConfigError."""
    origin = get_origin(tp)
    if tp is Any:
        return value
    if origin is Literal:
        if value in get_args(tp):
            return value
        raise ConfigError(key, value, _type_name(tp))
    if origin in (Union, types.UnionType):
        return _coerce_union(value, tp, key)
    if origin in (list, tuple) or tp in (list, tuple):
        return _coerce_sequence(value, tp, origin, key)
    if _is_dataclass_type(tp):
        if isinstance(value, tp):
            return value
        if not isinstance(value, Mapping):
            raise ConfigError(key, value, f"a mapping of {tp.__name__} fields")
        return build_dataclass(tp, value, prefix=key)
    scalar = _SCALARS.get(tp)
    return scalar(value, key) if scalar is not None else value


def _coerce_union(value: Any, tp: Any, key: str) -> Any:
    args = get_args(tp)
    if value is None and type(None) in args:
        return None
    for arg in args:
        if arg is type(None):
            continue
        with contextlib.suppress(ConfigError):
            return _coerce(value, arg, key)
    raise ConfigError(key, value, _type_name(tp))


def _coerce_sequence(value: Any, tp: Any, origin: Any, key: str) -> Any:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise ConfigError(key, value, f"a list ({_type_name(tp)})")
    inner = get_args(tp)
    item_tp = inner[0] if inner else Any
    items = [_coerce(v, item_tp, f"{key}[{i}]") for i, v in enumerate(value)]
    return tuple(items) if (origin is tuple or tp is tuple) else items


def _exactly(tp: type, words: str) -> Any:
    """A check that a value is of type ``tp``, else ``words`` in the error."""
    def check(value: Any, key: str) -> Any:
        if isinstance(value, tp):
            return value
        raise ConfigError(key, value, words)
    return check


def _to_int(value: Any, key: str) -> int:
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    raise ConfigError(key, value, "an integer")


def _to_float(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(key, value, "a real number")
    value = float(value)
    if math.isnan(value):
        raise ConfigError(key, value, "a real number (not NaN)")
    return value


_SCALARS = {bool: _exactly(bool, "true or false"), int: _to_int, float: _to_float,
            str: _exactly(str, "a string")}


def build_dataclass(cls: type[T], mapping: Mapping[str, Any] | None, prefix: str = "") -> T:
    """Instantiate the dataclass ``cls`` from ``mapping``, checking keys and value types
    (missing keys: the field default; ``name`` and ``_``-keys, the node's metadata, ignored).
    ``prefix``: the dotted config path of error messages (``problem.noise``)."""
    mapping = dict(mapping or {})
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    dot = f"{prefix}." if prefix else ""
    unknown = [k for k in mapping if k not in fields and k != "name" and not str(k).startswith("_")]
    if unknown:
        allowed = ", ".join(sorted(fields)) or "(none)"
        raise ConfigError(f"{dot}{unknown[0]}", mapping[unknown[0]], f"known keys are {allowed}")
    kwargs = {}
    for field_name in fields:
        if field_name in mapping:
            kwargs[field_name] = _coerce(mapping[field_name], hints[field_name], dot + field_name)
    try:
        return cls(**kwargs)
    except ConfigError:
        raise
    except (TypeError, ValueError) as exc:
        raise ConfigError(prefix or cls.__name__, kwargs, str(exc)) from exc


#: Field metadata of :func:`added_setting`.
ADDED_SETTING = "vpid_bench_added_setting"
#: Field metadata of a mapping whose keys the user names (``open_keys=True``).
OPEN_KEYS = "vpid_bench_open_keys"


def added_setting(default: Any = dataclasses.MISSING,
                  default_factory: Any = dataclasses.MISSING, open_keys: bool = False) -> Any:
    """A config field added after runs and archives were recorded, whose default reproduces
    the problem as it was: at its default it is left out of a job's settings, so earlier
    records, run ids, optima and archives stay valid. ``open_keys=True``: a mapping whose
    keys the user names (``problem.known.kt=210000`` without Hydra's ``+``); the problem
    checks the names itself."""
    return dataclasses.field(default=default, default_factory=default_factory,
                             metadata={ADDED_SETTING: True, OPEN_KEYS: open_keys})


def open_key_paths(cls: type, prefix: str = "") -> list[str]:
    """The dotted paths of the ``open_keys`` fields of the dataclass ``cls`` (at any depth)."""
    out: list[str] = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        path = f"{prefix}{f.name}"
        if f.metadata.get(OPEN_KEYS):
            out.append(path)
        elif _is_dataclass_type(hints.get(f.name)):
            out.extend(open_key_paths(hints[f.name], path + "."))
    return out


def settings_of(obj: Any) -> Any:
    """:func:`to_plain` of a config, leaving out every :func:`added_setting` field (at any
    depth) whose value equals its default."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out = {}
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            if f.metadata.get(ADDED_SETTING) and value == _default_of(f):
                continue
            out[f.name] = settings_of(value)
        return out
    return to_plain(obj)


def _default_of(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def to_plain(obj: Any) -> Any:
    """A dataclass (possibly nested) as plain JSON-able dicts, lists and scalars."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): to_plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_plain(v) for v in obj]
    return obj


def dataclass_defaults(cls: type) -> dict[str, Any]:
    """The defaults of a dataclass type as a plain nested dict (fields without default: None)."""
    out: dict[str, Any] = {}
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if (default := _default_of(f)) is not dataclasses.MISSING:
            out[f.name] = to_plain(default)
        elif _is_dataclass_type(hints[f.name]):
            out[f.name] = dataclass_defaults(hints[f.name])
        else:
            out[f.name] = None
    return out


def hydra_node(cls: type, name: str, exclude: tuple[str, ...] = ()) -> dict[str, Any]:
    """The Hydra config node of a plugin, ``{"name": name, **defaults}`` without ``exclude``
    (what the job fills in): a third-party plugin needs no YAML."""
    node: dict[str, Any] = {"name": name}
    node.update({k: v for k, v in dataclass_defaults(cls).items() if k not in exclude})
    return node
