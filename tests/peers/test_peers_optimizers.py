"""scipy_de, lsq and de_lsq as optimizers: they beat random search on the sphere, scipy_de
with rand1bin is statistically indistinguishable from DE1, budgets and keys."""

from __future__ import annotations

import numpy as np
import pytest
from peers_helpers import loop_threads
from scipy.stats import mannwhitneyu

from vpid_bench.api import ConfigError
from vpid_bench.build import build_problem, optimizer_params
from vpid_bench.runner import run

PS, ITERATIONS = 10, 10
BUDGET = PS * (ITERATIONS + 1)


def _best(registry, name, seed, function="sphere", dim=5, ps=PS, iterations=ITERATIONS,
          budget=None, **keys):
    problem = build_problem(registry, {"name": "functions", "function": function, "dim": dim,
                                       "ps": ps, "iterations": iterations})
    cls, params = optimizer_params(registry, {"name": name, "ps": ps,
                                              "iterations": iterations, **keys})
    opt = cls(params, problem.bounds, np.random.default_rng(seed))
    return run(problem, opt, budget or ps * (iterations + 1))


@pytest.mark.parametrize("name", ["scipy_de", "lsq", "de_lsq"])
def test_beats_random_search_on_the_sphere(registry, name):
    seeds = range(6)
    keys = {"popsize": "ps"} if name == "scipy_de" else {}
    mine = [_best(registry, name, s, **keys).f_best for s in seeds]
    rand = [_best(registry, "random", s).f_best for s in seeds]
    assert np.median(mine) < 0.5 * np.median(rand)
    assert mannwhitneyu(mine, rand, alternative="less").pvalue < 0.01
    assert loop_threads() == []


def test_least_squares_solves_the_sphere(registry):
    for seed in range(3):
        assert _best(registry, "lsq", seed).f_best < 1e-16  # a linear residual: one step


def test_scipy_de_rand1bin_and_de1_are_indistinguishable(registry):
    """20 seeds on Rastrigin (5-D), ps 20, 30 generations, both with F = 0.6, CR = 0.9 and
    reinitialisation outside the box. The same test tells both apart from random search,
    so it has the power to see a difference."""
    keys = {"function": "rastrigin", "ps": 20, "iterations": 30}
    scipy_de = [_best(registry, "scipy_de", s, strategy="rand1bin", F=0.6, F_max=None,
                      CR=0.9, popsize="ps", **keys).f_best for s in range(20)]
    de1 = [_best(registry, "de1", s, **keys).f_best for s in range(20)]
    rand = [_best(registry, "random", s, **keys).f_best for s in range(20)]
    assert mannwhitneyu(scipy_de, de1).pvalue > 0.05
    assert mannwhitneyu(scipy_de, rand).pvalue < 0.001
    assert mannwhitneyu(de1, rand).pvalue < 0.001


def test_scipy_de_uses_the_protocol_budget_one_generation_per_batch(registry):
    result = _best(registry, "scipy_de", 0, budget=10 * BUDGET, popsize="ps")
    assert result.stopped_by == "optimizer" and result.evaluations == BUDGET
    assert np.diff([0, *result.trace_evaluations]).tolist() == [PS] * (ITERATIONS + 1)
    cut = _best(registry, "scipy_de", 0, budget=BUDGET - 3, popsize="ps")  # inside scipy
    assert cut.evaluations == BUDGET - 3 and cut.stopped_by == "budget"
    assert loop_threads() == []


def test_scipy_de_at_its_library_population_runs_to_the_budget(registry):
    """popsize=library (the default): scipy's 15 D members per generation (75 in 5-D); the
    run's budget, not the protocol's generations, ends it."""
    result = _best(registry, "scipy_de", 0, budget=1000)
    steps = np.diff([0, *result.trace_evaluations]).tolist()
    assert steps[:-1] == [75] * (len(steps) - 1) and result.evaluations == 1000
    assert result.stopped_by == "budget"
    rand = [_best(registry, "random", s, budget=1000).f_best for s in range(6)]
    mine = [_best(registry, "scipy_de", s, budget=1000).f_best for s in range(6)]
    assert mannwhitneyu(mine, rand, alternative="less").pvalue < 0.01


def test_de_lsq_runs_de4_for_its_fraction_then_least_squares(registry):
    result = _best(registry, "de_lsq", 0, budget=BUDGET, fraction=0.5)
    steps = np.diff([0, *result.trace_evaluations]).tolist()
    # 0.5 * 11 generations -> the initial population and 5 generations of DE4 (10 rows each)
    assert steps[:6] == [PS] * 6
    assert steps[6] == 6  # then one Jacobian batch of n + 1 = 6 rows from DE4's best
    assert result.f_best < 1e-16


@pytest.mark.parametrize(("name", "key", "value"), [
    ("scipy_de", "strategy", "rand1"),
    ("scipy_de", "F_max", 0.1),
    ("scipy_de", "CR", 1.5),
    ("lsq", "scaling", "logarithmic"),
    ("lsq", "inner", 0),
    ("de_lsq", "fraction", 1.5),
])
def test_bad_keys_name_the_key(registry, name, key, value):
    with pytest.raises(ConfigError, match=f"optimizer.{key}"):
        optimizer_params(registry, {"name": name, "ps": PS, "iterations": ITERATIONS,
                                    key: value})


def test_log_scaling_refused_on_a_box_through_zero(registry):
    problem = build_problem(registry, {"name": "functions", "function": "sphere", "dim": 3})
    cls, params = optimizer_params(registry, {"name": "lsq", "scaling": "log"})
    with pytest.raises(ConfigError, match="optimizer.scaling"):
        cls(params, problem.bounds, np.random.default_rng(0))


def test_every_peer_names_the_library_and_version_that_ran(registry):
    """Each peer's provenance (copied into every record's ``optimizer.plugin``) names the
    library that runs its search and that library's installed version."""
    import importlib.metadata

    libraries = {"scipy_de": "scipy", "lsq": "scipy", "de_lsq": "scipy", "cmaes": "cma",
                 "nevergrad": "nevergrad"}
    for name, dist in libraries.items():
        if name not in registry.optimizers:  # cmaes, nevergrad: the peers extra
            continue
        assert registry.provenance("optimizer", name)["library"] == {
            "name": dist, "version": importlib.metadata.version(dist)}
    assert "library" not in registry.provenance("optimizer", "de4")  # written here


def test_no_peer_reaches_into_a_library_s_internals():
    """Peers run as their users run them: no module of the plugins imports a private module
    or name of nevergrad or cma (``nevergrad.optimization``, ``optimizerlib``, ``_CMA``)."""
    from pathlib import Path

    import vpid_peers

    root = Path(vpid_peers.__file__).parent
    for path in root.rglob("*.py"):
        text = path.read_text()
        for private in ("nevergrad.optimization", "optimizerlib", "_CMA", "cma.evolution_"):
            assert private not in text, f"{path.name} uses {private}"
