"""DE1-DE8 as optimizers: defaults (Table I), validation, schedule and budget, factor draws."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from vpid_de.variants import STRATEGIES

from vpid_bench.api import Bounds, ConfigError
from vpid_bench.params import build_dataclass

BOX = Bounds(np.array([-1.0, 0.0, 10.0]), np.array([1.0, 5.0, 20.0]), ("a", "b", "c"))

TABLE_I = {
    "de1": {"F": 0.6, "CR": 0.9},
    "de2": {"F": 0.6, "CR": 0.9},
    "de3": {"F": 0.6, "CR": 0.9},
    "de4": {"F": 0.6, "CR": 0.9},
    "de5": {"F": 0.6, "CR": 0.9},
    "de6": {"K": 0.5, "CR": 0.8, "F_min": -2.0, "F_max": 2.0, "draw": "generation"},
    "de7": {"CR": 0.9, "R_min": 0.5, "R_max": 1.0, "draw": "generation"},
    "de8": {"CR": 0.9, "R_max": 1.2, "R_min": 0.4, "eq15": "das"},
}
MIN_PS = {"de1": 4, "de2": 5, "de3": 3, "de4": 3, "de5": 6, "de6": 4, "de7": 4, "de8": 4}


def sphere(X):
    return np.sum(X * X, axis=1)


def make(name, seed=0, **kw):
    cls = STRATEGIES[name]
    return cls(build_dataclass(cls.Params, kw, prefix="optimizer"), BOX,
               np.random.default_rng(seed))


def drive(opt, f=sphere, max_batches=1000):
    """Run an ask/tell loop until done; return the list of asked batches."""
    batches = []
    while not opt.done and len(batches) < max_batches:
        X = opt.ask()
        batches.append(X)
        opt.tell(X, f(X))
    return batches


@pytest.mark.parametrize("name", sorted(TABLE_I))
def test_defaults_are_table_one(name):
    params = STRATEGIES[name].Params()
    plain = dataclasses.asdict(params)
    for key, value in TABLE_I[name].items():
        assert plain[key] == value, (name, key)
    assert plain["bounds"] == "reinit"


def test_parameters_belong_to_their_variant():
    assert build_dataclass(STRATEGIES["de6"].Params, {"K": 0.4}).K == 0.4
    with pytest.raises(ConfigError, match="optimizer.K"):
        build_dataclass(STRATEGIES["de1"].Params, {"K": 0.4}, prefix="optimizer")
    assert build_dataclass(STRATEGIES["de1"].Params, {"F": 0.8}).F == 0.8


@pytest.mark.parametrize(
    "name,key,value",
    [("de1", "bounds", "wrap"), ("de1", "CR", 1.5), ("de2", "F", 0.0), ("de6", "draw", "run"),
     ("de7", "draw", "x"), ("de8", "eq15", "paper"), ("de7", "R_max", 0.1)],
)
def test_bad_choices_name_the_key(name, key, value):
    with pytest.raises(ConfigError, match=f"optimizer.{key}"):
        build_dataclass(STRATEGIES[name].Params, {key: value}, prefix="optimizer")


@pytest.mark.parametrize(
    "name,key,listed",
    [("de1", "bounds", "'reinit', 'clip', 'reflect', 'midpoint'"),
     ("de6", "draw", "'generation', 'vector'"), ("de7", "draw", "'generation', 'vector'"),
     ("de8", "eq15", "'das', 'printed'")],
)
def test_choice_keys_are_literals_that_list_their_choices(name, key, listed):
    """The params module (and so the pre-flight) checks choice keys from their Literal type;
    the dataclasses carry no hand-written check."""
    with pytest.raises(ConfigError, match=f"optimizer.{key}='x' is not allowed: one of {listed}"):
        build_dataclass(STRATEGIES[name].Params, {key: "x"}, prefix="optimizer")


@pytest.mark.parametrize("name", sorted(MIN_PS))
def test_population_size_minimum_per_strategy(name):
    n = MIN_PS[name]
    make(name, ps=n, iterations=2)  # the smallest allowed population works
    with pytest.raises(ConfigError, match=f"problem.ps.*at least {n} for {name}"):
        make(name, ps=n - 1, iterations=2)


@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_budget_schedule_and_box(name):
    opt = make(name, ps=7, iterations=5)
    batches = drive(opt)
    assert len(batches) == 6  # initial population + 5 generations
    assert sum(len(b) for b in batches) == 7 * (5 + 1)
    for b in batches:
        assert b.shape == (7, 3)
        assert np.all(BOX.contains(b))
    assert opt.done


def test_generational_update_and_greedy_selection():
    """Trials of generation k come only from population k; a member is replaced only by its
    own, strictly better trial."""
    opt = make("de4", ps=6, iterations=3, seed=11)
    X0 = opt.ask()
    f0 = sphere(X0)
    opt.tell(X0, f0)
    U = opt.ask()
    fU = sphere(U)
    np.testing.assert_array_equal(opt.ask(), U)  # asking twice gives the same pending batch
    opt.tell(U, fU)
    better = fU < f0
    np.testing.assert_array_equal(opt.population[better], U[better])
    np.testing.assert_array_equal(opt.population[~better], X0[~better])
    np.testing.assert_array_equal(opt.fitness, np.minimum(f0, fU))


def test_trial_of_best1_uses_best_of_current_generation():
    """With CR = 1 and clip, DE3's trial of row i is exactly x_best + F (x_r1 - x_r2) for some
    pair of distinct others; check the reconstructed base vector is the current best."""
    opt = make("de3", ps=5, iterations=1, CR=1.0, bounds="clip", F=1e-9, seed=3)
    X0 = opt.ask()
    f0 = sphere(X0)
    opt.tell(X0, f0)
    U = opt.ask()
    # F tiny: every trial sits (within 1e-8 of the box scale) on the best vector
    np.testing.assert_allclose(U, np.broadcast_to(X0[np.argmin(f0)], U.shape), atol=1e-7)


class _Recorder:
    """Wraps ``opt.factors`` to record the factors each generation used."""

    def __init__(self, opt):
        self.calls = []
        factors = opt.factors

        def spy():
            kw = factors()
            self.calls.append(kw)
            return kw

        opt.factors = spy


@pytest.mark.parametrize("name,key,low,high", [("de6", "F", -2.0, 2.0), ("de7", "F", 0.5, 1.0)])
def test_random_factor_per_generation_or_per_vector(name, key, low, high):
    opt = make(name, ps=8, iterations=30)
    rec = _Recorder(opt)
    drive(opt)
    values = [c[key] for c in rec.calls]
    assert len(values) == 30 and all(isinstance(v, float) for v in values)
    assert all(low <= v <= high for v in values) and len(set(values)) == 30
    opt = make(name, ps=8, iterations=4, draw="vector")
    rec = _Recorder(opt)
    drive(opt)
    for v in (c[key] for c in rec.calls):
        assert v.shape == (8, 1) and np.all((v >= low) & (v <= high))
        assert len(np.unique(v)) == 8


def test_de6_passes_k():
    opt = make("de6", ps=5, iterations=2, K=0.3)
    rec = _Recorder(opt)
    drive(opt)
    assert [c["K"] for c in rec.calls] == [0.3, 0.3]


@pytest.mark.parametrize("form,first,last", [("das", 1.2, 0.4 + 0.8 / 4), ("printed", 0.8, 0.2)])
def test_de8_schedule(form, first, last):
    opt = make("de8", ps=5, iterations=4, eq15=form)
    rec = _Recorder(opt)
    drive(opt)
    values = [c["F"] for c in rec.calls]
    assert values[0] == pytest.approx(first) and values[-1] == pytest.approx(last)
    assert np.all(np.diff(values) < 0)


def test_zero_iterations_is_only_the_initial_population():
    opt = make("de1", ps=5, iterations=0)
    assert len(drive(opt)) == 1


def test_tell_without_matching_ask_is_refused():
    opt = make("de1", ps=5, iterations=2)
    with pytest.raises(ValueError):
        opt.tell(np.zeros((5, 3)), np.zeros(5))


@pytest.mark.parametrize("bounds", ["reinit", "clip", "reflect", "midpoint"])
@pytest.mark.parametrize("name", sorted(STRATEGIES))
def test_numba_engine_matches_numpy_reference_bit_for_bit(name, bounds):
    """Whole runs with the fused numba generation and with the numpy kernels are identical
    (same seed, same uniforms, same floating-point operation order)."""
    extra = {"draw": "vector"} if name in ("de6", "de7") else {}
    runs = {}
    for engine in ("numba", "numpy"):
        opt = make(name, seed=9, ps=8, iterations=6, bounds=bounds, **extra)
        opt.engine = engine
        # optimum at a corner of the box, so the bounds rules fire often
        batches = drive(opt, f=lambda X: np.sum((X - BOX.upper) ** 2, axis=1))
        runs[engine] = np.vstack(batches)
    np.testing.assert_array_equal(runs["numba"], runs["numpy"])
