"""Plugin discovery: entry points, collisions, broken and blocked plugins."""

from __future__ import annotations

import importlib.metadata
import sys
import types

import pytest

from vpid_bench import Optimizer, hookimpl
from vpid_bench.api import ConfigError, PluginError
from vpid_bench.plugins import BLOCK_ENV, PluginLoadWarning, Registry, get_plugin_manager


class Dummy(Optimizer):
    def ask(self):
        return self.bounds.sample(self.rng, 1)

    def tell(self, X, f):
        pass


def _plugin_module(name: str, optimizer_names: tuple[str, ...]) -> types.ModuleType:
    """A module object acting as a plugin that registers the given optimizer names."""
    mod = types.ModuleType(name)

    @hookimpl
    def vpid_bench_register_optimizers(register):
        for n in optimizer_names:
            register(n, Dummy)

    mod.vpid_bench_register_optimizers = vpid_bench_register_optimizers
    return mod


@pytest.fixture
def fake_modules(monkeypatch):
    """Install plugin modules in sys.modules so EntryPoint.load() finds them."""

    def install(**modules):
        for name, mod in modules.items():
            monkeypatch.setitem(sys.modules, name, mod)

    return install


def _ep(name: str, value: str) -> importlib.metadata.EntryPoint:
    return importlib.metadata.EntryPoint(name=name, value=value, group="vpid_bench")


def test_builtins_arrive_through_entry_points(registry):
    names = {ep.name for ep in importlib.metadata.entry_points(group="vpid_bench")}
    assert {"functions", "baselines"} <= names
    assert "functions" in registry.problems
    assert "random" in registry.optimizers
    assert registry.owner("optimizer", "random") == "baselines"


def test_two_plugins_with_one_optimizer_name_is_an_error_naming_both(fake_modules):
    fake_modules(plug_a=_plugin_module("plug_a", ("twin",)),
                 plug_b=_plugin_module("plug_b", ("twin",)))
    pm = get_plugin_manager([_ep("alpha", "plug_a"), _ep("beta", "plug_b")])
    with pytest.raises(PluginError) as info:
        Registry(pm)
    message = str(info.value)
    assert "'twin'" in message and "'alpha'" in message and "'beta'" in message


def test_two_entry_points_with_one_name_is_an_error(fake_modules):
    fake_modules(plug_a=_plugin_module("plug_a", ("a1",)), plug_b=_plugin_module("plug_b", ("b1",)))
    with pytest.raises(PluginError, match="entry-point name 'same'"):
        get_plugin_manager([_ep("same", "plug_a"), _ep("same", "plug_b")])


def test_a_plugin_that_fails_to_import_is_reported_and_skipped(fake_modules):
    fake_modules(plug_a=_plugin_module("plug_a", ("good",)))
    with pytest.warns(PluginLoadWarning, match="'broken'.*ModuleNotFoundError"):
        pm = get_plugin_manager([_ep("broken", "no_such_module_xyz"), _ep("alpha", "plug_a")])
    assert "broken" in pm.info.failed
    assert set(Registry(pm).optimizers) == {"good"}


def test_a_hook_that_raises_is_named_in_the_registry_info_and_by_the_preflight(fake_modules):
    """What went wrong while the plugins loaded has one home, the manager's ``info`` (it was
    an attribute stuck on pluggy's manager, read back with ``getattr`` in four places): a
    registration hook that raises is recorded there, and the pre-flight's error names it."""
    from vpid_bench.plugins import PluginManagerInfo
    from vpid_bench.shell.preflight import _check_choice

    mod = types.ModuleType("plug_raises")

    @hookimpl
    def vpid_bench_register_optimizers(register):
        register("half", Dummy)
        raise RuntimeError("boom")

    mod.vpid_bench_register_optimizers = vpid_bench_register_optimizers
    fake_modules(plug_raises=mod, plug_a=_plugin_module("plug_a", ("good",)))
    pm = get_plugin_manager([_ep("raiser", "plug_raises"), _ep("alpha", "plug_a")])
    assert isinstance(pm.info, PluginManagerInfo) and pm.info.failed == {}
    with pytest.warns(PluginLoadWarning, match="'raiser' failed to register"):
        registry = Registry(pm)
    assert registry.info is pm.info and registry.info.failed == {"raiser": "RuntimeError: boom"}
    assert set(registry.optimizers) == {"good"}  # what it half registered is undone
    with pytest.raises(ConfigError, match="failed to load: raiser: RuntimeError: boom"):
        _check_choice("optimizer", "half", registry)


def test_blocked_plugins_are_not_loaded(fake_modules, monkeypatch):
    fake_modules(plug_a=_plugin_module("plug_a", ("a1",)), plug_b=_plugin_module("plug_b", ("b1",)))
    monkeypatch.setenv(BLOCK_ENV, " beta , other")
    pm = get_plugin_manager([_ep("alpha", "plug_a"), _ep("beta", "plug_b")])
    assert pm.info.blocked == ["beta"]
    assert set(Registry(pm).optimizers) == {"a1"}


def test_a_hook_with_a_misspelled_name_is_refused(fake_modules):
    mod = types.ModuleType("plug_typo")

    @hookimpl
    def vpid_bench_register_optimiser(register):  # British spelling: no such hook
        pass

    mod.vpid_bench_register_optimiser = vpid_bench_register_optimiser
    fake_modules(plug_typo=mod)
    with pytest.raises(PluginError, match="plug_typo|typo"):
        get_plugin_manager([_ep("typo", "plug_typo")])


@pytest.mark.parametrize(
    "name, cls, fragment",
    [
        ("not-an-identifier", Dummy, "identifier"),
        ("notaclass", object, "not a subclass"),
    ],
)
def test_bad_registrations_are_refused(fake_modules, name, cls, fragment):
    mod = types.ModuleType("plug_bad")

    @hookimpl
    def vpid_bench_register_optimizers(register):
        register(name, cls)

    mod.vpid_bench_register_optimizers = vpid_bench_register_optimizers
    fake_modules(plug_bad=mod)
    with pytest.raises(PluginError, match=fragment):
        Registry(get_plugin_manager([_ep("bad", "plug_bad")]))


def test_unknown_names_list_the_known_ones(registry):
    with pytest.raises(ConfigError, match="random"):
        registry.optimizer("no_such_optimizer")
    with pytest.raises(ConfigError, match="functions"):
        registry.problem("no_such_problem")


def test_params_without_dataclass_are_refused(fake_modules):
    class NoParams(Dummy):
        Params = dict  # type: ignore[assignment]

    mod = types.ModuleType("plug_np")

    @hookimpl
    def vpid_bench_register_optimizers(register):
        register("np_opt", NoParams)

    mod.vpid_bench_register_optimizers = vpid_bench_register_optimizers
    fake_modules(plug_np=mod)
    with pytest.raises(PluginError, match="Params dataclass"):
        Registry(get_plugin_manager([_ep("np", "plug_np")]))
