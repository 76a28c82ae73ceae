"""Pre-flight: every point of the command checked before any job runs (docs/architecture.md,
how a command flows).

Hydra composes a job's config only when that job starts, so a bad value in the tenth point of
a sweep once stopped it after nine jobs. The pre-flight expands the sweep exactly as Hydra's
basic sweeper does (the cartesian product of the sweep overrides, the first outermost),
composes each point and parses it with :func:`vpid_bench.spec.parse_job`, the function the job
calls: anything bad stops the command with one line, exit 2, before any folder is written.
Points that differ only in plain ``key=value`` settings share one composition
(:class:`.compose.Composer`), their values set on a copy as Hydra sets them.
"""

from __future__ import annotations

import dataclasses
import difflib
import itertools
import math
import os
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from hydra._internal.config_loader_impl import get_overrides_dirname
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import ChoiceSweep, Glob, RangeSweep, Sweep
from hydra.errors import OverrideParseException
from omegaconf import DictConfig, OmegaConf, open_dict
from omegaconf.errors import OmegaConfBaseException

from ..errors import ConfigError, VpidBenchError
from ..fileio import own_folder
from ..params import to_plain
from ..plugins import Registry
from ..problem import FILLED_PARAMS
from ..spec import TOP_LEVEL_KEYS, Job, parse_job
from .argv import CommandLine, ConfigSource
from .callbacks import JOB_DIR_RESOLVER, job_dir_name
from .compose import GROUPS, SHIPPED, Composer, hydra_error, initialize
from .presets import yaml_presets
from .resume import check_reuse, find_previous

#: The most jobs one command may start (a typo in a range() should not plan a million).
MAX_JOBS = 10_000
#: The folders the command keeps in its output folder: the instance optima and the report.
OWN_FOLDERS = ("optima", "report")


@dataclasses.dataclass
class Plan:
    """What the pre-flight decided: the command line for Hydra, the output folder, the jobs,
    each job's folder as Hydra's basic sweeper will name it (empty when unknown in advance)
    and the problems it built (a :class:`~vpid_bench.build.ProblemCache`, or None)."""

    hydra_args: list[str]
    output_dir: Path | None
    multirun: bool
    jobs: list[Job]
    points: list[list[str]]
    job_dirs: list[Path] = dataclasses.field(default_factory=list)
    problems: Any = None


def parse_overrides(overrides: Sequence[str]) -> list[Any]:
    """Hydra's parsed ``Override`` objects; a syntax error is one ConfigError line."""
    parser = OverridesParser.create()
    parsed = []
    for text in overrides:
        try:
            parsed.extend(parser.parse_overrides([text]))
        except OverrideParseException as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else "syntax error"
            raise ConfigError("override", text, f"key=value, a sweep key=a,b,c (with -m) or "
                              f"+key=value ({first})") from None
    return parsed


def _raw_value(override: Any) -> str:
    return str(override.input_line).split("=", 1)[-1]


def _group_names(group: str, registry: Registry, folders: Sequence[str] = ()) -> list[str]:
    """The choices of ``group``: plugins, presets and ``<folder>/<group>/<name>.yaml``."""
    table = registry.problems if group == "problem" else registry.optimizers
    own = {f.stem for folder in folders for f in Path(folder, group).glob("*.yaml")}
    return sorted({*table, *yaml_presets(group), *own})


def _sweep_size(override: Any) -> int | None:
    """How many values a sweep override stands for (None: not a list, e.g. interval())."""
    value = override.value()
    if isinstance(value, RangeSweep):
        if not value.step:
            raise ConfigError(override.key_or_group, _raw_value(override),
                              "range(start, stop[, step]) with a step that is not 0")
        return max(0, math.ceil((value.stop - value.start) / value.step))
    return len(value.list) if isinstance(value, ChoiceSweep) else None


def _refuse_nested_sweep(o: Any, value: Any) -> None:
    """Refuse a sweep function inside a list sweep (``a,choice(b,c)``): Hydra cannot expand
    it (a 20-line ``ValidationError`` once, round five's N19)."""
    for item in getattr(value, "list", None) or ():
        if isinstance(item, (Sweep, Glob)):
            raise ConfigError(o.key_or_group, _raw_value(o),
                              "a list of plain values (a,b,c) or one sweep function "
                              "(choice(), range(), glob()) alone, not one inside a list")


def _axis(o: Any, multirun: bool, registry: Registry, custom_sweeper: bool,
          folders: Sequence[str] = ()) -> list[str] | None:
    """The override strings one override contributes (``None``: a sweeper's choice)."""
    if not o.is_sweep_override():
        return [o.input_line]
    key = o.get_key_element()
    if not multirun:
        raise ConfigError(o.key_or_group, _raw_value(o),
                          "one value here; to run every value, start a sweep with -m")
    if custom_sweeper:  # an optimizing sweeper chooses values itself: check one setting
        return None
    value = o.value()
    if isinstance(value, Glob):
        if o.key_or_group not in GROUPS:
            raise ConfigError(o.key_or_group, _raw_value(o), "glob() chooses among "
                              "problem or optimizer names")
        choices = _group_names(o.key_or_group, registry, folders)
        names = value.filter(choices)
        if not names:
            raise ConfigError(o.key_or_group, _raw_value(o), "a pattern matching one of "
                              + ", ".join(choices))
        return [f"{key}={n}" for n in names]
    _refuse_nested_sweep(o, value)
    size = _sweep_size(o)
    if size is None:
        raise ConfigError(o.key_or_group, _raw_value(o), "a list of values (a,b,c, "
                          "range(), choice()); interval() needs an optimizing sweeper such "
                          "as hydra/sweeper=optuna")
    if size > MAX_JOBS:
        raise ConfigError(o.key_or_group, _raw_value(o), f"a sweep of at most {MAX_JOBS} values")
    return [f"{key}={s}" for s in o.sweep_string_iterator()]


def expand_points(parsed: list[Any], multirun: bool, registry: Registry,
                  custom_sweeper: bool, folders: Sequence[str] = ()) -> list[list[str]]:
    """The override strings of every job, in the order Hydra's basic sweeper runs them."""
    # each override with its own axis (zipping with a shorter list once checked wrong values)
    pairs = [(o, a) for o in parsed
             if (a := _axis(o, multirun, registry, custom_sweeper, folders)) is not None]
    axes = [a for _, a in pairs]
    for o, axis in pairs:
        if o.key_or_group in GROUPS and not o.is_delete():
            for text in axis:
                _check_choice(o.key_or_group, text.split("=", 1)[1], registry, folders)
    count = math.prod(len(a) for a in axes)
    if count == 0:
        empty = next(o for o, a in pairs if not a)
        raise ConfigError(empty.key_or_group, _raw_value(empty),
                          "a sweep with at least one value (this one is empty: no job would run)")
    if count > MAX_JOBS:
        raise ConfigError("-m", f"{count} jobs", f"at most {MAX_JOBS} jobs in one command")
    return [list(p) for p in itertools.product(*axes)]


def _check_choice(group: str, name: str, registry: Registry, folders: Sequence[str] = ()) -> None:
    """Refuse a name that is no choice, listing the known ones and the failed plugins."""
    names = _group_names(group, registry, folders)
    if name.strip("'\"") in names:
        return
    allowed = "one of " + ", ".join(names) if names else "none is registered"
    allowed += did_you_mean(name.strip("'\""), names)
    if registry.info.failed:
        allowed += " (plugins that failed to load: " + ", ".join(
            f"{n}: {why}" for n, why in sorted(registry.info.failed.items())) + ")"
    raise ConfigError(group, name, allowed)


def did_you_mean(given: str, known: Sequence[str]) -> str:
    """`` (did you mean de4?)`` for a near miss (difflib ratio >= 0.6), else ``""``."""
    close = difflib.get_close_matches(given, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]}?)" if close else ""


def _is_structural(o: Any) -> bool:
    """Overrides that need Hydra's composition: config-group choices and hydra settings."""
    key = o.key_or_group
    return ("/" in key or key in GROUPS or key == "hydra" or key.startswith("hydra.")
            or o.package is not None)


def _apply(cfg: Any, o: Any) -> None:
    """Set one plain ``key=value`` override on a composed config, as Hydra would."""
    key, value = o.key_or_group, o.value()
    head, _, rest = key.partition(".")
    if head in GROUPS and rest == "name":
        raise ConfigError(key, value, f"choose the {head} with {head}=<name> instead")
    if o.is_delete():
        with open_dict(cfg):
            if OmegaConf.select(cfg, key, default="<missing>") == "<missing>":
                raise ConfigError(key, "~", "a key that exists (nothing to delete)")
            parent, _, leaf = key.rpartition(".")
            node = OmegaConf.select(cfg, parent) if parent else cfg
            del node[leaf]
        return
    exists = OmegaConf.select(cfg, key, default="<missing>") != "<missing>"
    if o.is_add() and exists:
        raise ConfigError(key, value, "a new key for +key=value (this one exists: drop the +)")
    if o.is_add() or o.is_force_add():
        with open_dict(cfg):
            OmegaConf.update(cfg, key, value, merge=True, force_add=True)
        return
    if not exists:  # new only in a mapping left open (``open_keys``: the plugin checks it)
        parent = key.rpartition(".")[0]
        node = OmegaConf.select(cfg, parent, default=None) if parent else None
        if not (isinstance(node, DictConfig) and not OmegaConf.is_struct(node)):
            raise _unknown_key(cfg, key, value)
    OmegaConf.update(cfg, key, value, merge=True)


def _unknown_key(cfg: Any, key: str, value: Any) -> ConfigError:
    """The error for ``key=value`` where ``key`` does not exist: names the keys that do."""
    parts = key.split(".")
    for depth in range(len(parts) - 1, -1, -1):
        parent = ".".join(parts[:depth])
        node = OmegaConf.select(cfg, parent) if parent else cfg
        if isinstance(node, DictConfig):
            keys = sorted(str(k) for k in node if str(k) != "name")
            hint = did_you_mean(parts[depth], keys) if depth < len(parts) else ""
            if not parent:
                return ConfigError(key, value, "known top-level keys are problem, optimizer, "
                                   + ", ".join(TOP_LEVEL_KEYS) + "; problem.<key> and "
                                   "optimizer.<key> set a plugin's parameters" + hint)
            if parent == "optimizer" and parts[1] in FILLED_PARAMS:
                where = "budget" if parts[1] == "budget" else f"problem.{parts[1]}"
                return ConfigError(key, value, "not settable on the optimizer: the job fills "
                                   f"it in, set {where}")
            owner = parent.split(".")[0]
            name = OmegaConf.select(cfg, f"{owner}.name")
            who = f"{owner} {name!r}" if owner in GROUPS and name else parent
            return ConfigError(key, value, f"{who} has no such key; keys under {parent} are "
                               + (", ".join(keys) or "(none)") + hint)
    return ConfigError(key, value, "a key of the config")


def check_points(points: list[list[str]], registry: Registry,
                 source: ConfigSource = SHIPPED) -> tuple[list[Job], Any]:
    """Compose and parse every point: the jobs and the first point's full config."""
    parser = OverridesParser.create()
    composer = Composer(source)
    jobs = []
    with initialize(source):
        for point in points:
            parsed = parser.parse_overrides(point)
            cfg = composer.task([o for o in parsed if _is_structural(o)]).copy()
            OmegaConf.set_struct(cfg, True)
            try:
                for o in parsed:
                    if not _is_structural(o):
                        _apply(cfg, o)
            except OmegaConfBaseException as exc:
                raise hydra_error(exc) from None
            with open_dict(cfg):
                cfg.pop("hydra", None)
            jobs.append(parse_job(cfg, registry))
    return jobs, composer.first_full


def _quote(path: str) -> str:
    """A path as a quoted Hydra override value."""
    return "'" + path.replace("\\", "\\\\").replace("'", "\\'") + "'"


def output_dir(full_cfg: Any, multirun: bool) -> Path:
    """The job's (``hydra.run.dir``) or sweep's (``hydra.sweep.dir``) folder, resolved once."""
    key = "hydra.sweep.dir" if multirun else "hydra.run.dir"
    try:
        value = OmegaConf.select(full_cfg, key)
    except OmegaConfBaseException as exc:
        raise ConfigError(key, "${...}", f"a folder ({' '.join(str(exc).split()[:10])})") from None
    if value is None or not str(value).strip():
        raise ConfigError(key, value if value is not None else "", "a folder name (empty "
                          "would write into the current folder)")
    return Path(str(value))


def check_writable(directory: Path, key: str) -> None:
    """Create ``directory`` if needed and prove a file can be written there."""
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=directory):
            pass
    except OSError as exc:
        raise ConfigError(key, str(directory),
                          f"a directory you can create and write to ({exc.strerror})") from None


def _resume_folder(cmd: CommandLine, full_cfg: Any, key: str) -> Path | None:
    """The folder ``--resume`` continues (None: the one named on the command line)."""
    if cmd.resume:
        folder = Path(cmd.resume)
        if not folder.is_dir():
            raise ConfigError("--resume", cmd.resume, "an existing sweep or run folder")
        return folder
    if any(a.startswith(key + "=") for a in cmd.overrides):
        return None  # the folder is named on the command line: that is the one continued
    section = OmegaConf.to_container(full_cfg.hydra.sweep if cmd.multirun  # as written
                                     else full_cfg.hydra.run, resolve=False)
    root = output_root(str(section.get("dir", "")))
    folder = find_previous(root, cmd.overrides, cmd.multirun)
    if folder is None:  # it once started a whole new sweep: asking to resume asks for none
        kind = "sweep" if cmd.multirun else "run"
        raise VpidBenchError(f"--resume: no earlier {kind} under {root} has these overrides, "
                             f"so there is nothing to resume; to start a new {kind}, run the "
                             "command without --resume")
    return folder


def _check_subdir(key: str, o: Any) -> None:
    """``hydra.sweep.subdir`` may not be absolute nor climb out with ``..`` (a job once ran
    outside, and the sweep counted 0 jobs)."""
    values = ([str(v) for v in o.sweep_string_iterator()] if o.is_sweep_override()
              else [str(o.value())])
    for value in values:
        parts = Path(value).parts
        if not value.strip() or Path(value).is_absolute() or ".." in parts:
            raise ConfigError(key, value, "a relative folder inside the sweep folder (no "
                              "leading /, no '..')")


def plan(cmd: CommandLine, registry: Registry) -> Plan:
    """Check the command line and fix the output folder; :class:`ConfigError`, no writes."""
    parsed = parse_overrides(cmd.overrides)
    for o in parsed:
        value = o.value()
        if ((o.key_or_group in GROUPS or o.key_or_group.startswith("hydra/"))
                and isinstance(value, str) and "${" in value):
            raise ConfigError(o.key_or_group, value, "a config name, not an interpolation")
    for o in parsed:
        group = o.key_or_group
        if group == "hydra.sweep.subdir":
            _check_subdir(group, o)
        if "/" in group and not group.startswith("hydra/"):
            raise ConfigError(group, _raw_value(o), "config groups are problem, optimizer and "
                              "Hydra's hydra/<group> (launcher, sweeper, ...)")
        if group in GROUPS and o.is_delete():
            raise ConfigError(f"~{group}", "", f"a {group} for every job: choose another one "
                              f"with {group}=<name>")
    custom_sweeper = any(o.key_or_group == "hydra/sweeper" and o.value() != "basic" for o in parsed)
    folders = [f.removeprefix("file://") for f in (cmd.config.path, cmd.config.search)
               if f is not None and not f.startswith("pkg://")]
    points = expand_points(parsed, cmd.multirun, registry, custom_sweeper, folders)
    try:
        jobs, full = check_points(points, registry, cmd.config)
    except VpidBenchError:
        raise
    except Exception as exc:  # noqa: BLE001 - anything else Hydra raises: one line too
        raise hydra_error(exc) from None
    if custom_sweeper:
        refuse_test_instances(jobs)
    problems = check_sized_jobs(jobs)
    key = "hydra.sweep.dir" if cmd.multirun else "hydra.run.dir"
    folder = _resume_folder(cmd, full, key) if cmd.resume is not None else None
    if folder is not None:
        print(f"resume: continuing {folder}", file=sys.stderr)
    else:
        folder = output_dir(full, cmd.multirun)
    hydra_args = [a for a in _globs_listed(cmd.hydra_args, parsed, registry, folders)
                  if not a.startswith(key + "=")]
    hydra_args.append(f"{key}={_quote(str(folder))}")
    job_dirs = planned_job_dirs(points, full, folder) if cmd.multirun and not custom_sweeper else []
    merged = check_reuse(folder, job_dirs if cmd.multirun else [folder], cmd.overrides,
                         cmd.multirun, cmd.merge, key)
    if merged:
        print(merged, file=sys.stderr)
    return Plan(hydra_args, folder, cmd.multirun, jobs, points, job_dirs, problems)


def check_sized_jobs(jobs: Sequence[Job]) -> Any:
    """The checks a job makes once its problem is built (``budget_per_dim``, ``target``:
    :func:`vpid_bench.targets.check_sized`), made for every job before any runs. In a
    supervised worker (a crash costs only the check: the job says why; a failure but
    ConfigError is the job's); with ``isolation=none`` here, the problems built returned for
    the jobs (else ``None``)."""
    from ..build import ProblemCache
    from ..experiment import setup_limit_s
    from ..targets import check_sized
    from ..workers import Workers, can_send

    wanted = [j for j in jobs if j.spec.target is not None or j.spec.budget_per_dim is not None]
    if not wanted:
        return None
    firsts: dict[str, Job] = {}  # once per what the check depends on (not the optimizer:
    for j in wanted:  # 323 checks once took 37 s of the vpid1 build's pre-flight)
        firsts.setdefault(repr((j.problem_cls, j.problem_name, j.problem_settings(),
                                j.spec.runs, j.spec.budget_per_dim, j.spec.target)), j)
    if all(j.spec.isolation != "none" and can_send(j) is None for j in wanted):
        pool = Workers(1)
        try:
            for job in firsts.values():
                try:
                    pool.call(job, check_sized, what="the pre-flight's check of target= and "
                              "budget_per_dim=", limit=setup_limit_s(job))
                except Exception as exc:  # noqa: BLE001 - plugin code: its job says why
                    if getattr(exc, "remote_type", None) == "ConfigError":
                        raise VpidBenchError(str(exc)) from None
        finally:
            pool.close()
        return None
    cache = ProblemCache()
    for job in firsts.values():
        try:
            problem = cache.get(job)
        except VpidBenchError:
            raise
        except Exception:  # noqa: BLE001 - plugin code: its job runs it again and says why
            continue
        check_sized(job, problem)
    return cache


def _globs_listed(hydra_args: Sequence[str], parsed: Sequence[Any], registry: Registry,
                  folders: Sequence[str]) -> list[str]:
    """The command line with each ``glob()`` over names replaced by the names it matched
    (Hydra's sweeper lists choices before it reads ``hydra.searchpath``: it would miss a
    ``-cd`` folder's)."""
    listed = {}
    for o in parsed:
        if o.key_or_group in GROUPS and isinstance(o.value(), Glob):
            names = o.value().filter(_group_names(o.key_or_group, registry, folders))
            listed[o.input_line] = f"{o.get_key_element()}=" + ",".join(
                n if n.isidentifier() else _quote(n) for n in names)
    return [listed.get(a, a) for a in hydra_args]


def refuse_test_instances(jobs: Sequence[Job]) -> None:
    """Tuning sees held-out instances only (docs/protocol.md): an optimizing sweeper's job
    whose problem's ``seed`` keys are all at their default (the test set) is refused."""
    from ..report.load import flatten

    for job in jobs:
        seeds = {k: v for k, v in flatten(job.problem_settings()).items()
                 if k == "seed" or k.endswith(".seed")}
        if not seeds:
            continue
        defaults = flatten(to_plain(job.problem_cls.Config()))
        if all(defaults.get(k) == v for k, v in seeds.items()):
            key, value = next(iter(seeds.items()))
            raise ConfigError(f"problem.{key}", value,
                              "held-out instances when tuning: the default seed's instances "
                              "are the test set a comparison reports on; tune on another, "
                              f"e.g. problem.{key}={value + 1} (docs/protocol.md)")


def planned_job_dirs(points: Sequence[Sequence[str]], full_cfg: Any, sweep_dir: Path) -> list[Path]:
    """The job folders of a basic-sweeper sweep, named as Hydra will name them (each point
    through ``override_dirname`` and :func:`~.callbacks.job_dir_name`); empty when
    ``hydra.sweep.subdir`` is not the default."""
    sweep = OmegaConf.to_container(full_cfg.hydra.sweep, resolve=False)
    if str(sweep.get("subdir")) != f"${{{JOB_DIR_RESOLVER}:${{hydra.job.override_dirname}}}}":
        return []
    naming = full_cfg.hydra.job.config.override_dirname
    parser = OverridesParser.create()
    dirs = []
    for point in points:
        lines: dict[str, str] = {}  # as Hydra's basic sweeper renders a job: value as a
        for o in parser.parse_overrides(list(point)):  # string (0.000001 -> 1e-06), the
            if not (o.key_or_group == "hydra"  # the last of a repeated key kept in the
                    or o.key_or_group.startswith(("hydra.", "hydra/"))):  # first's place
                key = o.get_key_element()
                value = (o.get_value_element_as_str() if not o.is_sweep_override()
                         else o.input_line.split("=", 1)[1])
                lines[key] = f"{key}={value}"
        task = parser.parse_overrides(list(lines.values()))
        name = get_overrides_dirname(task, list(naming.exclude_keys), str(naming.item_sep),
                                     str(naming.kv_sep))
        dirs.append(Path(sweep_dir) / job_dir_name(name))
    return dirs


def create_job_dirs(plan: Plan) -> None:
    """Create every planned job folder before the first job (Hydra makes it outside our
    task): one that cannot be created refuses the command; one that cannot be written fails
    its job alone. Links planted at ``multirun.yaml`` or :data:`OWN_FOLDERS` are removed."""
    planted = plan.output_dir / "multirun.yaml"
    if plan.multirun and planted.is_symlink():
        planted.unlink()
    for name in OWN_FOLDERS:  # a link planted in their place: removed, never followed
        if (plan.output_dir / name).is_symlink():
            own_folder(plan.output_dir / name)
    for job_dir in plan.job_dirs:
        try:
            job_dir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError("hydra.sweep.dir", str(plan.output_dir), f"a folder where every "
                              f"job folder can be created ({job_dir.name}: {exc.strerror})"
                              ) from None


def output_root(path_template: str) -> Path:
    """The part of an output-dir template before its first interpolation (``${now:...}``)."""
    head = path_template.split("${", 1)[0]
    if "${" in path_template:
        head = head if head.endswith(("/", os.sep)) else os.path.dirname(head)
    return Path(head or ".")
