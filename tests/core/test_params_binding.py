"""An optimizer plugin that forgets ``Params = MyParams`` is refused before any run, in one
line naming what its code reads (issue 46: it used to fail every run with AttributeError)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from vpid_bench.errors import ConfigError
from vpid_bench.optimizer import Optimizer, OptimizerParams
from vpid_bench.params_binding import check_params_bound, params_read
from vpid_bench.plugins import Registry
from vpid_bench.spec import parse_job


@dataclasses.dataclass(frozen=True)
class StepParams(OptimizerParams):
    sigma: float = 0.1


class Forgot(Optimizer):
    """Reads ``sigma`` but never binds ``Params = StepParams``."""

    def ask(self) -> np.ndarray:
        return self.bounds.lower + self.params.sigma * (self.bounds.upper - self.bounds.lower)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


class Bound(Forgot):
    """The same code with its Params bound."""

    Params = StepParams


class OnlyBase(Optimizer):
    """Reads only what the base parameters have."""

    def ask(self) -> np.ndarray:
        return np.tile(self.bounds.lower, (self.params.ps, 1))

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        pass


def test_the_class_source_is_read_for_its_parameters():
    assert params_read(Forgot) == {"sigma"}
    assert "ps" in params_read(OnlyBase)


def test_an_unbound_params_is_refused_naming_the_parameter():
    with pytest.raises(ConfigError, match=r"sigma missing from OptimizerParams.*"
                                          r"bind Params = "):
        check_params_bound(Forgot, "forgot")


def test_a_bound_params_or_base_only_reads_pass():
    check_params_bound(Bound, "bound")
    check_params_bound(OnlyBase, "only_base")


def test_every_registered_optimizer_passes():
    registry = Registry()
    for name, cls in registry.optimizers.items():
        check_params_bound(cls, name)


def test_the_job_refuses_it_before_any_run():
    registry = Registry()
    registry.optimizers["forgot"] = Forgot
    cfg = {"problem": {"name": "functions"}, "optimizer": {"name": "forgot"}}
    with pytest.raises(ConfigError, match="optimizer=forgot") as err:
        parse_job(cfg, registry)
    assert str(err.value).count("\n") == 0
    registry.optimizers["forgot"] = Bound
    assert parse_job(cfg, registry).params.sigma == 0.1
