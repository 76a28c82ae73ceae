"""Tuning sees held-out instances only: an optimizing sweeper (Optuna) on a problem's default
seed (its test instances) is refused in the pre-flight, naming the seed key to change."""

from __future__ import annotations

import pytest

from vpid_bench import ConfigError
from vpid_bench.shell.argv import parse_command_line
from vpid_bench.shell.callbacks import ensure_job_dir_resolver
from vpid_bench.shell.config_store import register_configs
from vpid_bench.shell.preflight import plan

TUNE = ["-m", "hydra/sweeper=optuna", "hydra.sweeper.n_trials=2", "optimizer=de1",
        "optimizer.F=interval(0.3,1.0)", "runs=2"]


def _plan(registry, tmp_path, *args):
    register_configs(registry)
    ensure_job_dir_resolver()
    return plan(parse_command_line([*TUNE, *args, f"hydra.sweep.dir={tmp_path}/t"]), registry)


@pytest.mark.parametrize("problem, key", [("smoke_quarter", "problem.seed"),
                                          ("vehicle", "problem.noise.seed")])
def test_tuning_on_the_test_instances_is_refused(registry, tmp_path, problem, key):
    with pytest.raises(ConfigError) as info:
        _plan(registry, tmp_path, f"problem={problem}")
    assert info.value.key == key
    assert "held-out instances when tuning" in str(info.value)
    assert f"{key}=1" in str(info.value)


@pytest.mark.parametrize("problem, key", [("smoke_quarter", "problem.seed"),
                                          ("vehicle", "problem.noise.seed")])
def test_tuning_on_held_out_instances_passes(registry, tmp_path, problem, key):
    assert _plan(registry, tmp_path, f"problem={problem}", f"{key}=1").jobs


def test_a_problem_without_instances_to_hold_out_is_let_through(registry, tmp_path):
    assert _plan(registry, tmp_path, "problem=functions", "problem.dim=3").jobs


def test_the_basic_sweeper_compares_on_the_test_instances(registry, tmp_path):
    register_configs(registry)
    ensure_job_dir_resolver()
    cmd = parse_command_line(["-m", "optimizer=de1,de4", "problem=smoke_quarter",
                              f"hydra.sweep.dir={tmp_path}/c"])
    assert len(plan(cmd, registry).jobs) == 2
