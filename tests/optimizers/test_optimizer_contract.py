"""The ask/tell contract, checked for EVERY registered optimizer (third-party ones included):
inside the box, within the budget, reproducible with a seed, different across seeds.

The project's own optimizers are checked in the pytest process; a third party's (an installed
plugin of another distribution) in a subprocess of its own: one that calls ``os._exit`` or
crashes once ended ``make test`` with no message (issue 44); now its test fails, named, with
how its process ended."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.plugins import Registry
from vpid_bench.runner import run

PS, ITERATIONS, DIM = 20, 5, 4
BUDGET = PS * (ITERATIONS + 1)
#: Optimizers that use no randomness on purpose (the same answer for every seed).
DETERMINISTIC = {"centre"}
#: The distribution of the project's own optimizers (checked in the pytest process).
OWN = "vpid-bench"
#: Seconds a third party's optimizer may take for the checks in its subprocess.
CHILD_S = 600


def _names() -> list[str]:
    return sorted(Registry().optimizers)


class CountingProblem:
    """Wraps a problem: counts evaluated rows and checks every row is inside the box."""

    def __init__(self, problem):
        self.inner, self.name, self.bounds = problem, problem.name, problem.bounds
        self.evaluated = 0
        self.outside = 0

    def evaluate(self, X):
        self.evaluated += len(X)
        self.outside += int(np.sum(~self.bounds.contains(X)))
        return self.inner.evaluate(X)

    # the residual path (least-squares optimizers), counted the same way
    @property
    def has_residuals(self):
        return self.inner.has_residuals

    def residual_groups(self):
        return self.inner.residual_groups()

    def evaluate_with_residuals(self, X):
        self.evaluated += len(X)
        self.outside += int(np.sum(~self.bounds.contains(X)))
        return self.inner.evaluate_with_residuals(X)


def _run(registry, name: str, seed: int, function: str = "rastrigin"):
    problem = build_problem(registry, {"name": "functions", "function": function, "dim": DIM,
                                       "ps": PS, "iterations": ITERATIONS})
    cls, params = optimizer_params(registry, {"name": name, "ps": PS, "iterations": ITERATIONS})
    counting = CountingProblem(problem)
    optimizer = cls(params, problem.bounds, np.random.default_rng(seed))
    optimizer.name = name
    return run(counting, optimizer, BUDGET), counting


def test_the_family_is_registered(registry):
    assert {f"de{i}" for i in range(1, 9)} | {"ga", "random"} <= set(registry.optimizers)


def third_party(registry, name: str) -> bool:
    """Whether optimizer ``name`` comes from another distribution than the project's own."""
    return registry.provenance("optimizer", name).get("distribution") != OWN


def _how(code: int) -> str:
    if code < 0:
        try:
            return f"signal {signal.Signals(-code).name}"
        except ValueError:
            return f"signal {-code}"
    return f"exit code {code}"


def _in_subprocess(name: str) -> None:
    """:func:`check` of ``name`` in a process of its own; fails the test naming the optimizer
    and how its process ended."""
    code = (f"import sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
            "import test_optimizer_contract as t; t.check_alone(sys.argv[1])")
    done = subprocess.run([sys.executable, "-c", code, name], capture_output=True, text=True,
                          timeout=CHILD_S, check=False)
    if done.returncode != 0:
        pytest.fail(f"the third party's optimizer {name!r} failed its contract check in its "
                    f"own process ({_how(done.returncode)}): {done.stderr[-2000:]}",
                    pytrace=False)


def check_alone(name: str) -> None:
    """:func:`check` in a process of its own (the installed registry)."""
    check(Registry(), name)


@pytest.mark.parametrize("name", _names())
def test_contract(registry, name):
    if third_party(registry, name):
        _in_subprocess(name)
    else:
        check(registry, name)


def check(registry, name: str) -> None:
    """The contract (see module) for optimizer ``name``."""
    result, counting = _run(registry, name, seed=1)
    assert counting.outside == 0
    assert counting.evaluated == result.evaluations <= BUDGET
    assert counting.bounds.contains(result.x_best).all()
    again, _ = _run(registry, name, seed=1)
    np.testing.assert_array_equal(again.x_best, result.x_best)
    assert again.trace_best == result.trace_best
    other, _ = _run(registry, name, seed=2)
    assert np.array_equal(other.x_best, result.x_best) == (name in DETERMINISTIC)


def test_compose_variant_parameters(compose_config):
    from hydra.errors import ConfigCompositionException

    cfg = compose_config(["problem=functions", "optimizer=de6", "optimizer.K=0.4"])
    assert cfg.optimizer.K == 0.4 and "ps" not in cfg.optimizer
    with pytest.raises(ConfigCompositionException, match="optimizer.K"):
        compose_config(["problem=functions", "optimizer=de1", "optimizer.K=0.4"])


def test_run_from_config_ga_and_de(compose_config, tmp_path):
    from vpid_bench.experiment import run_from_config
    from vpid_bench.store.records import read_record

    for name, expected in (("de8", [10, 10, 10, 10]), ("ga", [10, 10, 10, 10]),
                           ("ga", [20, 20, 20, 20])):
        ps = expected[0]
        cfg = compose_config(["problem=functions", f"optimizer={name}", f"problem.ps={ps}",
                              "problem.iterations=3", "runs=2", "progress=false",
                              "report=false"])
        summary = run_from_config(cfg, tmp_path / f"{name}-{ps}")
        assert summary.ran == 2 and not summary.failed
        record = read_record(summary.record_paths[0])
        steps = np.diff([0, *record["trace"]["evaluations"]]).tolist()
        # GA: the whole population is scored every generation, elites included (as stepGA)
        assert steps == expected
