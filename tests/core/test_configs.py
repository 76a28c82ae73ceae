"""Every config composes: each registered problem with each registered optimizer, every YAML
preset shipped in conf/, and the user's sweep command's overrides."""

from __future__ import annotations

from importlib import resources

import pytest

from vpid_bench.api import ConfigError
from vpid_bench.spec import parse_job


def _yaml_presets(group: str) -> list[str]:
    folder = resources.files("vpid_bench.conf") / group
    if not folder.is_dir():
        return []
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def _check_job(cfg, registry):
    assert "ps" not in cfg.optimizer and "iterations" not in cfg.optimizer
    job = parse_job(cfg, registry)  # every plugin's own checks run here
    assert job.params.ps == cfg.problem.ps  # the protocol, copied from the problem
    assert job.params.iterations == cfg.problem.iterations
    assert job.budget == cfg.problem.ps * (cfg.problem.iterations + 1)
    return job


def test_every_problem_and_optimizer_composes_and_builds(registry, compose_config):
    """Every problem composes, parses and builds (with ``random``); every optimizer composes
    and parses with one problem of each distinct protocol (``ps``, ``iterations``), the
    values its own checks read. Each optimizer is composed by Hydra once; its node is set on
    the other protocols' problems as the pre-flight does (``shell/compose.Composer``, checked
    against Hydra's own composition by tests/sweeps/test_preflight_compose.py): a compose
    costs about 0.3 s, and the product of the two protocols took minutes on a loaded machine."""
    import copy

    from omegaconf import open_dict

    # problem=fmu needs the user's FMU and record: tests/fmu/test_fmu_cli.py composes and
    # builds it with the example FMU
    problems = sorted(set(registry.problems) - {"fmu"}) + _yaml_presets("problem")
    optimizers = sorted(registry.optimizers) + _yaml_presets("optimizer")
    assert "functions" in problems and "random" in optimizers
    protocols: dict[tuple[int, int], object] = {}
    for problem in problems:
        cfg = compose_config([f"problem={problem}", "optimizer=random"])
        job = _check_job(cfg, registry)
        assert job.problem_cls(job.problem_config).bounds.dim >= 1
        protocols.setdefault((cfg.problem.ps, cfg.problem.iterations), (problem, cfg))
    assert len(protocols) >= 2  # the paper's protocol and the smoke members' shorter one
    (first, _), *others = protocols.values()
    for optimizer in optimizers:
        cfg = compose_config([f"problem={first}", f"optimizer={optimizer}"])
        _check_job(cfg, registry)
        for _, base in others:
            task = copy.deepcopy(base)
            with open_dict(task):
                task.optimizer = copy.deepcopy(cfg.optimizer)
            _check_job(task, registry)


def test_protocol_defaults_are_the_papers(compose_config):
    cfg = compose_config(["problem=functions", "optimizer=random"])
    assert (cfg.problem.ps, cfg.problem.iterations, cfg.runs, cfg.seed) == (20, 50, 30, 0)
    assert cfg.budget is None


def test_problem_ps_override_reaches_the_optimizer(compose_config, registry):
    cfg = compose_config(["problem=functions", "optimizer=random", "problem.ps=30"])
    job = parse_job(cfg, registry)
    assert (job.params.ps, job.budget) == (30, 30 * 51)


def test_the_protocol_cannot_be_set_on_the_optimizer(compose_config, registry):
    """``optimizer.ps=7`` would decouple the budget from the population: refused."""
    cfg = compose_config(["problem=functions", "optimizer=random", "+optimizer.ps=7"])
    with pytest.raises(ConfigError, match="set problem.ps"):
        parse_job(cfg, registry)


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
    from vpid_bench.shell.callbacks import ensure_job_dir_resolver

    ensure_job_dir_resolver()
    assert cfg.hydra.sweep.subdir == "optimizer=random,problem=functions"
    assert str(cfg.hydra.sweep.dir).startswith("outputs/")
    assert str(cfg.hydra.run.dir).startswith("outputs/")


def test_a_yaml_preset_extends_a_registered_problem(compose_config, registry):
    from vpid_bench.shell.argv import parse_command_line
    from vpid_bench.shell.preflight import plan
    from vpid_bench.shell.presets import yaml_presets

    assert yaml_presets("problem")["vehicle_long_record"] == "vehicle"
    cfg = compose_config(["problem=vehicle_long_record", "optimizer=de4"])
    assert cfg.problem.name == "vehicle" and cfg.problem.record.extra == 0.5
    checked = plan(parse_command_line(["problem=vehicle_long_record", "problem.record.extra=1"]),
                   registry)
    assert [j.problem_name for j in checked.jobs] == ["vehicle"]
    assert checked.jobs[0].problem_config.record.extra == 1.0


def test_the_folder_name_leaves_out_exactly_the_operational_keys():
    """The spec node's exclude_keys (what a job folder's name leaves out) and
    spec.OPERATIONAL_KEYS (what may differ between a sweep and its resume) are one list
    written twice; a key added to one only (as archive nearly was) fails here."""
    from vpid_bench.shell.config_store import spec_node
    from vpid_bench.spec import OPERATIONAL_KEYS

    excluded = spec_node()["hydra"]["job"]["config"]["override_dirname"]["exclude_keys"]
    assert sorted(excluded) == sorted(OPERATIONAL_KEYS)
