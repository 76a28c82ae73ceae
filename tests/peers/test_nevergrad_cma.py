"""``vpid_peers.nevergrad_cma``: nevergrad's CMA reusing its running strategy, and asked
through the optimizer the registry's ``CMA`` selects, asks and tells exactly what it did
before (over restarts), through the plugin too, and the speed-up is in
effect for ``optimizer=nevergrad``'s default (a nevergrad whose internals moved fails here).
Its time is measured by ``benchmarks/bench_nevergrad_cma.py``, not here. About 5 s."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vpid_bench.build import build_problem, optimizer_params, run_rng
from vpid_bench.runner import run

ng = pytest.importorskip("nevergrad")

from vpid_peers import nevergrad_cma, nevergrad_opt  # noqa: E402
from vpid_peers.nevergrad_cma import (  # noqa: E402
    cma_class,
    driven,
    skip_repeated_bounds_check,
)

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")  # nevergrad's, cma's advice


def _inner(optimizer):
    return getattr(optimizer, "optim", optimizer)


def _candidates(method: str, reuse: bool, evaluations: int = 2500, dim: int = 2,
                direct: bool = False):
    """Every candidate nevergrad asks on a sphere in the unit box, and how many cma
    strategies it made (the first one and one per restart); ``direct``: asking and telling
    the optimizer :func:`driven` returns, as the plugin does."""
    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(7)
    optimizer = ng.optimizers.registry[method](parametrization=parametrization,
                                               budget=evaluations, num_workers=1)
    if reuse:
        skip_repeated_bounds_check(optimizer)
    if direct:
        optimizer = driven(optimizer)
    asked, strategies, last = [], 0, None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(evaluations):
            candidate = optimizer.ask()
            x = np.array(candidate.value)
            asked.append(x)
            optimizer.tell(candidate, float(np.sum((x - 0.5) ** 2)))
            strategy = getattr(_inner(optimizer), "_es", None)
            if strategy is not None and strategy is not last:
                strategies, last = strategies + 1, strategy
    return np.array(asked), strategies


@pytest.mark.parametrize("method", ["CMA", "OldCMA"])
def test_the_same_candidates_over_restarts(method):
    before, made_before = _candidates(method, reuse=False)
    after, made_after = _candidates(method, reuse=True)
    assert made_before >= 3  # a sphere converges: cma stops and nevergrad restarts it
    assert made_after == made_before
    np.testing.assert_array_equal(after, before)


def test_asking_the_selected_optimizer_gives_the_same_candidates(dim=4):
    """The registry's ``CMA`` asked through its selected optimizer (with the reuse, as the
    plugin does) asks exactly what the wrapper asks, restarts included."""
    before, made_before = _candidates("CMA", reuse=False, dim=dim)
    after, made_after = _candidates("CMA", reuse=True, dim=dim, direct=True)
    assert made_before >= 2 and made_after == made_before
    np.testing.assert_array_equal(after, before)


def test_driven_is_the_selected_optimizer_for_the_wrapper_only():
    parametrization = ng.p.Array(init=np.full(3, 0.3), lower=0.0, upper=1.0)
    wrapper = ng.optimizers.registry["CMA"](parametrization=parametrization, budget=20,
                                            num_workers=1)
    assert driven(wrapper) is wrapper.optim and isinstance(driven(wrapper), cma_class())
    plain = ng.optimizers.registry["TwoPointsDE"](parametrization=parametrization, budget=20,
                                                  num_workers=1)
    assert driven(plain) is plain


def test_in_effect_for_the_plugins_default(registry):
    """The plugin's default (``CMA``) builds the reusing class: if a nevergrad upgrade moves
    ``_CMA``, ``_es`` or ``_config``, this fails (the plugin then still runs, without it)."""
    assert cma_class() is not None
    problem = build_problem(registry, {"name": "functions", "function": "sphere", "dim": 3})
    cls, params = optimizer_params(registry, {"name": "nevergrad", "budget": 50})
    optimizer = cls(params, problem.bounds, run_rng(1, 0))
    optimizer.ask()
    inner = optimizer._ng  # the selected optimizer itself, not the registry's wrapper
    assert not isinstance(inner, ng.optimizers.registry["MetaCMA"])
    assert type(inner) is not cma_class() and isinstance(inner, cma_class())
    assert type(inner).__name__ == "_CMA"


def test_other_methods_are_left_alone():
    parametrization = ng.p.Array(init=np.full(3, 0.3), lower=0.0, upper=1.0)
    optimizer = ng.optimizers.registry["TwoPointsDE"](parametrization=parametrization,
                                                      budget=20, num_workers=1)
    cls = type(optimizer)
    assert skip_repeated_bounds_check(optimizer) is optimizer and type(optimizer) is cls


def test_a_run_of_the_plugin_is_unchanged(registry, monkeypatch):
    """``optimizer=nevergrad`` through the run loop, as built and as nevergrad is: the same
    best value after every evaluation (each batch is one candidate), the same best point."""
    problem = build_problem(registry, {"name": "functions", "function": "rosenbrock",
                                       "dim": 3})
    cls, params = optimizer_params(registry, {"name": "nevergrad", "budget": 900})

    def once():
        return run(problem, cls(params, problem.bounds, run_rng(3, 0)), 900)

    reused = once()
    monkeypatch.setattr(nevergrad_opt, "skip_repeated_bounds_check", lambda o: o)
    monkeypatch.setattr(nevergrad_opt, "driven", lambda o: o)
    plain = once()
    assert reused.evaluations == plain.evaluations == 900
    assert reused.batches == 900
    np.testing.assert_array_equal(reused.trace_best, plain.trace_best)
    np.testing.assert_array_equal(reused.x_best, plain.x_best)
    assert nevergrad_cma._reusing.cache_info().currsize >= 1
