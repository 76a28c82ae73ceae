"""Every config composes: each registered problem with each registered optimizer, every YAML
preset shipped in conf/, and the user's sweep command's overrides."""

from __future__ import annotations

from importlib import resources

import pytest

from vpid_bench.experiment import build_problem, optimizer_params


def _yaml_presets(group: str) -> list[str]:
    folder = resources.files("vpid_bench.conf") / group
    if not folder.is_dir():
        return []
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def test_every_problem_and_optimizer_composes_and_builds(registry, compose_config):
    problems = sorted(registry.problems) + _yaml_presets("problem")
    optimizers = sorted(registry.optimizers) + _yaml_presets("optimizer")
    assert "functions" in problems and "random" in optimizers
    for problem in problems:
        for optimizer in optimizers:
            cfg = compose_config([f"problem={problem}", f"optimizer={optimizer}"])
            assert cfg.optimizer.ps == cfg.problem.ps  # interpolated protocol
            assert cfg.optimizer.iterations == cfg.problem.iterations
            built = build_problem(registry, cfg.problem)
            assert built.bounds.dim >= 1
            cls, params = optimizer_params(registry, cfg.optimizer)
            assert params.ps == cfg.problem.ps


def test_protocol_defaults_are_the_papers(compose_config):
    cfg = compose_config(["problem=functions", "optimizer=random"])
    assert (cfg.problem.ps, cfg.problem.iterations, cfg.runs, cfg.seed) == (20, 50, 30, 0)
    assert cfg.budget is None


def test_problem_ps_override_reaches_the_optimizer(compose_config):
    cfg = compose_config(["problem=functions", "optimizer=random", "problem.ps=30"])
    assert cfg.optimizer.ps == 30


def test_optimizer_can_override_its_own_population(compose_config):
    cfg = compose_config(["problem=functions", "optimizer=random", "optimizer.ps=7"])
    assert (cfg.optimizer.ps, cfg.problem.ps) == (7, 20)


def test_unknown_key_is_refused_by_struct_mode(compose_config):
    from hydra.errors import ConfigCompositionException

    with pytest.raises(ConfigCompositionException, match="nosuchkey"):
        compose_config(["problem=functions", "optimizer=random", "optimizer.nosuchkey=1"])


def test_sweep_dirs_are_named_by_overrides(compose_config):
    from hydra import compose, initialize_config_module
    from hydra.core.global_hydra import GlobalHydra

    GlobalHydra.instance().clear()
    with initialize_config_module(version_base="1.3", config_module="vpid_bench.conf"):
        cfg = compose("config", overrides=["problem=functions", "optimizer=random"],
                      return_hydra_config=True)
    assert cfg.hydra.sweep.subdir == "optimizer=random,problem=functions"
    assert str(cfg.hydra.sweep.dir).startswith("outputs/")
    assert str(cfg.hydra.run.dir).startswith("outputs/")


def test_a_yaml_preset_extends_a_registered_problem(compose_config, registry):
    from vpid_bench.preflight import check_overrides, yaml_presets

    assert yaml_presets("problem")["vehicle_long_record"] == "vehicle"
    cfg = compose_config(["problem=vehicle_long_record", "optimizer=de4"])
    assert cfg.problem.name == "vehicle" and cfg.problem.record.extra == 0.5
    chosen = check_overrides(["problem=vehicle_long_record", "problem.record.extra=1"], registry,
                             {"problem": "vehicle", "optimizer": "de4"})
    assert chosen["problem"] == ["vehicle"]
