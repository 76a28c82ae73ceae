"""Plugin discovery: entry points of group ``vpid_bench``, loaded into a pluggy manager by the
factory ``get_plugin_manager()`` (nothing imported at import time of this module), and the
``Registry`` of what they register (the failures, names registered twice and
``VPID_BENCH_BLOCK_PLUGINS``: docs/plugins.md).
"""

from __future__ import annotations

import dataclasses
import importlib.metadata
import os
import warnings
from collections.abc import Iterable
from typing import Any

import pluggy

from . import hookspecs
from .errors import ConfigError, PluginError
from .optimizer import Optimizer, OptimizerParams
from .problem import Problem, ProblemConfig
from .store.provenance import code_digest, distribution_provenance, library_provenance

ENTRY_POINT_GROUP = "vpid_bench"
BLOCK_ENV = "VPID_BENCH_BLOCK_PLUGINS"


class PluginLoadWarning(UserWarning):
    """A plugin was skipped because it failed to import."""


@dataclasses.dataclass
class PluginManagerInfo:
    """What happened while loading plugins: skipped (blocked) and failed entry points, and
    where each loaded plugin came from (its distribution, version and requirements)."""

    blocked: list[str] = dataclasses.field(default_factory=list)
    failed: dict[str, str] = dataclasses.field(default_factory=dict)
    sources: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)


class PluginManager(pluggy.PluginManager):
    """pluggy's manager of the ``vpid_bench`` hooks, and how its plugins loaded (:attr:`info`)."""

    def __init__(self) -> None:
        super().__init__(hookspecs.PROJECT_NAME)
        self.add_hookspecs(hookspecs)
        self.info = PluginManagerInfo()


def get_plugin_manager(entry_points: Iterable[importlib.metadata.EntryPoint] | None = None,
                       extra_plugins: Iterable[tuple[str, Any]] = ()) -> PluginManager:
    """A fresh plugin manager with every ``vpid_bench`` entry point loaded (its
    :attr:`~PluginManager.info` says what was blocked, failed and where each came from).
    ``entry_points`` replaces the installed ones (tests use it); ``extra_plugins`` registers
    ``(name, module_or_object)`` pairs on top."""
    pm = PluginManager()
    info = pm.info
    blocked = {n.strip() for n in os.environ.get(BLOCK_ENV, "").split(",") if n.strip()}
    if entry_points is None:
        entry_points = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    owners: dict[str, str] = {}
    for ep in entry_points:
        if ep.name in blocked:
            info.blocked.append(ep.name)
            continue
        dist = getattr(ep, "dist", None)
        owner = ep.value if dist is None else f"{dist.metadata['Name']} {dist.version}"
        if ep.name in owners:
            raise PluginError(f"two plugins use the entry-point name {ep.name!r}: "
                              f"{owners[ep.name]} and {owner}; uninstall one or block it with "
                              f"{BLOCK_ENV}={ep.name}")
        owners[ep.name] = owner
        try:
            plugin = ep.load()
        except Exception as exc:  # a broken third-party plugin must not stop the others
            info.failed[ep.name] = f"{type(exc).__name__}: {exc}"
            warnings.warn(f"vpid-bench plugin {ep.name!r} ({owner}) failed to import and was "
                          f"skipped: {type(exc).__name__}: {exc}", PluginLoadWarning,
                          stacklevel=2)
            continue
        _register(pm, plugin, ep.name, owner)
        info.sources[ep.name] = distribution_provenance(dist)
    for name, plugin in extra_plugins:
        _register(pm, plugin, name, name)
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        raise PluginError(f"plugin {pm.get_name(exc.plugin)!r} implements a hook vpid-bench "
                          f"does not know: {exc}; the hooks are vpid_bench_register_optimizers, "
                          "vpid_bench_register_problems and vpid_bench_register_report_sections"
                          ) from exc
    return pm


def _register(pm: pluggy.PluginManager, plugin: Any, name: str, owner: str) -> None:
    try:
        pm.register(plugin, name=name)
    except pluggy.PluginValidationError as exc:
        raise PluginError(f"plugin {name!r} ({owner}) has an invalid hook: {exc}") from exc


class Registry:
    """The problems and optimizers the plugins registered, by name."""

    def __init__(self, pm: PluginManager | None = None) -> None:
        self.pm = pm if pm is not None else get_plugin_manager()
        #: What happened while the plugins loaded and registered (blocked, failed, sources).
        self.info = self.pm.info
        self.optimizers: dict[str, type[Optimizer]] = {}
        self.problems: dict[str, type[Problem]] = {}
        self._owner: dict[tuple[str, str], str] = {}
        self._collect("optimizer", self.pm.hook.vpid_bench_register_optimizers, self.optimizers)
        self._collect("problem", self.pm.hook.vpid_bench_register_problems, self.problems)
        #: Report sections per problem name, in plugin load order: (plugin name, function).
        self.report_sections: dict[str, list[tuple[str, Any]]] = {}
        for impl in reversed(self.pm.hook.vpid_bench_register_report_sections.get_hookimpls()):
            def add(problem: str, section: Any, _plugin: str = impl.plugin_name) -> None:
                if not isinstance(problem, str) or not callable(section):
                    raise PluginError(f"plugin {_plugin!r} registered report section "
                                      f"{section!r} for {problem!r}: needs (name, callable)")
                self.report_sections.setdefault(problem, []).append((_plugin, section))

            impl.function(register=add)

    def _collect(self, kind: str, hook: Any, table: dict[str, Any]) -> None:
        base, params_attr, params_base = {
            "optimizer": (Optimizer, "Params", OptimizerParams),
            "problem": (Problem, "Config", ProblemConfig),
        }[kind]
        # Oldest registration first, so error messages name plugins in load order.
        for impl in reversed(hook.get_hookimpls()):
            plugin_name = impl.plugin_name

            def register(name: str, cls: type, _plugin: str = plugin_name) -> None:
                if not isinstance(name, str) or not name.isidentifier():
                    raise PluginError(f"plugin {_plugin!r} registered the {kind} name {name!r}: "
                                      "a name must be a Python identifier (letters, digits, "
                                      "underscores)")
                if not (isinstance(cls, type) and issubclass(cls, base)):
                    raise PluginError(f"plugin {_plugin!r} registered {kind} {name!r} as "
                                      f"{cls!r}, which is not a subclass of "
                                      f"{base.__module__}.{base.__name__}")
                params = getattr(cls, params_attr, None)
                if not (dataclasses.is_dataclass(params) and issubclass(params, params_base)):
                    raise PluginError(f"plugin {_plugin!r}: {kind} {name!r} needs a "
                                      f"{params_attr} dataclass deriving from "
                                      f"{params_base.__name__}")
                if name in table:
                    raise PluginError(f"{kind} name {name!r} is registered twice: by plugin "
                                      f"{self._owner[(kind, name)]!r} and by plugin "
                                      f"{_plugin!r}; block one with {BLOCK_ENV}=<plugin name>")
                table[name] = cls
                self._owner[(kind, name)] = _plugin

            before = dict(table)
            try:
                impl.function(register=register)
            except PluginError:
                raise
            except Exception as exc:  # a broken hook must not stop the other plugins
                for key in set(table) - set(before):  # undo what it half registered
                    del table[key]
                    self._owner.pop((kind, key), None)
                self.info.failed[plugin_name] = f"{type(exc).__name__}: {exc}"
                warnings.warn(f"vpid-bench plugin {plugin_name!r} failed to register its "
                              f"{kind}s and was skipped: {type(exc).__name__}: {exc}",
                              PluginLoadWarning, stacklevel=2)

    def suites(self) -> dict[str, list[str]]:
        """The suites the registered problems declare (``Problem.suites``), problems sorted."""
        out: dict[str, list[str]] = {}
        for name, cls in sorted(self.problems.items()):
            for suite in getattr(cls, "suites", ()) or ():
                if isinstance(suite, str) and suite.isidentifier():
                    out.setdefault(suite, []).append(name)
        return out

    def owner(self, kind: str, name: str) -> str:
        """The name of the plugin that registered ``kind`` ``name``."""
        return self._owner[(kind, name)]

    def provenance(self, kind: str, name: str) -> dict[str, Any]:
        """Where ``kind`` ``name`` comes from: ``{"plugin", "distribution", "version",
        "requires", "code"}`` and, for an optimizer that runs a library (``Optimizer.library``),
        ``"library": {"name", "version"}`` (distribution, version and requires empty for a plugin no
        distribution ships; ``code`` the digest of its installed source,
        :func:`~vpid_bench.store.provenance.code_digest`, so a plugin changed under the
        same version is told apart)."""
        plugin = self._owner[(kind, name)]
        source = self.info.sources.get(plugin, {})
        cls = (self.problems if kind == "problem" else self.optimizers)[name]
        out = {"plugin": plugin, **source, "code": code_digest(cls)}
        library = getattr(cls, "library", None) if kind == "optimizer" else None
        if isinstance(library, str):
            out["library"] = library_provenance(library)
        return out

    def optimizer(self, name: str) -> type[Optimizer]:
        """The optimizer class registered as ``name``; a clear error lists the known names."""
        try:
            return self.optimizers[name]
        except KeyError:
            known = ", ".join(sorted(self.optimizers))
            raise ConfigError("optimizer", name, "one of " + known) from None

    def problem(self, name: str) -> type[Problem]:
        """The problem class registered as ``name``; a clear error lists the known names."""
        try:
            return self.problems[name]
        except KeyError:
            known = ", ".join(sorted(self.problems))
            raise ConfigError("problem", name, "one of " + known) from None


def registered_optimizer(name: str) -> type[Optimizer]:
    """The optimizer class installed under ``name`` (``optimizer=<name>``), for a plugin that
    composes another plugin's optimizer without importing its package (``de_lsq`` runs
    ``de4`` first). Each call loads the installed plugins (about 50 ms once imported): look
    it up once per run, not per generation. Raises :class:`ConfigError` naming the installed
    optimizers when ``name`` is not one of them."""
    return Registry().optimizer(name)
