"""``vpid_peers.nevergrad_cma`` and ``nevergrad_replica``: nevergrad's CMA reusing its running
strategy, asked through the optimizer the registry's ``CMA`` selects, and replicated on cma,
asks and tells exactly what nevergrad does (over restarts, infinite losses, batches), through
the plugin too, and the speed-up is in
effect for ``optimizer=nevergrad``'s default (a nevergrad whose internals moved fails here).
Its time is measured by ``benchmarks/bench_nevergrad_cma.py``, not here. About 5 s."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vpid_bench.build import build_problem, optimizer_params, run_rng
from vpid_bench.runner import run

ng = pytest.importorskip("nevergrad")

from vpid_peers import nevergrad_cma, nevergrad_opt, nevergrad_replica  # noqa: E402
from vpid_peers.nevergrad_cma import (  # noqa: E402
    cma_class,
    driven,
    skip_repeated_bounds_check,
)
from vpid_peers.nevergrad_replica import ReplicatedCMA, replicated, why_not  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")  # nevergrad's, cma's advice


def _inner(optimizer):
    return getattr(optimizer, "optim", optimizer)


def _sphere(x, i):
    return float(np.sum((x - 0.5) ** 2))


def _candidates(method: str, reuse: bool, evaluations: int = 2500, dim: int = 2,
                direct: bool = False, replica: bool = False, batch: int = 1, loss=_sphere):
    """Every candidate nevergrad asks (``batch`` per ask and tell) of ``loss`` in the unit box,
    and how many cma strategies it made (the first one and one per restart); ``direct``:
    asking and telling the optimizer :func:`driven` returns; ``replica``: that one
    replicated on cma, as the plugin does."""
    parametrization = ng.p.Array(init=np.full(dim, 0.3), lower=0.0, upper=1.0)
    parametrization.random_state = np.random.RandomState(7)
    optimizer = ng.optimizers.registry[method](parametrization=parametrization,
                                               budget=evaluations, num_workers=batch)
    if reuse:
        skip_repeated_bounds_check(optimizer)
    if direct:
        optimizer = driven(optimizer)
    if replica:
        optimizer = replicated(optimizer)
        assert isinstance(optimizer, ReplicatedCMA)
    asked, strategies, last = [], 0, None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(evaluations // batch):
            candidates = [optimizer.ask() for _k in range(batch)]
            for candidate in candidates:
                x = np.array(candidate.value)
                asked.append(x)
                optimizer.tell(candidate, loss(x, len(asked)))
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


def _awkward(x, i):
    """A loss that is sometimes infinite or nan (nevergrad clips both) and has its optimum in
    a corner (candidates bounce off the walls)."""
    return float("inf") if i % 7 == 0 else float("nan") if i % 11 == 0 else \
        float(np.sum((x - 0.97) ** 2))


@pytest.mark.parametrize(("method", "dim", "batch", "loss"), [
    ("CMA", 2, 1, _sphere),     # restarts (a sphere converges and cma stops)
    ("CMA", 20, 1, _awkward),   # 18 parameters or more: nevergrad's smaller first step
    ("CMA", 4, 6, _awkward),    # batch=ps: a population per ask and tell
    ("OldCMA", 3, 1, _sphere),  # another CMA of nevergrad's, not diagonal nor elitist
    ("SDiagonalCMA", 5, 1, _awkward),  # its step divided by 1000 (nevergrad's ``zero``)
    ("CMApara", 5, 1, _awkward),  # a population 8 ln(D) + 4
])
def test_the_replica_asks_what_nevergrad_asks(method, dim, batch, loss):
    evaluations = 2500 if dim == 2 else 600
    before, made_before = _candidates(method, reuse=False, dim=dim, batch=batch, loss=loss,
                                      evaluations=evaluations)
    after, _ = _candidates(method, reuse=True, dim=dim, direct=True, replica=True,
                           batch=batch, loss=loss, evaluations=evaluations)
    if dim == 2:
        assert made_before >= 2
    np.testing.assert_array_equal(after, before)


def test_the_replica_runs_only_where_it_was_checked(monkeypatch):
    """Another nevergrad version, another method, another box, an optimizer already asked:
    nevergrad itself runs (the test above then no longer covers it)."""
    def selected(method="CMA", lower=0.0, upper=1.0, dim=3):
        parametrization = ng.p.Array(init=np.full(dim, 0.3 * upper), lower=lower, upper=upper)
        return driven(ng.optimizers.registry[method](parametrization=parametrization,
                                                     budget=50, num_workers=1))

    assert why_not(selected()) is None
    assert "not nevergrad's CMA" in why_not(selected("TwoPointsDE"))
    assert "unit box" in why_not(selected(upper=2.0))
    assert "one parameter" in why_not(ng.optimizers.registry["OldCMA"](
        parametrization=ng.p.Array(init=[0.3], lower=0.0, upper=1.0), budget=50))
    asked = selected()
    asked.tell(asked.ask(), 1.0)
    assert "already asked" in why_not(asked) and replicated(asked) is asked
    monkeypatch.setattr(ng, "__version__", "1.1.0")
    assert "1.1.0" in why_not(selected())
    assert not isinstance(replicated(selected()), ReplicatedCMA)


def test_the_checked_version_is_the_installed_one():
    """When nevergrad moves past the checked versions, the plugin runs nevergrad itself
    (slower, still right): this fails then, so that the replica is checked on the new one."""
    assert ng.__version__ in nevergrad_replica.CHECKED_VERSIONS


def test_driven_is_the_selected_optimizer_for_the_wrapper_only():
    parametrization = ng.p.Array(init=np.full(3, 0.3), lower=0.0, upper=1.0)
    wrapper = ng.optimizers.registry["CMA"](parametrization=parametrization, budget=20,
                                            num_workers=1)
    assert driven(wrapper) is wrapper.optim and isinstance(driven(wrapper), cma_class())
    plain = ng.optimizers.registry["TwoPointsDE"](parametrization=parametrization, budget=20,
                                                  num_workers=1)
    assert driven(plain) is plain


def test_in_effect_for_the_plugins_default(registry):
    """The plugin's default (``CMA``) runs the replica; a nevergrad where it cannot, the
    reusing class: if a nevergrad upgrade moves ``_CMA``, ``_es`` or ``_config``, this fails
    (the plugin then still runs, without them)."""
    assert cma_class() is not None
    problem = build_problem(registry, {"name": "functions", "function": "sphere", "dim": 3})
    cls, params = optimizer_params(registry, {"name": "nevergrad", "budget": 50})
    optimizer = cls(params, problem.bounds, run_rng(1, 0))
    optimizer.ask()
    assert isinstance(optimizer._ng, ReplicatedCMA)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(nevergrad_opt, "replicated", lambda o: o)
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

    built = once()
    monkeypatch.setattr(nevergrad_opt, "skip_repeated_bounds_check", lambda o: o)
    monkeypatch.setattr(nevergrad_opt, "driven", lambda o: o)
    monkeypatch.setattr(nevergrad_opt, "replicated", lambda o: o)
    plain = once()
    assert built.evaluations == plain.evaluations == 900
    assert built.batches == 900
    np.testing.assert_array_equal(built.trace_best, plain.trace_best)
    np.testing.assert_array_equal(built.x_best, plain.x_best)
    assert nevergrad_cma._reusing.cache_info().currsize >= 1
