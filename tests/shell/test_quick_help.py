"""``vpid-bench --help`` built without Hydra's help machinery (issue 46), and the near-miss
hints of the one-line refusals."""

from __future__ import annotations

import pytest

from vpid_bench.errors import ConfigError
from vpid_bench.plugins import Registry
from vpid_bench.shell import preflight
from vpid_bench.shell.argv import parse_command_line
from vpid_bench.shell.config_store import register_configs
from vpid_bench.shell.quick_help import help_text


@pytest.fixture(scope="module")
def registry():
    reg = Registry()
    register_configs(reg)
    return reg


def _choices(text: str) -> str:
    return text.split("== Choices (group=option) ==")[1].split("== Config")[0]


def test_help_lists_every_problem_and_optimizer(registry):
    text = help_text(parse_command_line(["--help"]), registry)
    assert text is not None and text.startswith("vpid-bench:")
    choices = _choices(text)
    lines = {line.split(":")[0]: line.split(": ")[1].split(", ")
             for line in choices.strip().splitlines()}
    assert set(registry.optimizers) <= set(lines["optimizer"])
    assert set(registry.problems) <= set(lines["problem"])
    assert "Hydra's own flags: --hydra-help" in text  # the footer


def test_help_shows_the_selected_config_with_overrides(registry):
    text = help_text(parse_command_line(["optimizer=ga", "problem.ps=31", "--help"]), registry)
    config = text.split("== Config of this selection")[1]
    assert "name: ga" in config and "ps: 31" in config and "crossover_fraction" in config


def test_help_of_a_sweep_list_or_custom_config_is_left_to_hydra(registry, tmp_path):
    assert help_text(parse_command_line(["-m", "optimizer=ga,de1", "--help"]), registry) is None
    assert help_text(parse_command_line(["-cd", str(tmp_path), "--help"]), registry) is None


def test_help_refuses_a_bad_choice_in_one_error(registry):
    with pytest.raises(ConfigError):
        help_text(parse_command_line(["optimizer=nope_not_here", "--help"]), registry)


def test_a_near_miss_choice_suggests_the_name(registry):
    with pytest.raises(ConfigError, match=r"\(did you mean de4\?\)"):
        preflight._check_choice("optimizer", "de44", registry)
    with pytest.raises(ConfigError) as far:
        preflight._check_choice("optimizer", "zzzzzz", registry)
    assert "did you mean" not in str(far.value)


def test_a_near_miss_key_suggests_the_key(registry):
    cmd = parse_command_line(["runz=3"])
    with pytest.raises(ConfigError, match=r"did you mean runs\?"):
        preflight.plan(cmd, registry)
    with pytest.raises(ConfigError, match=r"keys under optimizer are .*did you mean F\?"):
        preflight.plan(parse_command_line(["optimizer=de4", "optimizer.FF=3"]), registry)


def test_did_you_mean_is_empty_without_a_close_name():
    assert preflight.did_you_mean("de44", ["de4", "ga"]) == " (did you mean de4?)"
    assert preflight.did_you_mean("qqq", ["de4", "ga"]) == ""


def test_the_resume_command_repeats_every_override_and_the_folder():
    from pathlib import Path

    from vpid_bench.shell.resume import resume_command

    given = ["-m", "optimizer=de1,ga", "runs=5", "hydra.sweep.dir=my sweep"]
    assert resume_command(given, Path("my sweep"), "hydra.sweep.dir") == (
        "vpid-bench -m optimizer=de1,ga runs=5 'hydra.sweep.dir=my sweep' --resume")
    assert resume_command(["-m", "runs=5", "--resume"], Path("outputs/multirun/x"),
                          "hydra.sweep.dir") == (
        "vpid-bench -m runs=5 --resume=outputs/multirun/x")
