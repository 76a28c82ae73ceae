"""The problem contract grouped into capabilities (vpid_bench/contract.py): a problem that
implements half of one is refused with one line naming what is missing, before any run."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from vpid_bench import Bounds, Problem, ProblemConfig
from vpid_bench.api import ConfigError
from vpid_bench.contract import CAPABILITIES, check_problem_class, offered

ROOT = Path(__file__).resolve().parents[2]


class Core(Problem):
    Config = ProblemConfig

    @property
    def bounds(self):
        return Bounds(np.zeros(2), np.ones(2), ("a", "b"))

    def evaluate(self, X):
        return np.sum(np.atleast_2d(X) ** 2, axis=1)


class InstanceOnly(Core):
    """The case that gave wrong numbers silently: instance(i) without instance_id()."""

    def instance(self, index):
        return self


class InstanceIdAttribute(Core):
    def instance(self, index):
        return self

    instance_id = "fixed"


class GroupsWithoutResiduals(Core):
    def residual_groups(self):
        return np.zeros(2, dtype=int)


class UnitsWithoutSignals(Core):
    def signal_units(self):
        return {"x": "m"}


class Whole(Core):
    def instance(self, index):
        return self

    def instance_id(self):
        return "one"

    def residuals(self, X):
        return np.atleast_2d(X)

    def signals(self, x):
        return {"t": np.arange(2.0), "x:measured": np.zeros(2), "x:fitted": np.asarray(x)}


@pytest.mark.parametrize("cls,missing", [
    (InstanceOnly, "but not instance_id()"),
    (GroupsWithoutResiduals, "but not residuals()"),
    (UnitsWithoutSignals, "but not signals()"),
])
def test_half_a_capability_is_refused_naming_what_is_missing(cls, missing):
    with pytest.raises(ConfigError) as err:
        check_problem_class(cls, "planted")
    text = str(err.value)
    assert text.startswith("problem='planted' is not allowed") and missing in text
    assert "\n" not in text


def test_a_method_replaced_by_a_value_is_refused():
    """instance_id = 'fixed' used to fail mid-job with "'str' object is not callable"."""
    with pytest.raises(ConfigError, match=r"instance_id must be a method.*not a str"):
        check_problem_class(InstanceIdAttribute, "planted")


def test_whole_capabilities_and_the_built_ins_pass(registry):
    check_problem_class(Core)
    check_problem_class(Whole)
    assert offered(Whole) == ["core", "residuals", "instances", "signals"]
    assert offered(Core) == ["core"]
    for name, cls in registry.problems.items():
        check_problem_class(cls, name)


def test_the_job_refuses_it_before_any_run(registry_of, tmp_path):
    """parse_job (the job and every point of the pre-flight) refuses the class: no folder,
    no record."""
    from vpid_bench import hookimpl as hook
    from vpid_bench.experiment import run_from_config

    class Plugin:
        @hook
        def vpid_bench_register_problems(self, register):
            register("half", InstanceOnly)

        @hook
        def vpid_bench_register_optimizers(self, register):
            from vpid_baselines.plugin import RandomSearch

            register("random", RandomSearch)

    registry = registry_of(("planted", Plugin()))
    cfg = {"problem": {"name": "half"}, "optimizer": {"name": "random"}, "runs": 2,
           "progress": False}
    with pytest.raises(ConfigError, match="but not instance_id"):
        run_from_config(cfg, tmp_path / "job", registry)
    assert not (tmp_path / "job").exists()


def test_every_member_of_the_contract_is_in_the_readme_table_and_in_a_capability():
    """The README's table names every member of Problem a plugin may define, and each member
    belongs to exactly one capability."""
    members = {m for cap in CAPABILITIES for m in cap.members}
    listed = [m for cap in CAPABILITIES for m in cap.members]
    assert len(listed) == len(members)
    public = {name for name in vars(Problem) if not name.startswith("_")} | {"Config"}
    public -= {"has_residuals"}  # derived from residuals(), not a member a plugin defines
    assert public == members, public ^ members
    text = (ROOT / "docs" / "plugins.md").read_text(encoding="utf-8")
    table = set(re.findall(r"^\| `([a-z_A-Z]+)(?:\(|`)", text, re.M))
    assert members <= table, members - table
