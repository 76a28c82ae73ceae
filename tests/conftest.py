"""Shared test set-up: a headless matplotlib, and helpers to compose Hydra configs."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator, Sequence

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("MPLCONFIGDIR", tempfile.mkdtemp(prefix="vpid-mpl-"))


def pytest_configure(config: pytest.Config) -> None:
    """Under xdist, pin each test process to one core of its own (``gw0`` the first, ...),
    with every process it starts: a CLI test's command then sees one core, as on a one-core
    allocation, and starts one worker process per job, not one per core (each costs about
    1.2 s of CPU to start), and two test processes never share a core. Not Linux, or one core:
    nothing is pinned. A test that needs more cores widens its own (tests/extras.py)."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "").removeprefix("gw")
    if not worker.isdigit() or not hasattr(os, "sched_setaffinity"):
        return
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) > 1:
        os.sched_setaffinity(0, {cores[int(worker) % len(cores)]})


@pytest.fixture(scope="session")
def registry():
    """The plugin registry of the installed environment (built-ins and third parties)."""
    from vpid_bench.plugins import Registry

    return Registry()


@pytest.fixture
def in_tmp(tmp_path, monkeypatch):
    """Run in an empty folder; keep the invocation id of main() out of this process."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("VPID_BENCH_INVOCATION", "test")
    monkeypatch.delenv("VPID_BENCH_DEBUG", raising=False)
    return tmp_path


@pytest.fixture(scope="session")
def registry_of():
    """``registry_of((name, plugin), ...)``: a registry of exactly these plugins (no installed
    entry points), for tests that plant a misbehaving one."""
    from vpid_bench.plugins import Registry, get_plugin_manager

    def build(*plugins: tuple[str, object]) -> Registry:
        return Registry(get_plugin_manager(entry_points=[], extra_plugins=list(plugins)))

    return build


@pytest.fixture(scope="session")
def compose_config(registry) -> Iterator:
    """``compose_config(overrides)`` -> the composed config, as the CLI would build it."""
    from hydra import compose, initialize_config_module
    from hydra.core.global_hydra import GlobalHydra

    from vpid_bench.shell.config_store import register_configs

    register_configs(registry)

    def _compose(overrides: Sequence[str] = ()):
        GlobalHydra.instance().clear()
        with initialize_config_module(version_base="1.3", config_module="vpid_bench.conf"):
            return compose(config_name="config", overrides=list(overrides))

    yield _compose
    GlobalHydra.instance().clear()


@pytest.fixture(scope="session")
def example_fmu(tmp_path_factory):
    """``example_fmu(name)``: the example quarter-car FMU (plugins/vpid_fmu/sources) built
    once per test session with gcc, as variant ``name`` (``fmi2``: FMI 2.0 co-simulation and
    model exchange; ``fmi3``; ``nointerp``; ``crash``; ``hang``; ``nobinary``; ``guid``: a
    binary that accepts another token). Skips with the reason where gcc or fmpy is missing."""
    pytest.importorskip("fmpy", reason="problem=fmu needs fmpy (pip install .[fmu])")
    from vpid_fmu import example

    if example.compiler() is None:
        pytest.skip("no C compiler (gcc) to build the test FMUs")
    folder = tmp_path_factory.mktemp("fmus")
    variants = {
        "fmi2": {}, "fmi3": {"fmi": 3, "kinds": ("cs",)}, "nointerp": {"interpolate": False},
        "crash": {"variant": "crash"}, "hang": {"variant": "hang"}, "nobinary": {"binary": False},
        "guid": {"binary_guid": "{00000000-0000-0000-0000-000000000000}"},
    }
    built: dict[str, object] = {}

    def get(name: str):
        if name not in built:
            built[name] = example.build(folder / f"{name}.fmu", **variants[name])
        return built[name]

    return get
