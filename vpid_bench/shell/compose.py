"""Hydra's composition for the pre-flight: the compose API set up as ``hydra.main`` sets
itself up, each distinct point of a sweep composed once (:class:`Composer`), and Hydra's and
OmegaConf's errors as one :class:`ConfigError` line."""

from __future__ import annotations

import copy
from typing import Any

import yaml
from hydra import compose, initialize_config_dir, initialize_config_module
from hydra.errors import HydraException, MissingConfigException
from omegaconf import OmegaConf, open_dict
from omegaconf.errors import OmegaConfBaseException

from ..errors import ConfigError
from ..spec import TOP_LEVEL_KEYS
from .argv import SHIPPED_CONFIGS, ConfigSource

#: The config groups of a job.
GROUPS = ("problem", "optimizer")
#: The shipped config (no -cp, -cn, -cd).
SHIPPED = ConfigSource()


def hydra_error(exc: BaseException) -> ConfigError:
    """A Hydra or OmegaConf error as one line (the innermost cause that names a key)."""
    if isinstance(exc, MissingConfigException):
        missing = str(getattr(exc, "missing_cfg_file", "") or "")
        group, _, name = missing.rpartition("/")
        options = sorted(getattr(exc, "options", None) or [])
        if "Cannot find primary config" in str(exc):
            return ConfigError("--config-name", missing, "the name of a .yaml file (without "
                               ".yaml) in the -cp or -cd folder")
        if group and options:
            return ConfigError(group, name, "one of " + ", ".join(options))
    cause: BaseException | None = exc  # a config file that is not YAML: the place named
    while cause is not None and not isinstance(cause, yaml.MarkedYAMLError):
        cause = cause.__cause__ or cause.__context__
    if cause is not None:
        mark = cause.problem_mark or cause.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        return ConfigError("config file", getattr(mark, "name", "?"),
                           f"YAML ({cause.problem or cause.context}{where})")
    cause = exc
    while cause is not None:
        key = getattr(cause, "full_key", None)
        if key:
            msg = " ".join(str(getattr(cause, "msg", cause)).split()).split(" full_key:")[0]
            return ConfigError(str(key), getattr(cause, "value", None), msg)
        cause = cause.__cause__ or cause.__context__
    text = " ".join(str(exc).split())
    if text.startswith("Could not override '"):
        key = text.split("'")[1]
        return ConfigError(key, "", "a key of the selected config (this one does not exist "
                           "there; Hydra's own settings: vpid-bench --hydra-help)")
    return ConfigError("override", "", text)


def _compose(overrides: list[str], hydra: bool, source: ConfigSource = SHIPPED) -> Any:
    overrides = [*overrides, *source.search_override()]  # as on Hydra's command line
    try:
        return compose(config_name=source.name or "config", overrides=overrides,
                       return_hydra_config=hydra)
    except (HydraException, OmegaConfBaseException) as exc:
        raise hydra_error(exc) from None


def initialize(source: ConfigSource) -> Any:
    """Hydra's compose API set up as ``hydra.main`` sets itself up for this command."""
    path = source.path or SHIPPED_CONFIGS
    if path.startswith("pkg://"):
        return initialize_config_module(version_base="1.3", config_module=path[len("pkg://"):])
    return initialize_config_dir(version_base="1.3", config_dir=path)


class Composer:
    """Hydra's composition of each distinct set of a sweep's structural overrides, made
    once, without the ``hydra`` node. For the shipped config (which keeps the two groups
    apart), the task config of (problem P, optimizer O) is P's composition with O's
    ``optimizer`` node (tests/sweeps/test_preflight_compose.py compares): each composed once
    (323 points took 28 s). A user's config, or an override with a package or of another
    group, is composed point by point."""

    def __init__(self, source: ConfigSource) -> None:
        self.source = source
        #: the first point's full config, ``hydra`` node included (the output folder's)
        self.first_full: Any = None
        self._tasks: dict[tuple[str, ...], Any] = {}
        self._by_rest: dict[tuple[str, ...], Any] = {}  # all but the optimizer choice
        self._optimizers: dict[str, Any] = {}  # an optimizer choice's node

    def task(self, structural: list[Any]) -> Any:
        """The task config (no ``hydra`` node) of a point whose structural overrides are
        ``structural`` (parsed); the caller copies it before changing it."""
        lines = tuple(o.input_line for o in structural)
        if lines in self._tasks:
            return self._tasks[lines]
        choice = next((o.input_line for o in structural if o.key_or_group == "optimizer"), "")
        rest = tuple(o.input_line for o in structural if o.key_or_group != "optimizer")
        separable = self._separable(structural)
        if separable and rest in self._by_rest and choice in self._optimizers:
            task = copy.deepcopy(self._by_rest[rest])
            with open_dict(task):
                task.optimizer = copy.deepcopy(self._optimizers[choice])
        else:
            task = self._compose(list(lines))
            if separable:
                self._by_rest.setdefault(rest, task)
                self._optimizers.setdefault(choice, task.optimizer)
        self._tasks[lines] = task
        return task

    def _compose(self, overrides: list[str]) -> Any:
        full = _compose(overrides, hydra=True, source=self.source)
        if self.source != SHIPPED and not all(k in full for k in TOP_LEVEL_KEYS):
            raise ConfigError("--config-name", self.source.name or "config",  # its defaults,
                              "a config whose defaults list starts with vpid_bench_spec (e.g. "
                              "defaults: [vpid_bench_spec, {problem: functions}, {optimizer: "
                              "random}, _self_]; docs/sweeps.md)")  # report, job folders
        if self.first_full is None:
            self.first_full = full
        return OmegaConf.masked_copy(full, [k for k in full if k != "hydra"])

    def _separable(self, structural: list[Any]) -> bool:
        """Whether the point's optimizer node can come from another composition (see the class)."""
        if self.source != SHIPPED:
            return False
        for o in structural:
            key = o.key_or_group
            if o.package is not None or o.is_delete() or o.is_add() or o.is_force_add():
                return False
            if key in GROUPS:
                continue
            if not key.startswith("hydra.") or key.startswith("hydra.searchpath"):
                return False
        return True
