"""The pre-flight composes a sweep over problems and optimizers of the shipped config once per
problem and once per optimizer (``shell/compose.py``: ``Composer``), and gets exactly the
jobs that composing every point gets; a user's own config is composed point by point. About
10 s."""

from __future__ import annotations

from pathlib import Path

import pytest

from vpid_bench.shell import compose as composition
from vpid_bench.shell import preflight
from vpid_bench.shell.argv import SHIPPED_CONFIGS, ConfigSource
from vpid_bench.shell.config_store import register_configs

PROBLEMS = ["vehicle", "vehicle_long_record", "functions", "vpid1_q_golden_hump",
            "vpid1_l_civic_sine"]
OPTIMIZERS = ["de1", "de4", "ga", "random"]


@pytest.fixture()
def counted(monkeypatch, registry):
    """How many times Hydra composed a config."""
    register_configs(registry)
    calls = []
    real = composition._compose

    def compose(overrides, hydra, source=composition.SHIPPED):
        calls.append(list(overrides))
        return real(overrides, hydra, source)

    monkeypatch.setattr(composition, "_compose", compose)
    return calls


def _points(*axes: list[str]) -> list[list[str]]:
    import itertools

    return [list(p) for p in itertools.product(*axes)]


def _sweep(extra: list[list[str]] | None = None) -> list[list[str]]:
    return _points([f"problem={p}" for p in PROBLEMS], [f"optimizer={o}" for o in OPTIMIZERS],
                   *(extra or []))


def test_each_problem_and_optimizer_composed_once_with_the_same_jobs(registry, counted,
                                                                      monkeypatch):
    points = _sweep([["problem.ps=20", "problem.ps=30"], ["hydra.sweep.dir=/tmp/x"]])
    jobs, full = preflight.check_points(points, registry)
    assert len(counted) == len(PROBLEMS) + len(OPTIMIZERS) - 1
    assert full is not None and "hydra" in full
    counted.clear()
    monkeypatch.setattr(composition.Composer, "_separable", lambda self, structural: False)
    every, _ = preflight.check_points(points, registry)
    assert len(counted) == len(PROBLEMS) * len(OPTIMIZERS)  # each point, whole
    assert jobs == every
    # the plain overrides of each point are its own, not a neighbour's
    assert [j.problem_config.ps for j in jobs if j.problem_name == "functions"] == [20, 30] * 4
    assert [j.optimizer_name for j in jobs] == [o for _ in PROBLEMS for o in OPTIMIZERS
                                                for _ in range(2)]
    # vehicle and its preset vehicle_long_record (a longer record), each at ps 20 and 30
    assert len({repr(j.problem_config) for j in jobs if j.problem_name == "vehicle"}) == 4


def test_an_optimizer_setting_stays_with_its_point(registry, counted):
    """A plain override of the optimizer's node, swept, lands on its own point only (the
    node comes from another point's composition and is copied)."""
    points = _points(["problem=functions", "problem=vehicle"], ["optimizer=de1", "optimizer=de4"],
                     ["optimizer.F=0.3", "optimizer.F=0.9"])
    jobs, _ = preflight.check_points(points, registry)
    assert len(counted) == 3
    assert [(j.problem_name, j.optimizer_name, j.params.F) for j in jobs] == \
        [(p.split("=")[1], o.split("=")[1], float(f.split("=")[1])) for p, o, f in points]


def test_a_users_config_is_composed_point_by_point(registry, counted, tmp_path: Path):
    (tmp_path / "mine.yaml").write_text(
        "defaults:\n  - vpid_bench_spec\n  - problem: functions\n  - optimizer: random\n"
        "  - _self_\n")
    source = ConfigSource(str(tmp_path), "mine", SHIPPED_CONFIGS)
    points = _points(["problem=functions", "problem=vehicle"], ["optimizer=de1", "optimizer=ga"])
    jobs, _ = preflight.check_points(points, registry, source)
    assert len(counted) == 4 and len(jobs) == 4


def test_a_searchpath_or_a_group_override_is_composed_whole(registry, counted):
    points = _points(["problem=functions", "problem=vehicle"], ["optimizer=de1", "optimizer=ga"],
                     ["hydra/launcher=basic"])
    preflight.check_points(points, registry)
    assert len(counted) == 4
