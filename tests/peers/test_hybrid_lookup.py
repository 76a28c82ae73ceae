"""de_lsq composes the installed de4 by name (``vpid_bench.registered_optimizer``), so the
peers package imports no other plugin package; without de4 it is refused with one line."""

from __future__ import annotations

import numpy as np
import pytest
from vpid_peers import hybrid

from vpid_bench import Bounds, ConfigError, registered_optimizer


def _bounds() -> Bounds:
    return Bounds(np.zeros(3), np.ones(3), ("a", "b", "c"))


def test_the_first_stage_is_the_installed_de4():
    opt = hybrid.DELeastSquares(hybrid.DELSQParams(ps=10, iterations=4, budget=100), _bounds(),
                                np.random.default_rng(0))
    assert opt._de_class is registered_optimizer("de4")
    # 0.5 of a 100-evaluation budget at ps=10: the initial population and 4 generations
    assert opt._de_params.iterations == 4 and opt._de_params.F == 0.6


def test_without_de4_installed_de_lsq_is_refused_naming_what_is_installed(monkeypatch):
    monkeypatch.setenv("VPID_BENCH_BLOCK_PLUGINS", "de")
    hybrid._first_stage.cache_clear()
    try:
        with pytest.raises(ConfigError) as err:
            hybrid.DELeastSquares(hybrid.DELSQParams(ps=10, iterations=4, budget=100),
                                  _bounds(), np.random.default_rng(0))
    finally:
        hybrid._first_stage.cache_clear()
    assert err.value.key == "optimizer" and err.value.value == "de4"
    assert "de_lsq" in str(err.value) and "de1" not in str(err.value)

