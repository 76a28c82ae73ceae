"""``optimizer=nevergrad``: any optimizer of nevergrad's registry, ``optimizer.method=<name>``
(an unknown name refused in one line listing the closest), built on the first ``ask`` with
the run's budget (a method that fails fails its run, not the job), searching the unit cube
from a uniform random start (nevergrad's default is the centre: the vehicle's truth) with a
``RandomState`` seeded from the run's generator, through nevergrad's public API only
(docs/optimizers.md, "optimizer=nevergrad"). ``import nevergrad`` (about 3 s) happens when
the parameters are checked, never when the plugin is registered.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from vpid_bench import Bounds, ConfigError, Optimizer, OptimizerParams

from .coordinates import to_physical

#: CMA, what NGOpt (nevergrad's recommendation) picks at the paper's protocol (identical runs);
#: NGOpt itself fails at small budgets in nevergrad 1.0.12 on numpy 2.x (a TypeError in its
#: metamodel, e.g. 4 parameters and 120 evaluations).
DEFAULT_METHOD = "CMA"


def check_method(method: str) -> None:
    """Refuse a ``method`` not in nevergrad's registry (imported here: about 3 s the first
    time), naming the 5 closest (difflib)."""
    try:
        import nevergrad as ng
    except ImportError as exc:  # pragma: no cover - the plugin registers only when it is found
        raise ConfigError("optimizer", "nevergrad", "install the extra: "
                          "pip install 'vpid-bench[peers]'") from exc
    names = list(ng.optimizers.registry)
    if method in names:
        return
    by_lower: dict[str, str] = {}
    for candidate in sorted(names):
        by_lower.setdefault(candidate.lower(), candidate)
    near = [by_lower[m] for m in difflib.get_close_matches(method.lower(), list(by_lower),
                                                           n=5, cutoff=0.6)]
    hint = ("closest: " + ", ".join(near)) if near else "no close name"
    raise ConfigError("optimizer.method", method,
                      f"a name in nevergrad's optimizer registry ({len(names)} names; {hint})")


@dataclass(frozen=True)
class NevergradParams(OptimizerParams):
    """``method``: a name in nevergrad's registry (``NGOpt``, ``CMA``, ...); ``batch``: 1 or ps."""

    method: str = DEFAULT_METHOD
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

    def ask(self) -> np.ndarray:
        if self._ng is None:
            import nevergrad as ng

            parametrization = ng.p.Array(init=self._x0, lower=0.0, upper=1.0)
            parametrization.random_state = np.random.RandomState(self._seed)
            self._ng = ng.optimizers.registry[self.params.method](
                parametrization=parametrization, budget=self.budget,
                num_workers=self.params.workers)
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

    @Optimizer.done.getter
    def done(self) -> bool:
        """True once the run's budget has been told (or ``self.done = True``)."""
        return self._done or self._told >= self.budget
