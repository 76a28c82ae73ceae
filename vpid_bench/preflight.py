"""Pre-flight checks of the command line, before Hydra composes anything.

Hydra's own messages for a bad override are several lines long and often do not say what
*is* allowed (``optimizer.FF=1`` gives "Key 'FF' is not in struct"). The registry knows every
problem's ``Config`` and optimizer's ``Params`` dataclass, so this module checks each
command-line override against them and raises :class:`ConfigError` naming the key, the bad
value and what is allowed. Every element of a sweep (``a,b,c``, ``range()``, ``choice()``,
``glob()``) is checked, so a sweep stops before its first job rather than in its tenth.

Only types and the framework's own ranges (``runs >= 1``, ``seed >= 0``, ...) are checked
here; a plugin's semantic checks (a noise level >= 0, a1 inside the wheelbase) run when the
job builds the problem, still before any run starts. Anything this module does not
understand (``hydra.*`` overrides, interpolations, deletions) is left to Hydra.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.resources
import os
import tempfile
import typing
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from .api import ConfigError
from .params import _coerce
from .plugins import Registry

GROUPS = ("problem", "optimizer")

#: The framework's top-level keys: (type, minimum, null allowed). Kept in step with
#: conf/config.yaml and vpid_bench.experiment.TOP_LEVEL_KEYS.
TOP_LEVEL: dict[str, tuple[type, int | None, bool]] = {
    "seed": (int, 0, False),
    "runs": (int, 1, False),
    "budget": (int, 1, True),
    "resume": (bool, None, False),
    "progress": (bool, None, False),
    "report": (bool, None, False),
}

#: Protocol fields every problem and optimizer has, and their least allowed value.
PROTOCOL_MINIMUM = {"ps": 1, "iterations": 1}


@dataclasses.dataclass
class CommandLine:
    """What pre-flight learned from the command line."""

    overrides: list[str]
    multirun: bool
    custom_config: bool  # --config-name/--config-path/--config-dir: skip our checks
    info_only: bool  # --help, --cfg, --info, ...: nothing runs


def split_command_line(argv: Sequence[str]) -> CommandLine | None:
    """Hydra's own argument parser applied to ``argv``; None when Hydra would reject it
    (Hydra then prints its usage message)."""
    from hydra._internal.utils import get_args_parser

    parser = get_args_parser()
    try:
        with open(os.devnull, "w") as devnull, contextlib.redirect_stderr(devnull):
            args = parser.parse_args(list(argv))
    except SystemExit:
        return None
    info_only = bool(
        args.help or args.hydra_help or args.cfg or args.info or args.shell_completion
        or args.experimental_rerun
    )
    return CommandLine(
        overrides=list(args.overrides or []),
        multirun=bool(args.multirun),
        custom_config=bool(args.config_name or args.config_path or args.config_dir),
        info_only=info_only,
    )


def primary_config() -> Any:
    """conf/config.yaml as an (unresolved) OmegaConf node."""
    from omegaconf import OmegaConf

    text = importlib.resources.files("vpid_bench.conf").joinpath("config.yaml").read_text()
    return OmegaConf.create(text)


def default_choices(primary: Any) -> dict[str, str]:
    """The default problem and optimizer named in the primary config's defaults list."""
    out: dict[str, str] = {}
    for item in primary.get("defaults", []):
        if isinstance(item, Mapping):
            for group, choice in item.items():
                if group in GROUPS:
                    out[group] = str(choice)
    return out


def parse_overrides(overrides: Sequence[str]) -> list[Any]:
    """Hydra's parsed ``Override`` objects; a syntax error becomes one ConfigError line."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import OverrideParseException

    parser = OverridesParser.create()
    parsed = []
    for text in overrides:
        try:
            parsed.extend(parser.parse_overrides([text]))
        except OverrideParseException as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else "syntax error"
            raise ConfigError(
                "override", text, f"key=value, a sweep key=a,b,c or +key=value ({first})"
            ) from None
    return parsed


def _values(override: Any, names: Iterable[str] = ()) -> list[Any]:
    """Every value an override stands for (one, or each element of a sweep)."""
    from hydra.core.override_parser.types import Glob

    value = override.value()
    if isinstance(value, Glob):
        return list(value.filter(sorted(names)))
    if override.is_sweep_override():
        try:
            return list(override.sweep_iterator())
        except Exception:  # interval() and other non-enumerable sweeps: leave to Hydra
            return []
    return [value]


def _raw_value(override: Any) -> str:
    """The value of an override as typed (``a,b`` for a sweep)."""
    return str(override.input_line).split("=", 1)[-1]


def _is_interpolation(value: Any) -> bool:
    return isinstance(value, str) and "${" in value


def yaml_presets(group: str) -> dict[str, str]:
    """Presets shipped as ``conf/<group>/<name>.yaml``, each mapped to the registered plugin
    name it extends (the first entry of its defaults list, followed through other presets)."""
    from omegaconf import OmegaConf

    folder = importlib.resources.files("vpid_bench.conf").joinpath(group)
    if not folder.is_dir():
        return {}
    parent: dict[str, str | None] = {}
    for entry in folder.iterdir():
        if entry.name.endswith(".yaml"):
            node = OmegaConf.create(entry.read_text())
            bases = [d for d in node.get("defaults", []) if isinstance(d, str) and d != "_self_"]
            parent[entry.name[: -len(".yaml")]] = bases[0] if bases else None
    out: dict[str, str] = {}
    for name in parent:
        current, seen = name, set()
        while current in parent and current not in seen and parent[current] is not None:
            seen.add(current)
            current = parent[current]
        if current is not None and current not in parent:
            out[name] = current
    return out


def _unknown_name(kind: str, name: Any, registry: Registry) -> ConfigError:
    table = {**(registry.optimizers if kind == "optimizer" else registry.problems),
             **yaml_presets(kind)}
    allowed = "one of " + ", ".join(sorted(table)) if table else "none is registered"
    failed = getattr(registry.pm, "vpid_bench_info", None)
    if failed is not None and failed.failed:
        allowed += " (plugins that failed to import: " + ", ".join(
            f"{n}: {why}" for n, why in sorted(failed.failed.items())
        ) + ")"
    return ConfigError(kind, name, allowed)


def check_top_level(key: str, value: Any) -> None:
    """Type and range of one of the framework's own top-level keys."""
    tp, minimum, nullable = TOP_LEVEL[key]
    if value is None and nullable:
        return
    allowed = (
        "true or false"
        if tp is bool
        else f"an integer >= {minimum}" + (" or null" if nullable else "")
    )
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(key, value, allowed)
        return
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or value < (minimum or 0):
        raise ConfigError(key, value, allowed)


def _field_type(cls: type, path: Sequence[str], full_key: str, value: Any, owner: str) -> Any:
    """The annotated type of ``cls.<path>``; ConfigError listing the known keys if absent."""
    current = cls
    for depth, part in enumerate(path):
        if not (isinstance(current, type) and dataclasses.is_dataclass(current)):
            break
        hints = typing.get_type_hints(current)
        fields = [f.name for f in dataclasses.fields(current) if f.init]
        if part not in fields:
            where = ".".join([full_key.split(".")[0], *path[:depth]])
            raise ConfigError(
                full_key, value, f"{owner} has no such key; keys under {where} are "
                + (", ".join(sorted(fields)) or "(none)")
            )
        current = hints[part]
    return current


def check_group_key(
    group: str, path: Sequence[str], value: Any, choices: Sequence[str], registry: Registry
) -> None:
    """``problem.<path>=value`` or ``optimizer.<path>=value`` against every selected class."""
    full_key = ".".join([group, *path])
    if list(path) == ["name"]:
        raise ConfigError(full_key, value, f"choose the {group} with {group}=<name> instead")
    for choice in choices:
        cls = registry.problem(choice) if group == "problem" else registry.optimizer(choice)
        data_cls = cls.Config if group == "problem" else cls.Params
        tp = _field_type(data_cls, path, full_key, value, f"{group} {choice!r}")
        if _is_interpolation(value) or value is None and _nullable(tp):
            continue
        _coerce(value, tp, full_key)
        if len(path) == 1 and path[0] in PROTOCOL_MINIMUM:
            check_minimum(full_key, value, PROTOCOL_MINIMUM[path[0]])


def _nullable(tp: Any) -> bool:
    return type(None) in typing.get_args(tp)


def check_minimum(key: str, value: Any, minimum: int) -> None:
    """An integer protocol value (ps, iterations) below its minimum is refused."""
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value < minimum:
        raise ConfigError(key, value, f"an integer >= {minimum}")


def check_overrides(
    overrides: Sequence[str], registry: Registry, defaults: Mapping[str, str]
) -> dict[str, list[str]]:
    """Check every override; return the problem and optimizer names the command selects."""
    parsed = parse_overrides(overrides)
    # A choice is a registered plugin name or a YAML preset (conf/<group>/), which stands
    # for the plugin it extends when its keys are checked.
    names: dict[str, dict[str, str]] = {}
    for group, table in (("problem", registry.problems), ("optimizer", registry.optimizers)):
        presets = {k: v for k, v in yaml_presets(group).items() if v in table}
        names[group] = {**presets, **{n: n for n in table}}
    choices = {g: [names[g].get(defaults[g], defaults[g])] if g in defaults else []
               for g in GROUPS}
    # Group choices first: the keys under a group are checked against what is selected.
    for o in parsed:
        key = o.key_or_group
        if key in GROUPS and not o.is_delete():
            values = _values(o, names[key])
            if not values and o.is_sweep_override():
                raise ConfigError(key, _raw_value(o), "a pattern matching one of "
                                  + ", ".join(sorted(names[key])))
            for v in values:
                if not isinstance(v, str) or v not in names[key]:
                    raise _unknown_name(key, v, registry)
            choices[key] = [names[key][str(v)] for v in values]
    for group in GROUPS:
        for name in choices[group]:
            if name not in names[group].values():
                raise _unknown_name(group, name, registry)
    for o in parsed:
        key = o.key_or_group
        if key in GROUPS or key == "hydra" or key.startswith(("hydra.", "hydra/")):
            continue
        if o.is_delete():
            continue
        head, *path = key.split(".")
        if "/" in key:
            raise ConfigError(key, _raw_value(o), "config groups are problem and optimizer")
        if head in GROUPS and path:
            for v in _values(o):
                check_group_key(head, path, v, choices[head], registry)
        elif head in TOP_LEVEL and not path:
            for v in _values(o):
                if not _is_interpolation(v):
                    check_top_level(head, v)
        else:
            allowed = "known top-level keys are " + ", ".join(
                [*GROUPS, *TOP_LEVEL]
            ) + "; problem.<key> and optimizer.<key> set a plugin's parameters"
            first = _values(o)
            raise ConfigError(key, first[0] if len(first) == 1 else _raw_value(o), allowed)
    return choices


def raw_output_dir(primary: Any, multirun: bool) -> str:
    """``hydra.sweep.dir`` (multirun) or ``hydra.run.dir`` of the primary config, unresolved."""
    from omegaconf import OmegaConf

    hydra_cfg = OmegaConf.to_container(primary, resolve=False).get("hydra", {})
    section = hydra_cfg.get("sweep" if multirun else "run", {})
    default = ("outputs/multirun/" if multirun else "outputs/runs/") + "${now:%Y-%m-%d_%H-%M-%S-%f}"
    return str(section.get("dir", default))


def output_root(path_template: str) -> Path:
    """The part of an output-dir template before its first interpolation (``${now:...}``)."""
    head = path_template.split("${", 1)[0]
    if "${" in path_template:
        head = head if head.endswith(("/", os.sep)) else os.path.dirname(head)
    return Path(head or ".")


def check_writable(directory: Path, key: str) -> None:
    """Create ``directory`` if needed and prove a file can be written there."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as exc:
        raise ConfigError(
            key, str(directory), f"a directory you can create and write to ({exc.strerror})"
        ) from None

