"""``optimizer=nevergrad``: any optimizer of nevergrad's registry, ``optimizer.method=<name>``.

* **Method**: a name of ``nevergrad.optimizers.registry`` (542 names in nevergrad 1.0.12).
  An unknown name is refused in one line (:class:`ConfigError`, key ``optimizer.method``)
  that lists the closest registered names.
* **Batches** (``batch``): the nevergrad optimizer is built with the run's ``budget`` (the
  evaluations the run loop allows, ``self.budget``) and ``num_workers`` = 1, nevergrad's
  default (``library``: one candidate per ask and tell), or ``ps`` (``batch=ps``: each ``ask``
  asks nevergrad for ``ps`` candidates, each ``tell`` tells all of them; the default before
  round three).
  The optimizer is ``done`` once it has told that budget.
* **Coordinates**: an ``ng.p.Array`` bounded to the unit cube (nevergrad's own bound handling),
  mapped to physical units on ``ask`` (:mod:`vpid_peers.unit_box`). Its initial value, around
  which methods such as CMA and NGOpt start, is drawn uniformly in the cube by the run's
  generator, not nevergrad's default (the centre: on the vehicle problem, the true parameters).
* **Randomness**: nevergrad draws from its parametrization's ``random_state``; it is a
  ``numpy.random.RandomState`` seeded with an integer drawn from the run's generator.
* **Failures**: nevergrad is built on the first ``ask``, not in the constructor, so a method
  that fails (at construction, e.g. one that cannot run ``ps`` workers, or during the run)
  raises inside the run loop, and the job records that run as failed and goes on.
* **As its users run it**: the registry's optimizer is asked and told through nevergrad's
  public API only, nothing of nevergrad's internals patched or bypassed, so a run costs what
  it costs a user of nevergrad (its CMA: about 0.8 ms per candidate of its own, most of it
  in nevergrad's parameter machinery; ``benchmarks/bench_nevergrad_cma.py`` measures it and
  docs/optimizers.md states it). Every record names nevergrad's version
  (``optimizer.plugin.library``).
* **Cost**: ``import nevergrad`` takes about 3 s; it happens when the parameters are checked
  (the registry is needed to check the name), never when the plugin is registered.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, Optimizer, OptimizerParams

from .unit_box import to_physical

#: The default method: CMA, the method NGOpt (nevergrad's own recommendation) picks at the
#: paper's protocol (9 parameters, 1020 evaluations, 20 workers: the runs are identical).
#: NGOpt itself is not the default: in nevergrad 1.0.12 on numpy 2.x it fails at small budgets
#: (a TypeError inside its metamodel, e.g. 4 parameters and 120 evaluations, or the vehicle
#: with 10 iterations).
DEFAULT_METHOD = "CMA"


def nevergrad_registry() -> Any:
    """nevergrad's optimizer registry (imports nevergrad: about 3 s the first time)."""
    try:
        import nevergrad as ng
    except ImportError as exc:  # pragma: no cover - the plugin registers only when it is found
        raise ConfigError("optimizer", "nevergrad", "install the extra: "
                          "pip install 'vpid-bench[peers]'") from exc
    return ng.optimizers.registry


def close_names(name: str, names: list[str], n: int = 5) -> list[str]:
    """Up to ``n`` of ``names`` closest to ``name``, ignoring case (difflib's ratio)."""
    by_lower: dict[str, str] = {}
    for candidate in sorted(names):
        by_lower.setdefault(candidate.lower(), candidate)
    matches = difflib.get_close_matches(name.lower(), list(by_lower), n=n, cutoff=0.6)
    return [by_lower[m] for m in matches]


def check_method(method: str) -> None:
    """Raise :class:`ConfigError` (one line, closest names listed) unless ``method`` is in
    nevergrad's registry."""
    names = list(nevergrad_registry())
    if method in names:
        return
    near = close_names(method, names)
    hint = ("closest: " + ", ".join(near)) if near else "no close name"
    raise ConfigError("optimizer.method", method,
                      f"a name in nevergrad's optimizer registry ({len(names)} names; {hint})")


@dataclass(frozen=True)
class NevergradParams(OptimizerParams):
    """``method``: the name of a nevergrad optimizer, as in ``nevergrad.optimizers.registry``
    (case matters: ``NGOpt``, ``TwoPointsDE``, ``CMA``, ``PSO``, ``DE``, ``OnePlusOne``, ...)."""

    method: str = DEFAULT_METHOD
    #: candidates per batch (nevergrad's ``num_workers``): ``library`` is nevergrad's default,
    #: 1 (one candidate asked, evaluated and told at a time); ``ps`` the protocol's
    #: population (the default before round three)
    batch: Literal["library", "ps"] = "library"

    def __post_init__(self) -> None:
        check_method(self.method)

    @property
    def workers(self) -> int:
        """nevergrad's ``num_workers``: the candidates of one batch."""
        return 1 if self.batch == "library" else self.ps


class NevergradOptimizer(Optimizer):
    """A nevergrad optimizer asked for ``params.workers`` candidates per batch."""

    Params = NevergradParams
    library = "nevergrad"

    def __init__(self, params: NevergradParams, bounds: Bounds, rng: np.random.Generator) -> None:
        super().__init__(params, bounds, rng)
        self._x0 = rng.random(bounds.dim)
        self._seed = int(rng.integers(2**32))
        self._ng: Any = None
        self._pending: list[Any] | None = None
        self._told = 0
        self._stopped = False

    def _build(self) -> Any:
        import nevergrad as ng

        parametrization = ng.p.Array(init=self._x0, lower=0.0, upper=1.0)
        parametrization.random_state = np.random.RandomState(self._seed)
        cls = ng.optimizers.registry[self.params.method]
        return cls(parametrization=parametrization, budget=self.budget,
                   num_workers=self.params.workers)

    def ask(self) -> np.ndarray:
        if self._ng is None:
            self._ng = self._build()
        if self._pending is None:
            self._pending = [self._ng.ask() for _ in range(self.params.workers)]
        U = np.array([candidate.value for candidate in self._pending], dtype=float)
        return to_physical(U, self.bounds)

    def tell(self, X: np.ndarray, f: np.ndarray) -> None:
        if self._pending is None or len(X) != len(self._pending):
            raise ValueError("tell() must follow ask() with the whole population it returned")
        for candidate, value in zip(self._pending, np.asarray(f, dtype=float).reshape(-1)):
            self._ng.tell(candidate, float(value))  # inf and nan are clipped at 5e20
        self._told += len(self._pending)
        self._pending = None

    # Settable (``self.done = True``), like the core's ``done`` is about to become; a
    # read-only property here would break a base class that assigns ``self.done``.
    @property
    def done(self) -> bool:
        """True once the run's budget (``self.budget``) has been told."""
        return self._stopped or self._told >= self.budget

    @done.setter
    def done(self, value: bool) -> None:
        self._stopped = bool(value)
